#include "motion/core/unix_socket.hpp"

#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>

namespace motion::unix_socket {
namespace {

std::error_code last_error() { return {errno, std::generic_category()}; }

const sockaddr* as_sockaddr(const sockaddr_un& a) {
  // NOLINTNEXTLINE(cppcoreguidelines-pro-type-reinterpret-cast): the sockets API
  return reinterpret_cast<const sockaddr*>(&a);
}

}  // namespace

std::optional<sockaddr_un> address(const std::filesystem::path& path) {
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  const std::string& text = path.native();
  if (text.empty() || text.size() >= sizeof(a.sun_path)) return std::nullopt;
  std::memcpy(a.sun_path, text.c_str(), text.size() + 1);
  return a;
}

int connect_seqpacket(const std::filesystem::path& path, std::error_code& error) {
  const auto a = address(path);
  if (!a) {
    error = std::make_error_code(std::errc::filename_too_long);
    return -1;
  }
  const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    error = last_error();
    return -1;
  }
  if (::connect(fd, as_sockaddr(*a), sizeof(*a)) != 0) {
    error = last_error();
    ::close(fd);
    return -1;
  }
  error.clear();
  return fd;
}

int listen_seqpacket(const std::filesystem::path& path, const FileAccess& access, std::error_code& error) {
  const auto a = address(path);
  if (!a) {
    error = std::make_error_code(std::errc::filename_too_long);
    return -1;
  }
  std::error_code probe;
  if (const int fd = connect_seqpacket(path, probe); fd >= 0) {
    ::close(fd);
    error = std::make_error_code(std::errc::address_in_use);
    return -1;
  }
  if (probe == std::errc::connection_refused) ::unlink(path.c_str());  // left by a dead process
  const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    error = last_error();
    return -1;
  }
  if (::bind(fd, as_sockaddr(*a), sizeof(*a)) != 0) {
    error = last_error();
    ::close(fd);
    return -1;
  }
  error = restrict_access(path.string(), access);
  if (!error && ::listen(fd, 64) != 0) error = last_error();
  if (error) {
    ::close(fd);
    ::unlink(path.c_str());
    return -1;
  }
  return fd;
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

TimePoint sent_time(TimePoint now, std::int64_t sent_wall_ns, Duration longest) {
  if (sent_wall_ns <= 0) return now;
  const std::int64_t wall_now_ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  const auto age = std::clamp<std::int64_t>(wall_now_ns - sent_wall_ns, 0,
                                            std::chrono::duration_cast<std::chrono::nanoseconds>(longest).count());
  return now - std::chrono::duration_cast<Duration>(std::chrono::nanoseconds(age));
}

}  // namespace motion::unix_socket
