#include "motion/serial/serial_port.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <utility>

#include "motion/core/unix_socket.hpp"

namespace motion::serial {
namespace {

std::error_code last_error() { return {errno, std::generic_category()}; }

struct BaudConstant {
  int baud;
  speed_t constant;
};
constexpr std::array kBaudConstants{
    BaudConstant{300, B300},       BaudConstant{600, B600},       BaudConstant{1200, B1200},
    BaudConstant{2400, B2400},     BaudConstant{4800, B4800},     BaudConstant{9600, B9600},
    BaudConstant{19200, B19200},   BaudConstant{38400, B38400},   BaudConstant{57600, B57600},
    BaudConstant{115200, B115200}, BaudConstant{230400, B230400}, BaudConstant{460800, B460800},
    BaudConstant{921600, B921600},
};

}  // namespace

SerialSettings line_settings(int baud, char parity, int stop_bits) {
  SerialSettings s;
  s.baud = baud;
  s.parity = parity == 'E' ? Parity::kEven : parity == 'O' ? Parity::kOdd : Parity::kNone;
  s.stop_bits = stop_bits;
  return s;
}

std::string simserial_link_path(std::string_view runtime_dir, std::string_view bus) {
  std::string path(runtime_dir);
  path += '/';
  path += bus;
  path += ".tty";
  return path;
}

bool termios_speed(int baud, unsigned& speed_constant) {
  for (const auto& entry : kBaudConstants) {
    if (entry.baud == baud) {
      speed_constant = entry.constant;
      return true;
    }
  }
  return false;
}

bool is_pty(int fd) {
  // Unix 98 pty slaves: character devices of majors 136..143 (UNIX98_PTY_SLAVE_MAJOR and the
  // next seven, Documentation/admin-guide/devices.txt).
  constexpr unsigned kFirstPtySlaveMajor = 136;
  constexpr unsigned kLastPtySlaveMajor = 143;
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISCHR(st.st_mode)) return false;
  const unsigned m = major(st.st_rdev);
  return m >= kFirstPtySlaveMajor && m <= kLastPtySlaveMajor;
}

namespace {

// What a port refuses on a tty and a simulated line's socket alike: a baud rate without a termios
// constant, other than 8 data bits, other than 1 or 2 stop bits.
bool supported(const SerialSettings& settings, unsigned& speed) {
  return termios_speed(settings.baud, speed) && settings.data_bits == 8 &&
         (settings.stop_bits == 1 || settings.stop_bits == 2);
}

}  // namespace

std::error_code configure_tty(int fd, const SerialSettings& settings, bool& parity_modelled) {
  parity_modelled = false;
  unsigned speed = 0;
  if (!supported(settings, speed)) return std::make_error_code(std::errc::invalid_argument);
  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) return last_error();
  ::cfmakeraw(&tio);  // no echo, no line editing, no CR/LF translation: binary frames
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS);
  tio.c_cflag |= CS8;
  if (settings.parity != Parity::kNone) tio.c_cflag |= PARENB;
  if (settings.parity == Parity::kOdd) tio.c_cflag |= PARODD;
  if (settings.stop_bits == 2) tio.c_cflag |= CSTOPB;
  tio.c_cc[VMIN] = 0;  // reads return what is there (the fd is non-blocking anyway)
  tio.c_cc[VTIME] = 0;
  if (::cfsetispeed(&tio, speed) != 0 || ::cfsetospeed(&tio, speed) != 0) return last_error();
  if (::tcsetattr(fd, TCSANOW, &tio) != 0) {
    const std::error_code refused = last_error();
    // A pty that refuses PARENB: the parity is modelled (counted in the character time), not set.
    if (refused != std::errc::invalid_argument || settings.parity == Parity::kNone || !is_pty(fd)) return refused;
    tio.c_cflag &= ~static_cast<tcflag_t>(PARENB | PARODD);
    if (::tcsetattr(fd, TCSANOW, &tio) != 0) return last_error();
    parity_modelled = true;
  }
  ::tcflush(fd, TCIOFLUSH);  // drop whatever a previous user left in the buffers
  return {};
}

