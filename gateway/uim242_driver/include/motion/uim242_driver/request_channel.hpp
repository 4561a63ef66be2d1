// One request at a time over the RS232 line to a UIM2501/2502 gateway: routing (`ADR η;` before
// the first instruction for another controller, EXT-2501 §3.3; EN/CN §3.1 are silent), reply
// matching, timeouts, retries.
//
// A request is one instruction for one controller (node 5..125) or for the gateway (node 0:
// ADR, g...). It ends exactly once: on_reply with the matching frame, or on_failure with a reason
// naming drive, node and instruction (EE error reply: no retry, the instruction was refused;
// silence: retried `retries` times, then failed). Frames that match nothing are counted as
// unexpected. After a timeout the gateway's target is unknown, so the next request re-selects it.
// Thread contract: single-threaded passive core (frames and `now` in, bytes out via `send`).
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <span>
#include <string>

#include "motion/core/clock.hpp"
#include "motion/uim242/feedback.hpp"

namespace motion::uim242_driver {

struct Request {
  std::string drive;  // for reasons; "gateway" for node 0
  int node = 0;       // 0 = gateway-level instruction (no ADR)
  uim242::Instruction instruction;
  std::int64_t group = 0;  // cancel key (a command id); 0 = start-up / polling
  std::function<void(const uim242::Frame& reply, TimePoint now)> on_reply;
  std::function<void(const std::string& reason, bool timed_out, TimePoint now)> on_failure;
  std::function<void(TimePoint sent)> on_sent;  // each time its bytes have crossed the wire (last character's end)
  TimePoint not_before{};  // not handed to the line before this (a start timed to the end of a longer frame)
  bool urgent = false;     // set by submit(front): a start or a stop, never held by limit()
};

// After an STO's reply the line stays quiet this long (UIM242 manual #42: "wait 20ms before
// sending other instructions").
inline constexpr Duration kStoPause = std::chrono::milliseconds(20);

struct ChannelSettings {
  Duration timeout = std::chrono::milliseconds(100);  // from the end of the instruction on the wire
  int retries = 1;
  Duration character_time{};  // one character at the line's baud rate (0: instant, as a pty alone)
  Duration egress_latency{};  // from a write to the port to the first character on the line (bus key)
};

struct ChannelStatistics {
  std::int64_t tx_frames = 0, rx_frames = 0, tx_bytes = 0, rx_bytes = 0;
  std::int64_t errors = 0, timeouts = 0, retries = 0, unexpected = 0;
};

class RequestChannel {
 public:
  RequestChannel(std::function<void(std::span<const std::uint8_t>)> send, ChannelSettings settings);

  // Queues a request (front = ahead of everything not yet sent, e.g. a start or a stop).
  void submit(Request request, bool front = false);
  // A parsed frame that is not a notification. False when it answered nothing in flight.
  bool on_frame(const uim242::Frame& frame, TimePoint now);
  // Sends the next request, handles the timeout; returns the next deadline or kNever.
  TimePoint process(TimePoint now);
  // A start frame goes out at `at` (kNever: no reservation): until then no request starts that
  // would still be waiting for its reply then (its instruction, a 24-character reply and
  // kReplyAllowance), nor any from `at` on, so the start is not queued behind a poll. Ends with
  // reserve(kNever) (the start) or by itself 5 kReplyAllowance after `at`.
  void reserve(TimePoint at) { reserved_at_ = at; }
  // While a move of the line awaits its trigger the stack announces how long an exchange of its
  // own may hold the line (its start wait): no request whose exchange_time() is longer begins,
  // nor a later one of the same node, until limit(Duration::max()). Other nodes' requests go by
  // it; a request to the gateway itself (node 0) goes by none; urgent ones are never held.
  void limit(Duration longest) { limit_ = longest; }
  static constexpr Duration kReplyAllowance = std::chrono::milliseconds(2);
  // A reply is counted this long in characters: longer than any frame the manuals document (13
  // bytes, EN/CN §12.2), so that a notification may come in between.
  static constexpr std::int64_t kReplyCharacters = 24;
  // How long the line is held by an exchange of `instruction` handed over now, as a reservation
  // judges it: the egress latency, `ADR select_node;` and its reply first (select_node 0: none),
  // the instruction, a reply of kReplyCharacters, and kReplyAllowance.
  [[nodiscard]] Duration exchange_time(const uim242::Instruction& instruction, int select_node) const;
  // Drops queued requests of `group` (the one in flight still completes, its callbacks are not called).
  void cancel(std::int64_t group);
  // Drops every request, queued and in flight, without calling back (the line is gone); the
  // gateway's target is unknown afterwards.
  void reset();
  [[nodiscard]] bool idle() const noexcept { return !in_flight_ && queue_.empty(); }
  // The request awaiting its reply, described, and how long ago it went on the wire; empty when
  // none does (SerialStack::exchange_under_way).
  [[nodiscard]] std::string under_way(TimePoint now) const;
  [[nodiscard]] const ChannelStatistics& statistics() const noexcept { return stats_; }
  [[nodiscard]] Duration character_time() const noexcept { return settings_.character_time; }
  void count_received(std::size_t bytes) noexcept { stats_.rx_bytes += static_cast<std::int64_t>(bytes); }
  void count_protocol_error() noexcept { ++stats_.errors; }

  // "u-drive (node 5): 'SPD 1000;'" — how reasons name a request.
  [[nodiscard]] static std::string describe(const Request& request);

 private:
  struct InFlight {
    Request request;
    bool is_selection = false;  // the ADR sent on behalf of `request`
    int attempts = 0;
    TimePoint deadline;
    bool cancelled = false;
    TimePoint on_wire{};  // its last character on the wire (the last attempt)
  };
  void transmit(InFlight& f, TimePoint now);
  // exchange_time() of `r` handed over now: with its selection when the gateway targets another node.
  [[nodiscard]] Duration exchange_time(const Request& r) const;
  // The queued request that may go next under limit_ (queue_.end(): none).
  [[nodiscard]] std::deque<Request>::iterator next_to_send();
  void finish_failure(const std::string& reason, bool timed_out, TimePoint now);

  std::function<void(std::span<const std::uint8_t>)> send_;
  ChannelSettings settings_;
  std::deque<Request> queue_;
  std::optional<InFlight> in_flight_;
  int selected_ = 0;        // the gateway's current target; 0 = unknown
  TimePoint hold_until_{};  // nothing is sent before (the pause after an STO)
  TimePoint reserved_at_ = kNever;
  Duration limit_ = Duration::max();
  ChannelStatistics stats_;
};

}  // namespace motion::uim242_driver
