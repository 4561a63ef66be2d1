// The simulated serial line of a `simserial:` bus, motion-sim's side, as a Unix-domain socket
// (SimLinkKind::kSocket, see sim_link.hpp): a SOCK_SEQPACKET socket listening at the link path
// (<sim_runtime_dir>/<bus>.tty). SerialPort::open connects to it when the path is a socket. Every
// connection is on the line: what motion-sim writes goes to all of them (in messages of at most
// kSimLinkMessage bytes), what any of them writes reaches motion-sim with the kernel's stamp of
// its send().
//
// Thread contract: read() and write() may run on two threads at once (one mutex over the
// connections); no call blocks. At most kMaxConnections connections; a further one is closed.
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "motion/core/file_access.hpp"
#include "motion/serial/sim_link.hpp"

namespace motion::serial {

class SocketLink final : public SimLink {
 public:
  static constexpr std::size_t kMaxConnections = 16;

  static std::unique_ptr<SocketLink> create(const std::string& link_path, std::error_code& error,
                                            const FileAccess& access = {});
  ~SocketLink() override;  // closes every connection; removes the socket file if it is still this one's
  SocketLink(const SocketLink&) = delete;
  SocketLink& operator=(const SocketLink&) = delete;

  // An epoll fd over the listening socket and the connections.
  [[nodiscard]] int fd() const override { return epoll_fd_; }
  [[nodiscard]] const std::string& link_path() const override { return link_path_; }
  // Accepts new connections, drops closed ones, and returns one message of a connection.
  std::size_t read(std::span<std::uint8_t> buffer, std::int64_t& sent_wall_ns) override;
  std::error_code write(std::span<const std::uint8_t> bytes) override;
  [[nodiscard]] std::size_t connections() const;

 private:
  SocketLink(int listen_fd, int epoll_fd, std::string link_path, ino_t inode);
  void accept_all();
  void drop(int fd);

  int listen_fd_ = -1;
  int epoll_fd_ = -1;
  std::string link_path_;
  ino_t inode_ = 0;  // of the socket file made: the destructor removes only that one
  mutable std::mutex mutex_;
  std::vector<int> connections_;  // guarded by mutex_
};

}  // namespace motion::serial
