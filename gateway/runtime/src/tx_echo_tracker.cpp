#include "motion/gateway/tx_echo_tracker.hpp"

#include <algorithm>

namespace motion::gateway {

void TxEchoTracker::sent(const can::Frame& frame) {
  if (disabled_) return;
  entries_.push_back(Entry{frame, {}});
  if (entries_.size() <= limit_) return;
  if (echoes_ == 0) {
    // `limit` frames and not one echo: the transport has none.
    disabled_ = true;
    entries_.clear();
    starts_.clear();
    return;
  }
  // Echoes work but this one is long gone (lost, or the bus is off): forget the oldest.
  for (const auto id : entries_.front().starts) starts_.erase(id);
  entries_.pop_front();
}

bool TxEchoTracker::mark_start(std::int64_t command_id, const can::Frame& frame) {
  if (disabled_) return false;
  const auto it = std::find_if(entries_.rbegin(), entries_.rend(), [&](const Entry& e) {
    return e.frame.id == frame.id && e.frame.extended == frame.extended;
  });
  if (it == entries_.rend()) return false;
  it->starts.push_back(command_id);
  ++starts_[command_id].frames;
  return true;
}

bool TxEchoTracker::on_receive(const can::Frame& frame, std::int64_t now_us,
                               std::vector<std::pair<std::int64_t, std::int64_t>>& started) {
  if (disabled_) return false;
  // Echoes come back in send order; a frame of another node is never equal to one of ours
  // (node and producer ids differ), so the first equal entry is this echo.
  const auto it = std::find_if(entries_.begin(), entries_.end(), [&](const Entry& e) { return e.frame == frame; });
  if (it == entries_.end()) return false;
  ++echoes_;
  const std::int64_t at = frame.timestamp_us != 0 ? frame.timestamp_us : now_us;
  for (const auto id : it->starts) {
    const auto s = starts_.find(id);
    if (s == starts_.end()) continue;
    s->second.first_echo_us = s->second.first_echo_us == 0 ? at : std::min(s->second.first_echo_us, at);
    if (--s->second.frames > 0) continue;
    started.emplace_back(id, s->second.first_echo_us);
    starts_.erase(s);
  }
  // Frames sent before this one that did not come back will not: forget them.
  for (auto lost = entries_.begin(); lost != it; ++lost) {
    for (const auto id : lost->starts) starts_.erase(id);
  }
  entries_.erase(entries_.begin(), std::next(it));
  return true;
}

}  // namespace motion::gateway
