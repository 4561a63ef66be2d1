#include "unix_socket.hpp"

#include <unistd.h>

#include <time.h>

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

void stamp_receptions(int fd) {
  const int on = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on);
}

ssize_t receive_stamped(int fd, std::span<std::uint8_t> buffer, std::int64_t& sent_wall_ns) {
  sent_wall_ns = 0;
  iovec io{buffer.data(), buffer.size()};
  alignas(cmsghdr) std::array<char, CMSG_SPACE(sizeof(timespec))> control{};
  msghdr message{};
  message.msg_iov = &io;
  message.msg_iovlen = 1;
  message.msg_control = control.data();
  message.msg_controllen = control.size();
  const ssize_t n = ::recvmsg(fd, &message, MSG_DONTWAIT);
  if (n < 0) return n;
  for (cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr; c = CMSG_NXTHDR(&message, c)) {
    if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SCM_TIMESTAMPNS) continue;
    timespec stamp{};
    std::memcpy(&stamp, CMSG_DATA(c), sizeof stamp);
    sent_wall_ns = static_cast<std::int64_t>(stamp.tv_sec) * 1'000'000'000LL + stamp.tv_nsec;
  }
  return n;
}

}  // namespace motion::simbus::detail
