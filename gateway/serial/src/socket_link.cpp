#include "motion/serial/socket_link.hpp"

#include <sys/epoll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <filesystem>

#include "motion/core/unix_socket.hpp"

namespace motion::serial {
namespace {

std::error_code last_error() { return {errno, std::generic_category()}; }

bool watch(int epoll_fd, int fd) {
  epoll_event event{};
  event.events = EPOLLIN;
  event.data.fd = fd;
  return ::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, fd, &event) == 0;
}

}  // namespace

std::unique_ptr<SocketLink> SocketLink::create(const std::string& link_path, std::error_code& error,
                                               const FileAccess& access) {
  const std::filesystem::path target{link_path};
  if (target.has_parent_path() && (error = make_private_dir(target.parent_path().string(), access))) return nullptr;
  // A pty link of an earlier run (a symlink) is not a socket a live simulator listens on.
  std::error_code ignored;
  if (std::filesystem::is_symlink(target, ignored)) std::filesystem::remove(target, ignored);
  const int listen_fd = unix_socket::listen_seqpacket(target, access, error);
  if (listen_fd < 0) return nullptr;
  struct stat st {};
  const int epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd < 0 || !watch(epoll_fd, listen_fd) || ::stat(link_path.c_str(), &st) != 0) {
    error = last_error();
    if (epoll_fd >= 0) ::close(epoll_fd);
    ::close(listen_fd);
    ::unlink(link_path.c_str());
    return nullptr;
  }
  error.clear();
  return std::unique_ptr<SocketLink>(new SocketLink(listen_fd, epoll_fd, link_path, st.st_ino));
}

SocketLink::SocketLink(int listen_fd, int epoll_fd, std::string link_path, ino_t inode)
    : listen_fd_(listen_fd), epoll_fd_(epoll_fd), link_path_(std::move(link_path)), inode_(inode) {}

SocketLink::~SocketLink() {
  for (const int fd : connections_) ::close(fd);
  struct stat st {};
  if (::stat(link_path_.c_str(), &st) == 0 && st.st_ino == inode_ && S_ISSOCK(st.st_mode)) ::unlink(link_path_.c_str());
  ::close(listen_fd_);
  ::close(epoll_fd_);
}

std::size_t SocketLink::connections() const {
  const std::lock_guard lock(mutex_);
  return connections_.size();
}

void SocketLink::accept_all() {
  for (;;) {
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;  // EAGAIN: none left
    if (connections_.size() >= kMaxConnections || !watch(epoll_fd_, fd)) {
      ::close(fd);
      continue;
    }
    unix_socket::stamp_receptions(fd);
    connections_.push_back(fd);
  }
}

void SocketLink::drop(int fd) {
  ::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr);
  ::close(fd);
  connections_.erase(std::remove(connections_.begin(), connections_.end(), fd), connections_.end());
}

std::size_t SocketLink::read(std::span<std::uint8_t> buffer, std::int64_t& sent_wall_ns) {
  sent_wall_ns = 0;
  const std::lock_guard lock(mutex_);
  std::array<epoll_event, kMaxConnections + 1> events{};
  const int ready = ::epoll_wait(epoll_fd_, events.data(), static_cast<int>(events.size()), 0);
  for (int i = 0; i < ready; ++i) {
    const int fd = events[static_cast<std::size_t>(i)].data.fd;
    if (fd == listen_fd_) {
      accept_all();
      continue;
    }
    const ssize_t n = unix_socket::receive_stamped(fd, buffer, sent_wall_ns);
    if (n > 0) return static_cast<std::size_t>(n);                // the other ready ones stay ready (level-triggered)
    if (n == 0 || (errno != EAGAIN && errno != EINTR)) drop(fd);  // closed by its end
  }
  sent_wall_ns = 0;
  return 0;
}

std::error_code SocketLink::write(std::span<const std::uint8_t> bytes) {
  const std::lock_guard lock(mutex_);
  std::error_code first;
  for (const int fd : connections_) {
    for (std::size_t at = 0; at < bytes.size(); at += kSimLinkMessage) {
      const auto part = bytes.subspan(at, std::min(kSimLinkMessage, bytes.size() - at));
      if (::send(fd, part.data(), part.size(), MSG_DONTWAIT | MSG_NOSIGNAL) < 0) {
        if (!first) first = last_error();  // a closed one is dropped by the next read
        break;
      }
    }
  }
  return first;
}

}  // namespace motion::serial