std::unique_ptr<SerialPort> SerialPort::open(const std::string& path, const SerialSettings& settings,
                                             std::error_code& error) {
  if (struct stat st{}; ::stat(path.c_str(), &st) == 0 && S_ISSOCK(st.st_mode)) {
    // A simulated line's socket: the same settings are refused as on a tty, none is applied.
    unsigned speed = 0;
    if (!supported(settings, speed)) {
      error = std::make_error_code(std::errc::invalid_argument);
      return nullptr;
    }
    const int fd = unix_socket::connect_seqpacket(path, error);
    if (fd < 0) return nullptr;
    return std::unique_ptr<SerialPort>(
        new SerialPort(fd, path, settings, settings.parity != Parity::kNone, /*socket=*/true));
  }
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    error = last_error();
    return nullptr;
  }
  if (!::isatty(fd)) {
    error = std::make_error_code(std::errc::inappropriate_io_control_operation);
    ::close(fd);
    return nullptr;
  }
  bool parity_modelled = false;
  if ((error = configure_tty(fd, settings, parity_modelled))) {
    ::close(fd);
    return nullptr;
  }
  error.clear();
  return std::unique_ptr<SerialPort>(new SerialPort(fd, path, settings, parity_modelled, /*socket=*/false));
}

SerialPort::SerialPort(int fd, std::string path, SerialSettings settings, bool parity_modelled, bool socket)
    : fd_(fd), path_(std::move(path)), settings_(settings), parity_modelled_(parity_modelled), socket_(socket) {}

SerialPort::~SerialPort() {
  if (fd_ >= 0) ::close(fd_);
}

std::size_t SerialPort::read_socket(std::span<std::uint8_t> buffer, std::error_code& error) {
  if (pending_.empty()) {
    std::array<std::uint8_t, kSimLinkMessage> message{};
    const ssize_t n = ::recv(fd_, message.data(), message.size(), MSG_DONTWAIT);
    if (n == 0) error = std::make_error_code(std::errc::io_error);  // motion-sim closed the line
    if (n < 0 && errno != EAGAIN && errno != EINTR) error = last_error();
    if (n <= 0) return 0;
    pending_.assign(message.begin(), message.begin() + n);
  }
  const std::size_t n = std::min(buffer.size(), pending_.size());
  std::copy_n(pending_.begin(), n, buffer.begin());
  pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(n));
  return n;
}

std::size_t SerialPort::read(std::span<std::uint8_t> buffer, std::error_code& error) {
  error.clear();
  if (socket_) return read_socket(buffer, error);
  const ssize_t n = ::read(fd_, buffer.data(), buffer.size());
  if (n > 0) return static_cast<std::size_t>(n);
  if (n == 0) {
    // VMIN = 0: nothing there, or a hung-up line (pty master closed, adapter unplugged), which
    // reads 0 for ever while polling POLLHUP: tell them apart, or the loop would spin.
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 0) == 1 && (p.revents & (POLLHUP | POLLERR | POLLNVAL)) != 0)
      error = std::make_error_code(std::errc::io_error);
    return 0;
  }
  if (errno == EAGAIN || errno == EINTR) return 0;
  error = last_error();
  return 0;
}

std::error_code SerialPort::write(std::span<const std::uint8_t> frame) {
  if (socket_) {
    for (std::size_t at = 0; at < frame.size(); at += kSimLinkMessage) {
      const auto part = frame.subspan(at, std::min(kSimLinkMessage, frame.size() - at));
      const ssize_t n = ::send(fd_, part.data(), part.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
      if (n < 0) return at == 0 ? last_error() : std::make_error_code(std::errc::resource_unavailable_try_again);
    }
    return {};
  }
  const ssize_t n = ::write(fd_, frame.data(), frame.size());
  if (n < 0) return last_error();
  if (static_cast<std::size_t>(n) != frame.size())
    return std::make_error_code(std::errc::resource_unavailable_try_again);
  return {};
}

}  // namespace motion::serial
