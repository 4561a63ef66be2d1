// A serial port for the poll loop: opened non-blocking with termios in raw mode (baud, parity,
// 8 data bits, stop bits: SerialSettings), exposing its fd for EventLoop::watch(). Plain values
// in, no configuration: the callers turn a configured bus into a path and SerialSettings.
//
// Where a bus's port is: `serial:/dev/ttyUSB0` → that device; `simserial:<name>` → the pty that
// motion-sim created for the bus, published as the symlink <sim_runtime_dir>/<bus>.tty
// (simserial_link_path). Both paths are opened the same way: a pty slave is a real tty, so the
// termios settings are exercised in tests too. When motion-sim made the line a Unix socket
// (`simulation.serial_link: socket`, sim_link.hpp), the link path is a socket and the port
// connects to it: no termios, the parity counted as on a pty that refuses it, each write() one
// message that motion-sim dates by its kernel send stamp.
//
// Thread contract: a SerialPort is used from one thread (the loop's). No call blocks: reads and
// writes return what the kernel took at once (EAGAIN is reported as "would block", not waited for).
#pragma once

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace motion::serial {

enum class Parity : std::uint8_t { kNone, kEven, kOdd };

// The largest message on a socket line (sim_link.hpp) in either direction: a frame is at most
// this long, and a SerialPort keeps what a caller's shorter read buffer could not take.
inline constexpr std::size_t kSimLinkMessage = 256;

struct SerialSettings {
  int baud = 115200;
  Parity parity = Parity::kNone;
  int data_bits = 8;  // the project's serial protocols all use 8 data bits
  int stop_bits = 1;  // 1 or 2
  // Bits on the wire per character: start + data + parity + stop.
  [[nodiscard]] int bits_per_character() const { return 1 + data_bits + (parity == Parity::kNone ? 0 : 1) + stop_bits; }
  // Time `bytes` characters take on the wire at this baud rate.
  [[nodiscard]] std::chrono::nanoseconds wire_time(std::size_t bytes) const {
    return std::chrono::nanoseconds(static_cast<std::int64_t>(bytes) * bits_per_character() * 1'000'000'000LL /
                                    std::max(baud, 1));
  }
};

// 8 data bits at `baud` with `parity` in the 8N1 letter notation ('N' none, 'E' even, 'O' odd;
// any other letter: none) and `stop_bits` (1 or 2; SerialPort::open refuses others).
[[nodiscard]] SerialSettings line_settings(int baud, char parity, int stop_bits);

// <runtime_dir>/<bus>.tty: where motion-sim publishes the pty of a simserial bus (runtime_dir: the
// configuration's simulation runtime directory).
[[nodiscard]] std::string simserial_link_path(std::string_view runtime_dir, std::string_view bus);

// The termios speed constant of a baud rate; false when the kernel has no such constant
// (e.g. 14400 and 56000, which the ADAM baud register lists, have none on Linux).
[[nodiscard]] bool termios_speed(int baud, unsigned& speed_constant);

// True when `fd` is the slave side of a Unix 98 pseudo-terminal (/dev/pts/N).
[[nodiscard]] bool is_pty(int fd);

// Applies raw 8-bit settings to an open tty fd (shared by SerialPort and the pty creator). When
// the fd is a pty that refuses the parity (see above), it is configured without PARENB and
// `parity_modelled` is set; a real device that refuses it fails with the kernel's error.
[[nodiscard]] std::error_code configure_tty(int fd, const SerialSettings& settings, bool& parity_modelled);

class SerialPort {
 public:
  // Opens and configures `path`. nullptr with `error` set (ENOENT when a simserial link is not
  // there yet: motion-sim is not running).
  static std::unique_ptr<SerialPort> open(const std::string& path, const SerialSettings& settings,
                                          std::error_code& error);
  ~SerialPort();
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  [[nodiscard]] int fd() const { return fd_; }
  [[nodiscard]] const std::string& path() const { return path_; }
  // The configured settings (with their parity: the character time counts the parity bit).
  [[nodiscard]] const SerialSettings& settings() const { return settings_; }
  // True when the parity is counted but not set on the tty (a pty that refuses PARENB, a socket).
  [[nodiscard]] bool parity_modelled() const { return parity_modelled_; }
  // True when the path was a simulated line's socket rather than a tty.
  [[nodiscard]] bool is_socket() const { return socket_; }

  // Reads what is available into `buffer`. Returns bytes read (0: nothing available right now);
  // `error` set on a real error or a hang-up (EIO; e.g. the pty's master side closed: a hung-up
  // tty reads 0 and polls POLLHUP).
  std::size_t read(std::span<std::uint8_t> buffer, std::error_code& error);
  // Writes the whole frame or reports why not (a frame ≤ 256 bytes always fits the tty buffer of
  // an idle half-duplex line; a partial write is reported as an error, never retried blindly).
  std::error_code write(std::span<const std::uint8_t> frame);

 private:
  SerialPort(int fd, std::string path, SerialSettings settings, bool parity_modelled, bool socket);
  std::size_t read_socket(std::span<std::uint8_t> buffer, std::error_code& error);
  int fd_ = -1;
  std::string path_;
  SerialSettings settings_;
  bool parity_modelled_ = false;
  bool socket_ = false;
  std::vector<std::uint8_t> pending_;  // the rest of a socket message a short read buffer left
};

}  // namespace motion::serial
