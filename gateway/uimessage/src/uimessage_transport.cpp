#include "motion/uimessage/uimessage_transport.hpp"

#include <poll.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <utility>

#include "motion/core/clock.hpp"
#include "motion/uim342/message.hpp"

namespace motion::uimessage {
namespace {

class Category final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "uimessage"; }
  [[nodiscard]] std::string message(int value) const override {
    switch (static_cast<UiMessageErrc>(value)) {
      case UiMessageErrc::kStandardFrame:
        return "11-bit CAN frame: a UIROBOT serial gateway (UIMessage) carries SimpleCAN 3.0 29-bit frames only "
               "(CANopen needs a CAN adapter: socketcan:)";
      case UiMessageErrc::kRemoteFrame: return "remote (RTR) frame: a UIMessage carries SimpleCAN data frames only";
      case UiMessageErrc::kNotSimpleCan:
        return "29-bit frame that is not SimpleCAN 3.0 (reserved identifier bits set): a UIMessage cannot carry it";
      case UiMessageErrc::kForeignProducer:
        return "producer is not the host: a UIMessage has no producer field, the gateway sends as the master (ID 4)";
      case UiMessageErrc::kDisconnected: return "the serial port hung up and cannot be opened again yet";
    }
    return "unknown uimessage error " + std::to_string(value);
  }
};

std::error_code last_error() { return {errno, std::generic_category()}; }

std::error_code watch(int epoll_fd, int fd) {
  epoll_event readable{};
  readable.events = EPOLLIN;
  readable.data.fd = fd;
  if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, fd, &readable) != 0) return last_error();
  return {};
}

// The host's instruction as a UIMessage, or why it cannot be one.
uim342::Result<uim342::UiMessage> to_ui(const can::Frame& frame, std::uint8_t host) {
  if (!frame.extended) return make_error_code(UiMessageErrc::kStandardFrame);
  if (frame.rtr) return make_error_code(UiMessageErrc::kRemoteFrame);
  const auto message = uim342::decode_can(frame);
  if (!message) return make_error_code(UiMessageErrc::kNotSimpleCan);
  const auto ui = uim342::instruction_to_ui(*message, host);
  if (!ui) return make_error_code(UiMessageErrc::kForeignProducer);
  return *ui;
}

}  // namespace

const std::error_category& uimessage_category() {
  static const Category category;
  return category;
}

std::error_code make_error_code(UiMessageErrc error) { return {static_cast<int>(error), uimessage_category()}; }

UiMessageOptions options_from(const config::Bus& bus) {
  UiMessageOptions options;
  options.crc = bus.uimessage_crc == config::UiMessageCrc::kIdToAux ? uim342::CrcCoverage::kIdToAux
                                                                    : uim342::CrcCoverage::kStartToAux;
  options.detect_crc = bus.uimessage_crc == config::UiMessageCrc::kDetect;
  if (bus.uimessage_crc_strict) {
    options.accept = options.crc == uim342::CrcCoverage::kIdToAux ? uim342::CrcAcceptance::kIdToAux
                                                                  : uim342::CrcAcceptance::kStartToAux;
  }
  return options;
}

UiMessageTransport::UiMessageTransport(std::string device, const serial::SerialSettings& settings,
                                       UiMessageOptions options)
    : device_(std::move(device)),
      settings_(settings),
      options_(options),
      stream_(options.accept),
      crc_(options.crc, options.detect_crc) {}

std::unique_ptr<UiMessageTransport> UiMessageTransport::open(std::string device, const serial::SerialSettings& settings,
                                                             UiMessageOptions options, std::error_code& error) {
  std::unique_ptr<UiMessageTransport> transport(new UiMessageTransport(std::move(device), settings, options));
  transport->epoll_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
  if (transport->epoll_fd_ < 0) {
    error = last_error();
    return nullptr;
  }
  transport->echo_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (transport->echo_fd_ < 0) {
    error = last_error();
    return nullptr;
  }
  if ((error = watch(transport->epoll_fd_, transport->echo_fd_))) return nullptr;
  if ((error = transport->open_port())) return nullptr;
  return transport;
}

UiMessageTransport::~UiMessageTransport() {
  port_.reset();
  for (const int fd : {echo_fd_, epoll_fd_}) {
    if (fd >= 0) ::close(fd);
  }
}

std::error_code UiMessageTransport::open_port() {
  last_open_attempt_ = std::chrono::steady_clock::now();
  std::error_code error;
  auto port = serial::SerialPort::open(device_, settings_, error);
  if (!port) return error;
  if ((error = watch(epoll_fd_, port->fd()))) return error;
  port_ = std::move(port);
  stream_.clear();  // bytes of a previous connection cannot complete a frame of this one
  enter_state(can::BusState::kErrorActive, "port open");
  return {};
}

void UiMessageTransport::close_port(const std::string& why) {
  // Explicitly: a forked child that still holds the fd would keep it in the set.
  ::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, port_->fd(), nullptr);
  port_.reset();
  ++counters_.disconnects;
  enter_state(can::BusState::kDisconnected, why);
}

