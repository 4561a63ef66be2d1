// The passive protocol core of one serial line, as gateway::SerialBusDriver (serial_bus_driver.hpp)
// drives it: fd-free and clock-free (every call gets `now`); bytes go out through the write
// function the core was built with. Implemented by adam_driver::AdamStack (Modbus RTU) and
// uim242_driver::Uim242Stack (UIM2501/2502 string protocol).
// Thread contract: one thread (the gateway's loop); no call blocks.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include <motionlcm/bus_stats_t.hpp>
#include <motionlcm/gateway_command_t.hpp>

#include "motion/core/clock.hpp"
#include "motion/gateway/command_ledger.hpp"

namespace motion::gateway {

class SerialStack {
 public:
  virtual ~SerialStack() = default;
  // The port is open (again): identify and set up the drives, begin polling.
  virtual void start(TimePoint now) = 0;
  virtual void on_bytes(std::span<const std::uint8_t> bytes, TimePoint now) = 0;
  // Timeouts, polls, the next request; returns the next deadline or kNever.
  virtual TimePoint process(TimePoint now) = 0;
  virtual void execute(const motionlcm::gateway_command_t& command, TimePoint now) = 0;
  virtual void fire(std::int64_t trigger_id, TimePoint now) = 0;
  // A start frame goes out at `at` (a scheduled trigger): the core starts no transaction that
  // would still hold the line then, so the start frame is not queued behind a poll. The
  // reservation ends with the next fire() or a few milliseconds after `at`. Default: ignored.
  virtual void reserve_line(TimePoint /*at*/, TimePoint /*now*/) {}
  // The longest exchange the core begins on its own (a poll) as reserve_line() judges it: a start
  // reserved at least this long before `at` finds the line free then (LINE_TIMING). Default: 0.
  [[nodiscard]] virtual Duration start_wait() const { return Duration::zero(); }
  // BusDriver::start_delay: fired that long after the reserved time, the start frame of
  // `trigger_id` goes out at once. Default: 0.
  [[nodiscard]] virtual Duration start_delay(std::int64_t /*trigger_id*/) const { return Duration::zero(); }
  // The exchange holding the line at `now`, as the core's reasons name it and how long ago its
  // request ended (or the silence the line keeps after it); empty when the line is free. A start fired meanwhile waits for its end: the
  // driver says so in the log. Default: empty.
  [[nodiscard]] virtual std::string exchange_under_way(TimePoint /*now*/) const { return {}; }
  // The port hung up: every running command ends FAILED, the drives are offline until start().
  virtual void line_lost(const std::string& why, TimePoint now) = 0;
  [[nodiscard]] virtual motionlcm::bus_stats_t statistics() const = 0;
  [[nodiscard]] virtual bool ready() const = 0;
  // The command ledger's counters (its parts by lifecycle state, what it refused): LEDGER_STATS.
  // Default: none.
  [[nodiscard]] virtual LedgerCounters ledger_counters() const { return {}; }
};

}  // namespace motion::gateway
