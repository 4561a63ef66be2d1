#include "unix_socket.hpp"

#include <sys/socket.h>

#include <array>

namespace motion::simbus::detail {

std::error_code send_message(int fd, const wire::Message& message) {
  std::array<std::uint8_t, wire::kMaxMessageSize> buffer{};
  const std::size_t size = wire::encode(message, buffer);
  if (size == 0) return std::make_error_code(std::errc::invalid_argument);
  if (::send(fd, buffer.data(), size, MSG_DONTWAIT | MSG_NOSIGNAL) < 0) return last_error();
  return {};
}

}  // namespace motion::simbus::detail
