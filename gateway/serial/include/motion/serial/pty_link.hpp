// The simulated serial line of a `simserial:` bus, motion-sim's side, as a pty (SimLinkKind::kPty,
// see sim_link.hpp): a pseudo-terminal pair in raw mode whose slave device path is published as a
// symlink (<sim_runtime_dir>/<bus>.tty, see serial_port.hpp). motion-sim reads and writes the
// master fd; the gateway (or any serial tool, e.g. pymodbus/pyserial) opens the link like a real
// port.
//
// The slave fd stays open here for the link's lifetime: without it, a read of the master fails
// with EIO whenever no client has the port open, and poll() would report the master hung up in a
// loop (a busy wait).
//
// Thread contract: one thread; no call blocks (the master fd is non-blocking).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <system_error>

#include "motion/core/file_access.hpp"
#include "motion/serial/serial_port.hpp"
#include "motion/serial/sim_link.hpp"

namespace motion::serial {

class PtyLink final : public SimLink {
 public:
  // Creates the pty, configures it raw with `settings`, restricts its slave device to `access`
  // (0600, or 0660 with a group: whoever opens it can write to the line; openpty leaves it 0620,
  // group tty), and (re)places the symlink atomically (a stale link of a crashed run is replaced).
  static std::unique_ptr<PtyLink> create(const std::string& link_path, const SerialSettings& settings,
                                         std::error_code& error, const FileAccess& access = {});
  ~PtyLink() override;  // closes both fds, removes the link if it still points to this pty
  PtyLink(const PtyLink&) = delete;
  PtyLink& operator=(const PtyLink&) = delete;

  [[nodiscard]] int master_fd() const { return master_; }
  [[nodiscard]] const std::string& slave_path() const { return slave_path_; }  // /dev/pts/N
  [[nodiscard]] const std::string& link_path() const override { return link_path_; }
  // SimLink on the master fd (a pty has no send stamps: `sent_wall_ns` is always 0).
  [[nodiscard]] int fd() const override { return master_; }
  std::size_t read(std::span<std::uint8_t> buffer, std::int64_t& sent_wall_ns) override;
  std::error_code write(std::span<const std::uint8_t> bytes) override;

 private:
  PtyLink(int master, int slave, std::string slave_path, std::string link_path);
  int master_ = -1;
  int slave_ = -1;
  std::string slave_path_;
  std::string link_path_;
};

}  // namespace motion::serial
