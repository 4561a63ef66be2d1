// CiA 301 §7.2.8 NMT master and heartbeat consumer, passive.
//  - send(): NMT node-control commands.
//  - Heartbeat consumer (CiA 301 §7.2.8.3.2.2): per monitored node a consumer time; monitoring
//    starts with the first heartbeat received (a boot-up does not arm it: the UC57 sends boot-up
//    with its heartbeat still off, 1017h = 0). No heartbeat within the consumer time -> one
//    kHeartbeatLost event; the next heartbeat -> kHeartbeatRecovered.
//  - Boot-up: kRebooted when the node had been marked configured (it lost its SDO/PDO settings
//    and must be configured again; the mark is cleared), kBootUp otherwise. After boot-up the node
//    is in Pre-operational (CiA 301 §7.3.2.2.1), which state() then reports.
//  - State changes reported by heartbeats -> kStateChanged.
//
// Thread contract: single-threaded, owned by the poll loop; the handler runs inside on_frame()
// and process().
#pragma once

#include <functional>
#include <map>
#include <optional>

#include "motion/can_frame/frame.hpp"
#include "motion/canopen/nmt.hpp"
#include "motion/canopen/types.hpp"
#include "motion/core/clock.hpp"

namespace motion::canopen {

enum class NodeEventKind : std::uint8_t {
  kBootUp,
  kRebooted,
  kStateChanged,
  kHeartbeatLost,
  kHeartbeatRecovered,
};

struct NodeEvent {
  NodeId node = 0;
  NodeEventKind kind = NodeEventKind::kBootUp;
  std::optional<NmtState> state;     // after the event; nullopt when lost
  std::optional<NmtState> previous;  // before the event; nullopt when unknown
  TimePoint at{};
};

class NmtMaster {
 public:
  using Handler = std::function<void(const NodeEvent&)>;

  explicit NmtMaster(FrameSink sink);

  void on_event(Handler handler) { handler_ = std::move(handler); }

  // Emits the NMT command; `node` 0 addresses all nodes.
  void send(NmtCommand command, NodeId node);

  // Heartbeat consumer time for `node` (zero stops monitoring). Typically 1.5-2 x its 1017h.
  void monitor(NodeId node, Duration consumer_time);
  // The node has been configured; a later boot-up reports kRebooted.
  void mark_configured(NodeId node);
  [[nodiscard]] bool configured(NodeId node) const;

  // True when `frame` is a heartbeat/boot-up (700h + n) and was consumed.
  bool on_frame(const can::Frame& frame, TimePoint now);
  // Detects heartbeat loss; returns the next deadline (kNever when nothing is armed).
  TimePoint process(TimePoint now);
  [[nodiscard]] TimePoint next_deadline() const;

  // Last state reported by the node; nullopt when never seen or its heartbeat is lost.
  [[nodiscard]] std::optional<NmtState> state(NodeId node) const;
  [[nodiscard]] bool lost(NodeId node) const;

 private:
  struct Node {
    Duration consumer_time{};
    std::optional<NmtState> state;
    TimePoint deadline = kNever;  // armed by heartbeats of a monitored node
    bool lost = false;
    bool configured = false;
  };

  void emit(const NodeEvent& event) const;

  FrameSink sink_;
  Handler handler_;
  std::map<NodeId, Node> nodes_;
};

}  // namespace motion::canopen
