#include "motion/canopen/nmt_master.hpp"

#include <algorithm>

#include "frame_util.hpp"
#include "motion/canopen/cob_id.hpp"

namespace motion::canopen {

NmtMaster::NmtMaster(FrameSink sink) : sink_(std::move(sink)) {}

void NmtMaster::send(NmtCommand command, NodeId node) {
  if (sink_) sink_(encode_nmt({command, node}));
}

void NmtMaster::monitor(NodeId node, Duration consumer_time) {
  Node& record = nodes_[node];
  record.consumer_time = consumer_time;
  if (consumer_time <= Duration::zero()) {
    record.deadline = kNever;
    record.lost = false;
  }
}

void NmtMaster::mark_configured(NodeId node) { nodes_[node].configured = true; }

bool NmtMaster::configured(NodeId node) const {
  const auto it = nodes_.find(node);
  return it != nodes_.end() && it->second.configured;
}

bool NmtMaster::on_frame(const can::Frame& frame, TimePoint now) {
  if (!detail::is_standard_data_frame(frame)) return false;
  const auto info = classify_cob_id(frame.id);
  if (!info || info->kind != MessageKind::kHeartbeat) return false;
  const auto reported = decode_heartbeat(frame.payload());
  if (!reported) return true;  // node-guarding replies or garbage: not a heartbeat
  Node& record = nodes_[info->node];
  const std::optional<NmtState> previous = record.state;
  const bool was_lost = record.lost;
  record.lost = false;

  if (*reported == NmtState::kBootUp) {
    const bool rebooted = record.configured;
    record.configured = false;
    record.state = NmtState::kPreOperational;
    record.deadline = kNever;  // re-armed by the first heartbeat after boot-up
    emit({info->node, rebooted ? NodeEventKind::kRebooted : NodeEventKind::kBootUp, record.state, previous, now});
    return true;
  }

  record.state = *reported;
  if (record.consumer_time > Duration::zero()) record.deadline = now + record.consumer_time;
  if (was_lost) {
    emit({info->node, NodeEventKind::kHeartbeatRecovered, record.state, std::nullopt, now});
  } else if (previous != record.state) {
    emit({info->node, NodeEventKind::kStateChanged, record.state, previous, now});
  }
  return true;
}

TimePoint NmtMaster::process(TimePoint now) {
  for (auto& [node, record] : nodes_) {
    if (record.lost || now < record.deadline) continue;
    const std::optional<NmtState> previous = record.state;
    record.lost = true;
    record.state.reset();
    record.deadline = kNever;
    emit({node, NodeEventKind::kHeartbeatLost, std::nullopt, previous, now});
  }
  return next_deadline();
}

TimePoint NmtMaster::next_deadline() const {
  TimePoint next = kNever;
  for (const auto& [node, record] : nodes_) next = std::min(next, record.deadline);
  return next;
}

std::optional<NmtState> NmtMaster::state(NodeId node) const {
  const auto it = nodes_.find(node);
  if (it == nodes_.end()) return std::nullopt;
  return it->second.state;
}

bool NmtMaster::lost(NodeId node) const {
  const auto it = nodes_.find(node);
  return it != nodes_.end() && it->second.lost;
}

void NmtMaster::emit(const NodeEvent& event) const {
  if (handler_) handler_(event);
}

}  // namespace motion::canopen
