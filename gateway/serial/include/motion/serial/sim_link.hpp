// motion-sim's end of a simulated serial line: what the gateway (or a serial tool) opens at
// <sim_runtime_dir>/<bus>.tty (simserial_link_path), and how motion-sim reads and writes it.
// Two kinds (`simulation.serial_link`):
//   pty     a pseudo-terminal pair; the link is a symlink to its slave (PtyLink). The gateway's
//           termios code runs as on a real port and any serial tool (pyserial, pymodbus, minicom)
//           can open the line. The kernel hands each write to the reader through a worker thread
//           of normal priority: the hop is tens of µs on an idle host and milliseconds under
//           real-time load, and motion-sim can only date the bytes by their read.
//   socket  a Unix-domain SOCK_SEQPACKET socket listening at the link (SocketLink); SerialPort
//           connects to it instead of opening a tty. Each message carries the kernel's send stamp,
//           so motion-sim dates the gateway's bytes by the write() that handed them over, as a UART
//           starts sending when its driver is given them; only programs of this project open it.
//
// Thread contract: read() from one thread and write() from another may run at once (the socket
// link locks its connections; a pty's master takes both directions); neither blocks.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <system_error>

#include "motion/core/file_access.hpp"
#include "motion/serial/serial_port.hpp"

namespace motion::serial {

enum class SimLinkKind : std::uint8_t { kPty, kSocket };
[[nodiscard]] std::string_view to_string(SimLinkKind kind);  // "pty", "socket"

class SimLink {
 public:
  virtual ~SimLink() = default;
  // Readable (poll, epoll) when what the other end wrote may be waiting.
  [[nodiscard]] virtual int fd() const = 0;
  [[nodiscard]] virtual const std::string& link_path() const = 0;
  // Takes what the other end wrote: its size (0: nothing waiting now). `sent_wall_ns`: when the
  // writer's write() handed it to the kernel (CLOCK_REALTIME, ns), 0 when the link cannot tell.
  virtual std::size_t read(std::span<std::uint8_t> buffer, std::int64_t& sent_wall_ns) = 0;
  // Hands `bytes` to whoever has the line open (nobody: they are gone, as on an open line).
  virtual std::error_code write(std::span<const std::uint8_t> bytes) = 0;

 protected:
  SimLink() = default;
  SimLink(const SimLink&) = default;
  SimLink& operator=(const SimLink&) = default;
};

// Creates the line's end of `kind` at `link_path` with `settings` (the pty is configured raw with
// them; the socket's messages carry no settings, its users count the parity as a pty's do) and
// `access` (0600, or 0660 with a group: whoever opens it can write to the line). nullptr with
// `error` set. Its folder is made private (make_private_dir).
[[nodiscard]] std::unique_ptr<SimLink> create_sim_link(SimLinkKind kind, const std::string& link_path,
                                                       const SerialSettings& settings, std::error_code& error,
                                                       const FileAccess& access = {});

}  // namespace motion::serial