// At most once per reopen_interval: a missing device costs one failed open(), not one per send.
bool UiMessageTransport::try_reopen() {
  if (std::chrono::steady_clock::now() - last_open_attempt_ < options_.reopen_interval) return false;
  if (open_port()) return false;
  ++counters_.reopens;
  return true;
}

bool UiMessageTransport::port_hung_up() const {
  pollfd p{port_->fd(), POLLIN, 0};
  return ::poll(&p, 1, 0) > 0 && (p.revents & (POLLHUP | POLLERR | POLLNVAL)) != 0;
}

void UiMessageTransport::enter_state(can::BusState next, std::string text) {
  if (next == state_) return;
  state_ = next;
  emit_bus_event(can::BusEvent{next, 0, name() + ": " + std::move(text)});
}

std::error_code UiMessageTransport::send(const can::Frame& frame) {
  const auto refuse = [this](std::error_code error) {
    ++stats_.tx_dropped;
    return error;
  };
  const auto ui = to_ui(frame, options_.host_id);
  if (!ui) return refuse(ui.error());
  if (!port_ && !try_reopen()) return refuse(make_error_code(UiMessageErrc::kDisconnected));
  const auto bytes = uim342::encode_ui_message(*ui, crc_.next_send());  // DL <= 8: decode_can checked it
  if (!bytes) return refuse(bytes.error());
  if (const auto error = port_->write(*bytes)) {
    // EAGAIN: the tty buffer is full (a partial frame is resynchronized over by the gateway);
    // anything else (EIO) means the port is gone.
    if (error != std::errc::resource_unavailable_try_again) close_port("write failed: " + error.message());
    return refuse(error);
  }
  ++stats_.tx_frames;
  stats_.tx_bytes += frame.dlc;
  if (own_echo_) {
    can::Frame echo = frame;
    echo.timestamp_us = wall_time_us();
    if (echoes_.empty()) {
      const std::uint64_t one = 1;
      [[maybe_unused]] const ssize_t written = ::write(echo_fd_, &one, sizeof one);  // a counter of 1: cannot fail
    }
    echoes_.push_back(echo);
  }
  return {};
}

std::optional<can::Frame> UiMessageTransport::next_echo() {
  while (!echoes_.empty()) {
    const can::Frame echo = echoes_.front();
    echoes_.pop_front();
    if (echoes_.empty()) {
      std::uint64_t count = 0;
      [[maybe_unused]] const ssize_t taken = ::read(echo_fd_, &count, sizeof count);  // nothing waits: not readable
    }
    if (can::passes(filters_, echo)) return echo;
  }
  return std::nullopt;
}

std::optional<can::Frame> UiMessageTransport::to_frame(const uim342::DecodedUiMessage& decoded) {
  if (!decoded.crc) {
    ++counters_.without_crc;
  } else {
    ++(*decoded.crc == uim342::CrcCoverage::kStartToAux ? counters_.crc_start_to_aux : counters_.crc_id_to_aux);
    if (crc_.on_received(*decoded.crc) && crc_handler_) {
      crc_handler_(name() + ": the gateway's CRC covers " + to_string(*decoded.crc) + "; sending the same from now on");
    }
  }
  auto frame = uim342::encode_can(uim342::drive_message_from_ui(decoded.message, options_.host_id));
  if (!frame) {
    ++counters_.unconvertible;
    return std::nullopt;
  }
  can::Frame out = *frame;
  out.timestamp_us = wall_time_us();
  return out;
}

std::optional<can::Frame> UiMessageTransport::receive() {
  if (auto echo = next_echo()) return echo;
  while (port_) {
    if (const auto decoded = stream_.next()) {
      auto frame = to_frame(*decoded);
      if (!frame || !can::passes(filters_, *frame)) continue;
      ++stats_.rx_frames;
      stats_.rx_bytes += frame->dlc;
      return frame;
    }
    std::array<std::uint8_t, 256> chunk{};
    std::error_code error;
    const std::size_t size = port_->read(chunk, error);
    if (error) {
      close_port("read failed: " + error.message());
    } else if (size > 0) {
      stream_.feed(std::span(chunk).first(size));
      continue;
    } else if (port_hung_up()) {  // a hung-up tty reads as empty but stays readable: no busy loop
      close_port("port hung up");
    }
    break;
  }
  return std::nullopt;
}

std::error_code UiMessageTransport::set_filters(const std::vector<can::Filter>& filters) {
  filters_ = filters;
  return {};
}

std::error_code UiMessageTransport::set_own_echo(bool enabled) {
  own_echo_ = enabled;
  if (!enabled) {
    echoes_.clear();
    std::uint64_t count = 0;
    [[maybe_unused]] const ssize_t taken = ::read(echo_fd_, &count, sizeof count);
  }
  return {};
}

can::Statistics UiMessageTransport::statistics() const {
  can::Statistics out = stats_;
  const auto& stream = stream_.counters();
  out.errors = stream.crc_errors + stream.malformed + counters_.unconvertible;
  return out;
}

UiMessageCounters UiMessageTransport::counters() const {
  UiMessageCounters out = counters_;
  out.stream = stream_.counters();
  out.crc_blind_switches = crc_.blind_switches();
  return out;
}

}  // namespace motion::uimessage
