// The one interface every CAN transport implements (simulated bus endpoint, SocketCAN).
//
// Threading/blocking contract: a transport is owned by one thread, the process's poll loop.
// No method blocks. The loop polls `fd()` for POLLIN and then calls `receive()` until it returns
// nullopt. `send()` either queues the frame in the transport/kernel or fails at once with an
// error (never waits for the wire).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "motion/can_frame/frame.hpp"

namespace motion::can {

// Acceptance filter with SocketCAN semantics: a frame passes when
// (frame_id & mask) == (id & mask) and its format (standard/extended) matches `extended` when
// `match_format` is set. An empty filter list accepts every frame.
struct Filter {
  std::uint32_t id = 0;
  std::uint32_t mask = 0;
  bool extended = false;
  bool match_format = false;
};

[[nodiscard]] bool passes(const std::vector<Filter>& filters, const Frame& frame);

// ISO 11898 fault confinement states, as SocketCAN reports them.
enum class BusState : std::uint8_t { kErrorActive, kErrorWarning, kErrorPassive, kBusOff, kDisconnected };
[[nodiscard]] const char* to_string(BusState state);

struct Statistics {
  std::uint64_t tx_frames = 0;
  std::uint64_t rx_frames = 0;
  std::uint64_t tx_bytes = 0;  // payload bytes
  std::uint64_t rx_bytes = 0;
  std::uint64_t errors = 0;      // error frames / corrupted frames seen
  std::uint64_t tx_dropped = 0;  // send() failures (queue full, bus-off, disconnected)
  std::uint64_t bus_off_count = 0;
  double bus_load = 0.0;  // 0..1, fraction of wire time used over the last second (where known)
};

// Errors, warnings and state changes the transport learned about (error frames, bus-off,
// recovery, disconnect). Delivered from receive() processing through the handler.
struct BusEvent {
  BusState state = BusState::kErrorActive;
  std::uint32_t error_class = 0;  // CAN_ERR_* class bits on SocketCAN, 0 elsewhere
  std::string text;
};

class Transport {
 public:
  virtual ~Transport() = default;

  // Name of the bus/interface, as written in candump lines ("can0", "sim:lab").
  [[nodiscard]] virtual std::string name() const = 0;
  // Readable when frames (or bus events) are waiting; -1 when disconnected.
  [[nodiscard]] virtual int fd() const = 0;

  virtual std::error_code send(const Frame& frame) = 0;
  // Sends `frames` in order, all at once where the transport can: one system call (SocketCAN:
  // sendmmsg), one message (the simulated bus). Between separate sends a reader woken by the
  // first frame may take the sender's CPU on a busy host, and the wire idles meanwhile. Returns
  // how many were taken; on a refusal `error` says why and the frames after it are not sent.
  // Default: send() each.
  virtual std::size_t send_batch(std::span<const Frame> frames, std::error_code& error);
  // Next received frame, or nullopt when none is waiting. Never blocks.
  virtual std::optional<Frame> receive() = 0;

  virtual std::error_code set_filters(const std::vector<Filter>& filters) = 0;
  // Whether this endpoint receives its own transmitted frames (vcan/SocketCAN "loopback").
  virtual std::error_code set_own_echo(bool enabled) = 0;

  [[nodiscard]] virtual BusState state() const = 0;
  [[nodiscard]] virtual Statistics statistics() const = 0;
  void on_bus_event(std::function<void(const BusEvent&)> handler) { bus_event_handler_ = std::move(handler); }

 protected:
  void emit_bus_event(const BusEvent& event) {
    if (bus_event_handler_) bus_event_handler_(event);
  }

 private:
  std::function<void(const BusEvent&)> bus_event_handler_;
};

}  // namespace motion::can
