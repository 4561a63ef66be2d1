// The adaptive trigger lead: how far ahead of its publication a trigger of several buses schedules
// the start (SYNC_TRIGGER2's first hand-over), so that every gateway of the move has heard it by
// its send time.
//
// Every gateway says when it heard each trigger (TRIGGER_HEARD, trigger_heard_t); the delay from
// the trigger's publication to that moment is one sample of its bus (wall clocks: the delay of
// LCM, the host, the signature check, and any offset between the two machines' clocks). Per bus
// the last `window` samples are kept. A bus's envelope is the largest of its samples, each halved
// for every `half_life` samples of the bus that came after it:
//     envelope(bus) = max over its samples i of delay_i x 2^(-age_i / half_life)
// (the newest sample has age 0). The lead for a move is
//     clamp(max over its buses of envelope(bus) x margin + floor, min, max)
// (max = coordinator.trigger_lead_ms, min = coordinator.trigger_lead_min_ms), and the configured
// maximum while any of its buses has fewer than `enough` samples. A trigger heard late (after its
// send time: the gateway fires at once, as it always did) took longer than the lead in force: its
// sample raises the lead at once, up to the maximum, and its weight then halves every `half_life`
// triggers, so one wake-up of an overloaded host costs a few dozen moves a longer lead rather
// than a whole window, while delays that keep coming back keep the lead up. Single-bus triggers
// are samples too (their send time is "now", so they are always late; the delay is what counts).
//
// Passive: wall-clock microseconds in, no clock of its own.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <string>

namespace motion::coordinator {

class TriggerLead {
 public:
  struct Settings {
    std::int64_t max_us = 30'000;   // coordinator.trigger_lead_ms: the start value and upper bound
    std::int64_t min_us = 5'000;    // coordinator.trigger_lead_min_ms: the lower bound
    double margin = 1.5;            // on the p99 of the samples
    std::int64_t floor_us = 2'000;  // added after the margin
    std::size_t window = 64;        // samples kept per bus
    std::size_t enough = 8;         // samples a bus needs before its lead adapts
    double half_life = 8;           // samples after which a delay weighs half (> 0)
  };
  static constexpr std::size_t kRememberedTriggers = 64;  // triggers whose hearing is taken as a sample

  explicit TriggerLead(Settings settings) : settings_(settings) {}

  // A trigger this coordinator published at `utime` (its SYNC_TRIGGER2's utime).
  void published(std::int64_t trigger_id, std::int64_t utime);
  // The gateway of `bus` heard `trigger_id` at `heard_utime`: a sample of `bus` when the trigger is
  // one of the last kRememberedTriggers published and this bus's first hearing of it; false (no
  // sample) otherwise.
  bool heard(const std::string& bus, std::int64_t trigger_id, std::int64_t heard_utime);
  // One sample of `bus` (negative delays, clocks apart, count as 0).
  void add(const std::string& bus, std::int64_t delay_us);

  // The lead for a trigger of `buses`, microseconds.
  [[nodiscard]] std::int64_t lead_us(const std::set<std::string>& buses) const;
  // The envelope of the samples of `bus` (nullopt: none), microseconds rounded to the nearest.
  [[nodiscard]] std::optional<std::int64_t> envelope_us(const std::string& bus) const;
  [[nodiscard]] std::size_t samples(const std::string& bus) const;
  [[nodiscard]] const Settings& settings() const { return settings_; }

 private:
  struct Published {
    std::int64_t utime = 0;
    std::set<std::string> heard_by;
  };
  Settings settings_;
  std::map<std::string, std::deque<std::int64_t>> delays_;  // bus -> its last `window` delays
  std::map<std::int64_t, Published> published_;             // trigger id -> when, and who heard it
};

}  // namespace motion::coordinator
