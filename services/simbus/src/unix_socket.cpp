#include "unix_socket.hpp"

#include <unistd.h>

#include <array>
#include <cstring>

namespace motion::simbus::detail {

std::optional<sockaddr_un> unix_address(const std::filesystem::path& path) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  const std::string& text = path.native();
  if (text.empty() || text.size() >= sizeof(address.sun_path)) return std::nullopt;
  std::memcpy(address.sun_path, text.c_str(), text.size() + 1);
  return address;
}

int connect_seqpacket(const std::filesystem::path& path, std::error_code& error) {
  const auto address = unix_address(path);
  if (!address) {
    error = std::make_error_code(std::errc::filename_too_long);
    return -1;
  }
  const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    error = last_error();
    return -1;
  }
  // NOLINTNEXTLINE(cppcoreguidelines-pro-type-reinterpret-cast): the sockets API
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&*address), sizeof(*address)) != 0) {
    error = last_error();
    ::close(fd);
    return -1;
  }
  error.clear();
  return fd;
}

std::error_code send_message(int fd, const wire::Message& message) {
  std::array<std::uint8_t, wire::kMaxMessageSize> buffer{};
  const std::size_t size = wire::encode(message, buffer);
  if (size == 0) return std::make_error_code(std::errc::invalid_argument);
  if (::send(fd, buffer.data(), size, MSG_DONTWAIT | MSG_NOSIGNAL) < 0) return last_error();
  return {};
}

}  // namespace motion::simbus::detail
