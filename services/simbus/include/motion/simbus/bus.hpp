// The simulated CAN bus itself, as a passive core: frames and `now` in, deliveries and the next
// deadline out. No sockets, no clock, no threads; the Hub drives it from the process's poll loop
// and tests drive it with hand-picked times.
//
// With the timing model on, frames are serialized on a virtual wire: a frame occupies it for its
// exact bit time (motion/can_frame/bit_timing.hpp); when the wire frees, the oldest waiting frame
// of each endpoint contends by arbitration (the lowest arbitration field wins, equal fields by submission order;
// an endpoint's own frames keep their order, as on a SocketCAN interface); receivers get the frame at its
// end of frame, stamped with that time. With it off, frames are delivered at the time they are
// submitted. Like vcan, every frame reaches every other attached endpoint; an endpoint receives
// its own frames only with own echo on. Frames are sent once (no automatic retransmission).
//
// Thread contract: single-threaded. Times passed to advance() must not go backwards; a frame may
// be submitted at a time the bus has already run past (its sender's send time, read late): it is
// queued at that time and takes the wire when the wire was free then, as it would have.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <variant>
#include <vector>

#include "motion/can/transport.hpp"
#include "motion/can_frame/bit_timing.hpp"
#include "motion/can_frame/frame.hpp"
#include "motion/core/clock.hpp"

namespace motion::simbus {

// SocketCAN error classes (linux/can/error.h) in can::BusEvent::error_class, so consumers can
// branch the same way on a simulated and a real bus.
inline constexpr std::uint32_t kErrorProtocol = 0x08;    // CAN_ERR_PROT: a corrupted frame
inline constexpr std::uint32_t kErrorBusOff = 0x40;      // CAN_ERR_BUSOFF
inline constexpr std::uint32_t kErrorRestarted = 0x100;  // CAN_ERR_RESTARTED

using EndpointId = std::uint32_t;  // 1, 2, ... in attach order, never reused by one bus
using FaultId = std::uint64_t;

struct BusConfig {
  std::uint32_t bitrate = 500'000;  // bit/s, > 0
  bool timing = true;               // false: no wire, deliver at submission time
  Duration load_window = std::chrono::seconds(1);
  std::size_t max_queued = 4096;  // frames waiting for the wire; more and submit() fails
  // Frame::timestamp_us = epoch_offset_us + microseconds of the (steady) time points handed in.
  std::int64_t epoch_offset_us = 0;
};

// One fault-injection rule. A frame is matched against the rules in the order they were
// injected; the first one that matches (and has frames left) applies, and only that one.
struct Fault {
  enum class Action : std::uint8_t {
    kDrop,     // the frame vanishes: no wire time, nobody receives it
    kCorrupt,  // the frame occupies the wire, then every endpoint gets an error event instead
    kDelay,    // receivers get the frame `delay` after its end of frame
  };
  static constexpr std::uint64_t kUnlimited = UINT64_MAX;

  Action action = Action::kDrop;
  std::vector<can::Filter> match;     // can::passes() semantics: empty matches every frame
  std::optional<EndpointId> sender;   // only frames sent by this endpoint
  std::uint64_t frames = kUnlimited;  // matching frames it applies to before it expires
  Duration delay{};                   // kDelay only

  static Fault drop(std::uint64_t frames = kUnlimited, std::vector<can::Filter> match = {});
  static Fault corrupt(std::uint64_t frames = kUnlimited, std::vector<can::Filter> match = {});
  static Fault delay_by(Duration delay, std::uint64_t frames = kUnlimited, std::vector<can::Filter> match = {});
};

struct BusStatistics {
  std::uint64_t frames = 0;    // frames that went over the wire (corrupted ones included)
  std::uint64_t bytes = 0;     // their payload bytes
  std::uint64_t bits = 0;      // their wire bits: stuffing, trailer and interframe space included
  std::uint64_t errors = 0;    // corrupted frames
  std::uint64_t dropped = 0;   // frames removed by a drop fault
  std::uint64_t rejected = 0;  // submissions refused (bus-off, queue full) or aborted by bus-off
  std::uint64_t overruns = 0;  // deliveries a receiver could not take (filled in by the Hub)
  std::size_t queued = 0;      // frames waiting for the wire now
  double bus_load = 0.0;       // fraction of the last load_window the wire was busy, 0..1
};

struct EndpointInfo {
  EndpointId id = 0;
  std::string label;
  can::BusState state = can::BusState::kErrorActive;
  bool own_echo = false;
  std::uint64_t tx_frames = 0;  // frames of this endpoint that went over the wire intact
  std::uint64_t rx_frames = 0;  // frames delivered to it (own echoes included)
  std::uint64_t errors = 0;     // error events sent to it
  std::uint64_t rejected = 0;
  std::uint64_t bus_off_count = 0;
};

// Receives the bus's output. Called only from Bus::advance(); must not call back into the Bus.
class BusSink {
 public:
  virtual ~BusSink() = default;
  virtual void deliver(EndpointId to, const can::Frame& frame, bool own_echo) = 0;
  virtual void notify(EndpointId to, const can::BusEvent& event) = 0;
};

class Bus {
 public:
  explicit Bus(BusConfig config = {});

