// Endpoints of a simulated CAN bus: motion::can::Transport implementations.
//
//   SocketEndpoint  another process's hub, reached over its Unix socket by bus name (gateways).
//   LocalEndpoint   (hub.hpp) a hub in the same process (motion-sim's drives).
//
// Threading/blocking: the can::Transport contract. One thread (the poll loop), nothing blocks.
// Filters are applied on receive; own echo is done by the hub, so an echoed frame arrives at its
// end-of-frame time like everyone else's copy. Bus events (errors, bus-off, recovery, disconnect)
// reach the on_bus_event handler from inside receive().
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "motion/can/transport.hpp"
#include "motion/can_frame/load_meter.hpp"
#include "motion/simbus/bus.hpp"
#include "motion/simbus/wire.hpp"

namespace motion::simbus {

// What both endpoint kinds share: name, filters, counters and the bus-state bookkeeping.
class EndpointTransport : public can::Transport {
 public:
  [[nodiscard]] std::string name() const override { return "sim:" + bus_name_; }
  [[nodiscard]] const std::string& bus_name() const { return bus_name_; }
  std::error_code set_filters(const std::vector<can::Filter>& filters) override;
  // bus_load: the wire time of the frames this endpoint sent and received from others (not its
  // own echoes) against the hub's bit rate, once the hub told it (0 without bus timing).
  [[nodiscard]] can::Statistics statistics() const override;

 protected:
  explicit EndpointTransport(std::string bus_name) : bus_name_(std::move(bus_name)) {}
  // Validates a frame about to be sent (invalid_argument) and counts a failure as tx_dropped.
  [[nodiscard]] std::error_code check_sendable(const can::Frame& frame);
  std::error_code count_send(const can::Frame& frame, std::error_code result);
  // True when `frame` passes the filters (and is then counted as received).
  bool accept(const can::Frame& frame);
  // Counts the event, updates `state` and hands it to the handler.
  void apply(const can::BusEvent& event, can::BusState& state);
  void count_tx_rejected() { ++stats_.tx_dropped; }
  // A frame that was on the wire (sent by this endpoint, or received from another), for bus_load.
  void count_on_wire(const can::Frame& frame) { load_.add(frame, SteadyClock::now()); }
  void set_load_bitrate(std::uint32_t bitrate) { load_.set_bitrate(bitrate); }

 private:
  std::string bus_name_;
  std::vector<can::Filter> filters_;
  can::Statistics stats_;
  can::LoadMeter load_;
};

struct EndpointOptions {
  std::filesystem::path socket_dir;  // empty: default_socket_dir(); must match the hub's
  std::string label;                 // how the hub lists this endpoint; empty: "pid <pid>"
  bool own_echo = false;
};

// A connection to the hub of `bus_name`. The hub assigns the endpoint id (after its Welcome has
// been received). When the hub goes away, receive() reports a kDisconnected bus event, fd()
// becomes -1 and the old descriptor number stays open but never readable, so a loop that still
// watches it does not spin; call reconnect() (and watch the new fd()) to join the bus again.
class SocketEndpoint final : public EndpointTransport {
 public:
  // nullptr with `error` set: invalid name (invalid_argument), no hub (ENOENT / ECONNREFUSED).
  static std::unique_ptr<SocketEndpoint> connect(std::string_view bus_name, EndpointOptions options,
                                                 std::error_code& error);
  ~SocketEndpoint() override;
  SocketEndpoint(const SocketEndpoint&) = delete;
  SocketEndpoint& operator=(const SocketEndpoint&) = delete;

  [[nodiscard]] int fd() const override { return fd_; }
  std::error_code send(const can::Frame& frame) override;
  // The frames in messages of up to wire::kMaxBatchFrames each: the hub takes each message's
  // frames together. An invalid frame stops the batch there with send()'s error for it.
  std::size_t send_batch(std::span<const can::Frame> frames, std::error_code& error) override;
  std::optional<can::Frame> receive() override;
  std::error_code set_own_echo(bool enabled) override;
  [[nodiscard]] can::BusState state() const override { return state_; }

  std::error_code reconnect();
  // Known once the hub's Welcome has been received (0 before).
  [[nodiscard]] EndpointId endpoint_id() const { return endpoint_id_; }
  // Bit rate of the hub's timing model; 0 when unknown or timing is off.
  [[nodiscard]] std::uint32_t bitrate() const { return bitrate_; }

 private:
  SocketEndpoint(std::string bus_name, EndpointOptions options);
  std::error_code open_connection();
  void lose_connection(const std::string& reason);
  // Sends one message to the hub; a refusal as send() reports it (the connection lost on a
  // broken socket).
  std::error_code deliver(const wire::Message& message);

  EndpointOptions options_;
  int fd_ = -1;
  int quiet_fd_ = -1;  // the old descriptor number after a disconnect (see class comment)
  can::BusState state_ = can::BusState::kDisconnected;
  EndpointId endpoint_id_ = 0;
  std::uint32_t bitrate_ = 0;
};

}  // namespace motion::simbus
