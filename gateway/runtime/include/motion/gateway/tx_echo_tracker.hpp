// When did our frames actually leave? With own-echo on (SocketCAN CAN_RAW_RECV_OWN_MSGS, the
// simulated bus's own echo), each frame a socket sends comes back to it once it has been sent,
// stamped with that time (the kernel's, or the simulated end of frame). This tracker keeps the
// frames sent and not yet echoed, in order, recognises their echoes among the received frames,
// and reports the echo time of the frames marked as the start frame of a command (a group BG, a
// SYNC), so a STARTED reply carries when the start frame was on the wire rather than when it was
// handed to the transport (which may queue it behind others).
//
// Passive: no clock, no I/O. A transport without own echo never echoes: after `limit` frames
// without one the tracker gives up (disabled()) and keeps nothing.
// Thread contract: single-threaded (the gateway's loop).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <utility>
#include <vector>

#include "motion/can_frame/frame.hpp"

namespace motion::gateway {

class TxEchoTracker {
 public:
  explicit TxEchoTracker(std::size_t limit = 256) : limit_(limit) {}

  // A frame the transport accepted.
  void sent(const can::Frame& frame);
  // The most recent sent frame with this identifier starts `command_id` (call right after its
  // send). False when there is no such frame waiting for its echo (nothing to wait for).
  bool mark_start(std::int64_t command_id, const can::Frame& frame);
  // A received frame: true when it is the echo of one of ours (frames sent before it that never
  // came back are forgotten). `started` gets (command id, echo time in us) of every command whose
  // last marked start frame this echo completes; the time is the earliest echo of its frames.
  bool on_receive(const can::Frame& frame, std::int64_t now_us,
                  std::vector<std::pair<std::int64_t, std::int64_t>>& started);

  // Echoes have been seen: a STARTED reply may wait for one.
  [[nodiscard]] bool working() const { return echoes_ > 0 && !disabled_; }
  [[nodiscard]] bool disabled() const { return disabled_; }
  // Start frames of `command_id` still waiting for their echo.
  [[nodiscard]] bool awaiting(std::int64_t command_id) const { return starts_.contains(command_id); }
  void forget(std::int64_t command_id) { starts_.erase(command_id); }
  [[nodiscard]] std::uint64_t echoes() const { return echoes_; }

 private:
  struct Entry {
    can::Frame frame;
    std::vector<std::int64_t> starts;  // commands this frame starts
  };
  struct Start {
    int frames = 0;  // marked frames not yet echoed
    std::int64_t first_echo_us = 0;
  };
  std::deque<Entry> entries_;
  std::map<std::int64_t, Start> starts_;
  std::size_t limit_;
  std::uint64_t echoes_ = 0;
  bool disabled_ = false;
};

}  // namespace motion::gateway