  [[nodiscard]] const BusConfig& config() const { return config_; }

  EndpointId attach(std::string label, bool own_echo = false);
  // Frames it still had queued are discarded; one already on the wire completes.
  void detach(EndpointId id);
  bool set_own_echo(EndpointId id, bool enabled);
  [[nodiscard]] std::optional<EndpointInfo> endpoint(EndpointId id) const;
  [[nodiscard]] std::optional<EndpointId> find(std::string_view label) const;
  [[nodiscard]] std::vector<EndpointInfo> endpoints() const;

  // Queues `frame` from `from` at `now` (which may lie before the last advance(), see above).
  // Errors: invalid_argument (bad frame), not_connected
  // (unknown endpoint), network_down (endpoint is bus-off), no_buffer_space (queue full).
  std::error_code submit(EndpointId from, const can::Frame& frame, TimePoint now);
  // Runs the wire up to `now` and hands everything due by then to `sink`, in time order.
  void advance(TimePoint now, BusSink& sink);
  // When advance() next has something to do; kNever when idle.
  [[nodiscard]] TimePoint next_deadline() const;

  FaultId inject(Fault fault);
  bool clear_fault(FaultId id);
  void clear_faults();
  // The endpoint goes bus-off at `now`: its queued frames are aborted, its submissions fail and
  // it receives nothing, until recover() or, when given, `recover_after` has passed.
  bool set_bus_off(EndpointId id, TimePoint now, std::optional<Duration> recover_after = std::nullopt);
  bool recover(EndpointId id, TimePoint now);

  [[nodiscard]] BusStatistics statistics(TimePoint now) const;

 private:
  struct Queued {
    std::uint64_t seq;
    EndpointId from;
    can::Frame frame;
    TimePoint queued_at;
  };
  struct Fate {
    bool drop = false;
    bool corrupt = false;
    Duration delay{};
  };
  struct OnWire {
    Queued frame;
    Fate fate;
    std::uint32_t bits;
    TimePoint end_of_frame;
  };
  struct FrameOut {
    EndpointId from;
    can::Frame frame;
  };
  struct EventOut {
    EndpointId to;  // 0: every endpoint
    can::BusEvent event;
    bool error_frame = false;  // counted per receiver and reported with its own state
  };
  using Output = std::variant<FrameOut, EventOut>;
  struct Endpoint {
    EndpointInfo info;
    TimePoint recover_at = kNever;
    TimePoint last_queued{};  // an endpoint's frames are queued in its sending order (see submit)
  };

  void run_wire(TimePoint now);
  void recover_due(TimePoint now);
  void emit_due(TimePoint now, BusSink& sink);
  Queued take_winner(TimePoint start);
  Fate fate_of(const Queued& q);
  // Occupies the wire (or, with timing off, notional wire time) from `start` and counts the frame.
  void occupy(std::uint32_t bits, TimePoint start);
  void complete(const Queued& q, const Fate& fate, std::uint32_t bits, TimePoint end_of_frame);
  void schedule(TimePoint at, Output output);
  void purge_queue(EndpointId from);
  Endpoint* find_endpoint(EndpointId id);
  [[nodiscard]] std::int64_t to_epoch_us(TimePoint t) const;

  BusConfig config_;
  std::map<EndpointId, Endpoint> endpoints_;
  EndpointId next_endpoint_ = 1;
  std::vector<Queued> queue_;  // by queued_at, equal times in submission order
  std::optional<OnWire> on_wire_;
  TimePoint wire_free_at_{TimePoint::min()};
  std::multimap<std::pair<TimePoint, std::uint64_t>, Output> outputs_;
  std::uint64_t next_seq_ = 1;
  std::map<FaultId, Fault> faults_;
  FaultId next_fault_ = 1;
  BusStatistics stats_;
  std::deque<std::pair<TimePoint, TimePoint>> busy_;  // wire intervals within the load window
};

}  // namespace motion::simbus
