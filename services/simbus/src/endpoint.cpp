#include "motion/simbus/endpoint.hpp"

#include <fcntl.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <variant>

#include "motion/core/unix_socket.hpp"
#include "motion/simbus/address.hpp"
#include "motion/simbus/wire.hpp"
#include "unix_socket.hpp"

namespace motion::simbus {

// ---- EndpointTransport ----------------------------------------------------------------------

std::error_code EndpointTransport::set_filters(const std::vector<can::Filter>& filters) {
  filters_ = filters;
  return {};
}

std::error_code EndpointTransport::check_sendable(const can::Frame& frame) {
  const bool valid = frame.dlc <= 8 && frame.id <= (frame.extended ? can::kMaxExtendedId : can::kMaxStandardId);
  return valid ? std::error_code{} : std::make_error_code(std::errc::invalid_argument);
}

std::error_code EndpointTransport::count_send(const can::Frame& frame, std::error_code result) {
  if (result) {
    ++stats_.tx_dropped;
  } else {
    ++stats_.tx_frames;
    stats_.tx_bytes += frame.rtr ? 0 : frame.dlc;
    count_on_wire(frame);
  }
  return result;
}

can::Statistics EndpointTransport::statistics() const {
  can::Statistics out = stats_;
  out.bus_load = load_.load(SteadyClock::now());
  return out;
}

bool EndpointTransport::accept(const can::Frame& frame) {
  if (!can::passes(filters_, frame)) return false;
  ++stats_.rx_frames;
  stats_.rx_bytes += frame.rtr ? 0 : frame.dlc;
  return true;
}

void EndpointTransport::apply(const can::BusEvent& event, can::BusState& state) {
  if ((event.error_class & kErrorProtocol) != 0) ++stats_.errors;
  if (event.state == can::BusState::kBusOff && state != can::BusState::kBusOff) ++stats_.bus_off_count;
  state = event.state;
  emit_bus_event(event);
}

// ---- SocketEndpoint -------------------------------------------------------------------------

SocketEndpoint::SocketEndpoint(std::string bus_name, EndpointOptions options)
    : EndpointTransport(std::move(bus_name)), options_(std::move(options)) {
  if (options_.label.empty()) options_.label = "pid " + std::to_string(::getpid());
}

std::unique_ptr<SocketEndpoint> SocketEndpoint::connect(std::string_view bus_name, EndpointOptions options,
                                                        std::error_code& error) {
  if (!valid_bus_name(bus_name)) {
    error = std::make_error_code(std::errc::invalid_argument);
    return nullptr;
  }
  std::unique_ptr<SocketEndpoint> endpoint(new SocketEndpoint(std::string(bus_name), std::move(options)));
  error = endpoint->open_connection();
  if (error) return nullptr;
  return endpoint;
}

SocketEndpoint::~SocketEndpoint() {
  if (fd_ >= 0) ::close(fd_);
  if (quiet_fd_ >= 0) ::close(quiet_fd_);
}

std::error_code SocketEndpoint::open_connection() {
  std::error_code error;
  const int fd = unix_socket::connect_seqpacket(socket_path(bus_name(), options_.socket_dir), error);
  if (fd < 0) return error;
  error = detail::send_message(fd, wire::Hello{wire::kProtocolVersion, options_.own_echo, options_.label});
  if (error) {
    ::close(fd);
    return error;
  }
  fd_ = fd;
  state_ = can::BusState::kErrorActive;
  return {};
}

std::error_code SocketEndpoint::reconnect() {
  if (fd_ >= 0) ::close(fd_);
  if (quiet_fd_ >= 0) ::close(quiet_fd_);
  fd_ = quiet_fd_ = -1;
  endpoint_id_ = 0;
  state_ = can::BusState::kDisconnected;
  return open_connection();
}

void SocketEndpoint::lose_connection(const std::string& reason) {
  // Keep the descriptor number valid but silent: an eventfd that is never written.
  const int silent = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (silent >= 0 && ::dup3(silent, fd_, O_CLOEXEC) >= 0) {
    quiet_fd_ = fd_;
  } else {
    ::close(fd_);
  }
  if (silent >= 0) ::close(silent);
  fd_ = -1;
  endpoint_id_ = 0;
  apply(can::BusEvent{can::BusState::kDisconnected, 0, "simulated bus " + bus_name() + ": " + reason}, state_);
}

std::error_code SocketEndpoint::deliver(const wire::Message& message) {
  std::error_code error = detail::send_message(fd_, message);
  if (error == std::errc::resource_unavailable_try_again) {
    error = std::make_error_code(std::errc::no_buffer_space);  // like a full SocketCAN tx queue
  } else if (error) {
    lose_connection(error.message());
    error = std::make_error_code(std::errc::not_connected);
  }
  return error;
}

std::error_code SocketEndpoint::send(const can::Frame& frame) {
  if (auto invalid = check_sendable(frame)) return count_send(frame, invalid);
  if (fd_ < 0) return count_send(frame, std::make_error_code(std::errc::not_connected));
  if (state_ == can::BusState::kBusOff) return count_send(frame, std::make_error_code(std::errc::network_down));
  return count_send(frame, deliver(wire::FrameMessage{frame, false}));
}

std::size_t SocketEndpoint::send_batch(std::span<const can::Frame> frames, std::error_code& error) {
  error = {};
  std::size_t done = 0;
  while (done < frames.size()) {
    wire::FrameBatch batch;
    while (batch.count < wire::kMaxBatchFrames && done + batch.count < frames.size() &&
           !check_sendable(frames[done + batch.count])) {
      batch.frames[batch.count] = frames[done + batch.count];
      ++batch.count;
    }
    if (batch.count <= 1 || fd_ < 0 || state_ == can::BusState::kBusOff) {
      // A lone frame, or one send() refuses: send() takes it or says why (and counts it).
      if ((error = send(frames[done]))) return done;
      ++done;
      continue;
    }
    if ((error = deliver(batch))) {
      (void)count_send(frames[done], error);  // counted as send() counts a refused frame
      return done;
    }
    for (const can::Frame& frame : batch.view()) (void)count_send(frame, {});
    done += batch.count;
  }
  return done;
}

std::optional<can::Frame> SocketEndpoint::receive() {
  std::array<std::uint8_t, wire::kMaxMessageSize> buffer{};
  while (fd_ >= 0) {
    const ssize_t n = ::recv(fd_, buffer.data(), buffer.size(), MSG_DONTWAIT);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) return std::nullopt;
      lose_connection(std::strerror(errno));
      return std::nullopt;
    }
    if (n == 0) {
      lose_connection("hub closed the connection");
      return std::nullopt;
    }
    auto message = wire::decode({buffer.data(), static_cast<std::size_t>(n)});
    if (!message) continue;  // a newer hub's message we do not know: skip it
    if (auto* fm = std::get_if<wire::FrameMessage>(&*message)) {
      if (!fm->own_echo) count_on_wire(fm->frame);  // an echo was counted when sent
      if (accept(fm->frame)) return fm->frame;
    } else if (const auto* ev = std::get_if<wire::BusEventMessage>(&*message)) {
      apply(ev->event, state_);
    } else if (const auto* welcome = std::get_if<wire::Welcome>(&*message)) {
      endpoint_id_ = welcome->endpoint;
      bitrate_ = welcome->bitrate;
      set_load_bitrate(bitrate_);
    } else if (std::holds_alternative<wire::TxRejected>(*message)) {
      count_tx_rejected();
    }
  }
  return std::nullopt;
}

std::error_code SocketEndpoint::set_own_echo(bool enabled) {
  options_.own_echo = enabled;
  if (fd_ < 0) return {};  // sent with the Hello of the next connection
  return detail::send_message(fd_, wire::SetOwnEcho{enabled});
}

}  // namespace motion::simbus
