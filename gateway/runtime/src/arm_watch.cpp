#include "motion/gateway/arm_watch.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "motion/lcm/reply_error.hpp"

namespace motion::gateway {

using Reply = motionlcm::gateway_reply_t;

void ArmWatch::on_command(const motionlcm::gateway_command_t& command, TimePoint now) {
  if (command.kind != motionlcm::gateway_command_t::ARM_MOVE || command.trigger_id == 0) return;
  Move m;
  m.command_id = command.command_id;
  m.trigger_id = command.trigger_id;
  for (const auto& a : command.axes) m.axes.push_back(a.axis);
  m.deadline = now + expiry_;
  moves_[m.command_id] = std::move(m);
}

void ArmWatch::on_reply(Reply& reply) {
  if (const auto it = released_.find(reply.command_id); it != released_.end()) {
    if (reply.status == Reply::FAILED) {
      reply.error_code = error_code(ReplyError::kTimeout);
      reply.reason = it->second;
    }
    if (reply.status == Reply::FAILED || reply.status == Reply::DONE) released_.erase(it);
    return;
  }
  const auto it = moves_.find(reply.command_id);
  if (it == moves_.end()) return;
  if (reply.status == Reply::ARMED) {
    it->second.armed = true;
  } else if (reply.status != Reply::ACCEPTED) {
    moves_.erase(it);  // STARTED (without a trigger heard here), DONE or FAILED: nothing left armed
  }
}

bool ArmWatch::on_trigger(std::int64_t trigger_id) {
  bool live = false;
  for (auto it = moves_.begin(); it != moves_.end();) {
    if (it->second.trigger_id == trigger_id) {
      live = true;
      it = moves_.erase(it);
    } else {
      ++it;
    }
  }
  if (live) return true;
  return std::find(released_triggers_.begin(), released_triggers_.end(), trigger_id) == released_triggers_.end();
}

std::vector<ArmWatch::Move> ArmWatch::due(TimePoint now) {
  std::vector<Move> out;
  for (auto it = moves_.begin(); it != moves_.end();) {
    if (!it->second.armed || it->second.deadline > now) {
      ++it;
      continue;
    }
    Move m = std::move(it->second);
    it = moves_.erase(it);
    released_[m.command_id] = reason(m);
    released_triggers_.push_back(m.trigger_id);
    if (released_triggers_.size() > kRemembered) released_triggers_.pop_front();
    if (released_.size() > kRemembered) released_.erase(released_.begin());  // the oldest ids
    ++released_count_;
    out.push_back(std::move(m));
  }
  return out;
}

TimePoint ArmWatch::next_deadline() const {
  TimePoint next = kNever;
  for (const auto& [id, m] : moves_) {
    if (m.armed) next = std::min(next, m.deadline);
  }
  return next;
}

std::string ArmWatch::reason(const Move& move) const {
  return fmt::format(
      "axis {} armed by command {} for trigger {} was never triggered within {} ms: released by the "
      "gateway, as a DISARM would: its trigger starts nothing",
      fmt::join(move.axes, ", "), move.command_id, move.trigger_id,
      std::chrono::duration_cast<std::chrono::milliseconds>(expiry_).count());
}

}  // namespace motion::gateway
