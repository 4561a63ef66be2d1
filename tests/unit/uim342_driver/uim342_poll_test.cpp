// Uim342Stack status polling on a bit-timed wire, on a simulated clock: the simulated bus's
// passive core (simbus::Bus: frames serialized for their exact bit time, arbitration by
// identifier, own echo at end of frame) between the stack and simulated UIM342 drives
// (sim::Uim342Drive, answering at once). Every frame is counted on the wire, so the tests judge
// what the bus carried, not what the stack meant to send:
//   - asked for more than the bus carries, polls fill at least 90% of it, every drive in turn,
//     without a timeout or retry;
//   - a command handed to the transport during saturated polling has at most one poll frame of
//     ours ahead of it on the wire;
//   - when the bus is not the limit, each drive is polled at the asked rate, no faster;
//   - a silent drive does not hold the others' polls back.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <optional>
#include <set>

#include "uim342_wire_rig.hpp"

namespace motion::gateway {
namespace {

using namespace test;  // NOLINT(google-build-using-namespace): the rig's types

constexpr std::int8_t kStop = gateway_command_t::STOP;

// Wire bits of the frames that ended within [from, to), all or the polls (MS requests and ACKs) only.
std::uint64_t wire_bits(const std::vector<OnWire>& wire, TimePoint from, TimePoint to, bool polls_only) {
  std::uint64_t bits = 0;
  for (const auto& w : wire) {
    if (w.end_of_frame >= from && w.end_of_frame < to && (!polls_only || w.is_poll()))
      bits += can::frame_bits(w.frame).total;
  }
  return bits;
}

// The start at `at`, with an ENABLE of `axis` standing in for its frame: fire() ends the
// reservation (trigger 0 starts nothing), the ENABLE's MO frame is the first handed over (a0, the
// first node the stack serves, goes before other commands released at the start, as fire()'s own
// start frames do), and how long it waited on the wire after `at` is returned (nullopt: not so, or
// never answered).
std::optional<Duration> stand_in_start(WireRig& rig, int axis, TimePoint at) {
  rig.stack->fire(0, rig.now);
  const auto handed_before = rig.handed.size();
  const auto id = rig.execute(kEnable, fmt::format("a{}", axis));
  const auto mo = *uim342::instruction_frame(static_cast<std::uint8_t>(5 + axis), uim342::request::driver_on(true));
  if (!rig.run_until([&] { return rig.terminal(id).has_value(); }, milliseconds(200))) return std::nullopt;
  if (rig.handed.size() <= handed_before || rig.handed[handed_before] != std::make_pair(at, mo)) return std::nullopt;
  const auto on_wire = std::find_if(rig.wire.begin(), rig.wire.end(),
                                    [&](const OnWire& w) { return w.ours && w.frame == mo && w.end_of_frame >= at; });
  if (on_wire == rig.wire.end()) return std::nullopt;
  return on_wire->start() - at;
}

// 120 drives at 20 Hz ask for 2,400 polls/s (9,600 frames); 1 Mbit/s carries about 2,200. Polls
// fill at least 90% of the bus (measured: every bit on the wire counted over one second), every
// drive gets its turn, and no request times out.
TEST(Uim342PollWire, PollsFillAtLeastNinetyPercentOfTheBusWhenAskedForMore) {
  WireRig rig(120, 20);
  rig.start();
  rig.run_for(milliseconds(200));  // into the poll rhythm
  const auto counters = rig.stack->counters();
  const auto updates = rig.out.updates;
  const TimePoint from = rig.now;
  rig.run_for(std::chrono::seconds(1));
  const double all = static_cast<double>(wire_bits(rig.wire, from, rig.now, false)) / kBitrate;
  const double polls = static_cast<double>(wire_bits(rig.wire, from, rig.now, true)) / kBitrate;
  EXPECT_GE(polls, 0.90) << "share of the bus the polls used";
  EXPECT_LE(all, 1.001);  // frames ending in the window, counted whole
  std::int64_t fewest = 1'000'000;
  std::int64_t total = 0;
  for (const auto& [axis, count] : rig.out.updates) {
    const auto it = updates.find(axis);
    const auto n = count - (it == updates.end() ? 0 : it->second);
    fewest = std::min(fewest, n);
    total += n;
  }
  EXPECT_GE(fewest, total / 120 * 9 / 10) << "every drive polled in turn";
  EXPECT_LT(total, 120 * 20) << "the asked rate does not fit: the bus is the limit";
  EXPECT_EQ(rig.stack->counters().timeouts - counters.timeouts, 0);
  EXPECT_EQ(rig.stack->counters().retries - counters.retries, 0);
  std::printf(
      "120 drives at 20 Hz, 1 Mbit/s: polls %.1f%% of the bus (all frames %.1f%%), %lld updates/s, "
      "fewest per drive %lld\n",
      100 * polls, 100 * all, static_cast<long long>(total), static_cast<long long>(fewest));
}

// During saturated polling, commands (ENABLE: one MO frame) are executed at 60 instants spread
// over a poll cycle. Each MO frame is handed to the transport ahead of every poll not yet handed
// over, so at most one poll frame of ours ends on the wire between its hand-over and its own end.
TEST(Uim342PollWire, ACommandFrameWaitsBehindAtMostOnePollFrame) {
  WireRig rig(120, 20);
  rig.start();
  rig.run_for(milliseconds(100));
  std::vector<double> waits_us;
  std::vector<double> exec_us;
  const auto poll_frame = can::frame_duration(
      *uim342::instruction_frame(5, uim342::request::get(uim342::MotionStatusIndex::kKinematics)), kBitrate);
  for (int k = 0; k < 60; ++k) {
    rig.run_for(microseconds(977 + 37 * k));  // instants at every phase of the poll rhythm
    const TimePoint executed = rig.now;
    const auto axis = k % 120;
    const auto handed_before = rig.handed.size();
    const auto id = rig.execute(kEnable, fmt::format("a{}", axis));
    ASSERT_TRUE(rig.run_until([&] { return rig.terminal(id).has_value(); }, milliseconds(200)));
    EXPECT_EQ(rig.terminal(id)->status, kDone) << rig.terminal(id)->reason;
    const auto mo = uim342::instruction_frame(static_cast<std::uint8_t>(5 + axis), uim342::request::driver_on(true));
    ASSERT_TRUE(mo.ok());
    // When the MO frame went to the transport, and when it ended on the wire.
    const auto handed = std::find_if(rig.handed.begin() + static_cast<std::ptrdiff_t>(handed_before), rig.handed.end(),
                                     [&](const auto& h) { return h.second == *mo; });
    ASSERT_NE(handed, rig.handed.end());
    const auto on_wire = std::find_if(rig.wire.begin(), rig.wire.end(), [&](const OnWire& w) {
      return w.ours && w.frame == *mo && w.end_of_frame >= handed->first;
    });
    ASSERT_NE(on_wire, rig.wire.end());
    const auto polls_ahead = std::count_if(rig.wire.begin(), on_wire, [&](const OnWire& w) {
      return w.ours && w.is_poll() && w.end_of_frame > handed->first;
    });
    EXPECT_LE(polls_ahead, 1) << "command " << k << " waited behind " << polls_ahead << " poll frames";
    waits_us.push_back(std::chrono::duration<double, std::micro>(on_wire->start() - handed->first).count());
    exec_us.push_back(std::chrono::duration<double, std::micro>(on_wire->start() - executed).count());
  }
  std::sort(waits_us.begin(), waits_us.end());
  std::sort(exec_us.begin(), exec_us.end());
  EXPECT_EQ(rig.stack->counters().timeouts, 0);
  std::printf(
      "command frame: handed -> on the wire p50 %.0f / max %.0f us; execute -> on the wire p50 %.0f / max %.0f us; "
      "one poll request frame %.0f us\n",
      waits_us[waits_us.size() / 2], waits_us.back(), exec_us[exec_us.size() / 2], exec_us.back(),
      std::chrono::duration<double, std::micro>(poll_frame).count());
}

// A start reserved start_wait() ahead (prepare_fire, as the gateway does when it hears a trigger)
// finds the bus quiet: while polls fill it (120 drives asked 20 Hz), the stack hands over no poll
// whose answer could still be on the wire at the reserved instant, so a frame handed over then
// starts on the wire at once. Without the reservation, the same frame waits behind a poll exchange
// at most phases of the poll rhythm.
TEST(Uim342PollWire, AReservedStartFindsTheBusQuiet) {
  WireRig rig(120, 20);
  rig.start();
  rig.run_for(milliseconds(100));
  const Duration wait = rig.stack->start_wait();
  ASSERT_GT(wait, Duration::zero());
  int reserved_quiet = 0;
  int unreserved_waited = 0;
  for (int k = 0; k < 40; ++k) {
    rig.run_for(microseconds(977 + 37 * k));  // every phase of the poll rhythm
    const bool reserve = k % 2 == 0;
    const TimePoint at = rig.now + wait;
    if (reserve) rig.stack->prepare_fire(at, rig.now);
    ASSERT_TRUE(rig.run_for(at - rig.now));
    ASSERT_EQ(rig.now, at);
    const auto waited = stand_in_start(rig, (7 * k) % 120, at);
    ASSERT_TRUE(waited) << "start " << k;
    const bool at_once = *waited < microseconds(2);  // within a bit time
    if (reserve) {
      EXPECT_TRUE(at_once) << "reserved start " << k << " waited "
                           << std::chrono::duration<double, std::micro>(*waited).count() << " us";
      reserved_quiet += at_once ? 1 : 0;
    } else {
      unreserved_waited += at_once ? 0 : 1;
    }
  }
  EXPECT_EQ(reserved_quiet, 20);
  EXPECT_GT(unreserved_waited, 10) << "without a reservation the frames should mostly meet a poll";
  EXPECT_EQ(rig.stack->counters().timeouts, 0);
}

// Commands heard while a start is reserved wait for it as polls do: 16 drives are enabled when the
// gateway hears the trigger (start_wait() before the send time), at several phases of the poll
// rhythm. An MO frame whose answer could still be on the wire at the send time is not handed over
// before it, a frame handed over at the start begins on the wire at once, and every ENABLE ends
// DONE. Without the reservation the 16 exchanges (about 3.5 ms of frames at 1 Mbit/s, against a
// start wait of 1.8 ms) are still on the wire then. A stop is never held.
TEST(Uim342PollWire, CommandsHeardDuringAReservedStartWaitForItButStopsDoNot) {
  WireRig rig(120, 20);
  rig.start();
  rig.run_for(milliseconds(100));
  const Duration wait = rig.stack->start_wait();
  int unreserved_waited = 0;
  for (int k = 0; k < 16; ++k) {
    const bool reserve = k % 2 == 0;
    rig.run_for(microseconds(977 + 137 * k));
    const TimePoint at = rig.now + wait;
    if (reserve) rig.stack->prepare_fire(at, rig.now);
    const auto handed_before = rig.handed.size();
    std::vector<std::int64_t> ids;
    std::vector<can::Frame> mo_frames;
    for (int j = 0; j < 16; ++j) {
      const int axis = (16 * k + j) % 119 + 1;  // never a0, the start's stand-in
      ids.push_back(rig.execute(kEnable, fmt::format("a{}", axis)));
      mo_frames.push_back(
          *uim342::instruction_frame(static_cast<std::uint8_t>(5 + axis), uim342::request::driver_on(true)));
    }
    const int stopped = (16 * k + 40) % 119 + 1;
    rig.execute(kStop, fmt::format("a{}", stopped));
    const auto st = *uim342::instruction_frame(static_cast<std::uint8_t>(5 + stopped), uim342::request::stop());
    ASSERT_TRUE(rig.run_for(at - rig.now));
    std::size_t mo_before = 0;
    bool stop_went = false;
    for (auto h = rig.handed.begin() + static_cast<std::ptrdiff_t>(handed_before); h != rig.handed.end(); ++h) {
      mo_before += std::find(mo_frames.begin(), mo_frames.end(), h->second) != mo_frames.end() ? 1U : 0U;
      stop_went = stop_went || h->second == st;
    }
    EXPECT_TRUE(stop_went) << "the stop was held";
    if (reserve) { EXPECT_LT(mo_before, 16U) << "no MO frame waited for the start"; }
    const auto waited = stand_in_start(rig, 0, at);
    ASSERT_TRUE(waited) << "start " << k;
    const bool at_once = *waited < microseconds(2);  // within a bit time
    if (reserve) {
      EXPECT_TRUE(at_once) << "reserved start " << k << " waited "
                           << std::chrono::duration<double, std::micro>(*waited).count() << " us";
    } else {
      unreserved_waited += at_once ? 0 : 1;
    }
    for (const auto id : ids) {
      ASSERT_TRUE(rig.run_until([&] { return rig.terminal(id).has_value(); }, milliseconds(200)));
      EXPECT_EQ(rig.terminal(id)->status, kDone) << rig.terminal(id)->reason;
    }
  }
  EXPECT_EQ(unreserved_waited, 8) << "without a reservation the commands' exchanges hold the start frame back";
  EXPECT_EQ(rig.stack->counters().timeouts, 0);
}

// A command's answer arbitrates against the polls' frames on the wire: from the drives of the
// highest node ids (the highest identifiers, UIM342 manual §2.5) it loses to every poll request and
// to every lower drive's answer. While polls fill the bus (120 drives asked 20 Hz), an ENABLE of
// each of the 30 highest drives, at 240 phases of the poll rhythm, ends DONE within a few poll
// exchanges: no poll is handed over while a command awaits its answer.
TEST(Uim342PollWire, ACommandsAnswerFromTheHighestNodeIsNotStarvedByPolls) {
  WireRig rig(120, 20);
  rig.start();
  rig.run_for(milliseconds(100));
  Duration longest{};
  for (int k = 0; k < 240; ++k) {
    rig.run_for(microseconds(977 + 37 * k));
    const TimePoint executed = rig.now;
    const auto id = rig.execute(kEnable, fmt::format("a{}", 119 - k % 30));
    ASSERT_TRUE(rig.run_until([&] { return rig.terminal(id).has_value(); }, milliseconds(500)));
    EXPECT_EQ(rig.terminal(id)->status, kDone) << rig.terminal(id)->reason;
    longest = std::max(longest, rig.now - executed);
  }
  EXPECT_LE(longest, milliseconds(5)) << "the polls in flight and the ENABLE's own exchange: about 1 ms";
  EXPECT_EQ(rig.stack->counters().timeouts, 0);
  EXPECT_EQ(rig.stack->counters().retries, 0);
  std::printf("ENABLE of the 30 highest drives under saturated polls: execute -> DONE at most %.0f us\n",
              std::chrono::duration<double, std::micro>(longest).count());
}

// 8 drives at 20 Hz need about 7% of 1 Mbit/s: each is polled exactly at the asked rate, and the
// rest of the bus stays idle.
TEST(Uim342PollWire, PollsKeepToTheAskedRateWhenTheBusIsNotTheLimit) {
  WireRig rig(8, 20);
  rig.start();
  rig.run_for(milliseconds(200));
  const auto updates = rig.out.updates;
  const TimePoint from = rig.now;
  rig.run_for(std::chrono::seconds(1));
  for (const auto& [axis, count] : rig.out.updates) {
    const auto it = updates.find(axis);
    const auto n = count - (it == updates.end() ? 0 : it->second);
    EXPECT_GE(n, 19) << axis;
    EXPECT_LE(n, 21) << axis;
  }
  const double all = static_cast<double>(wire_bits(rig.wire, from, rig.now, false)) / kBitrate;
  EXPECT_LT(all, 0.10);
}

// One of 120 drives falls silent during saturated polling: its requests time out and it goes
// offline (and is tried again after its back-off), while the others' polls still fill the bus:
// an unanswered poll holds the later ones back only for a few exchanges, not until its timeout.
TEST(Uim342PollWire, ASilentDriveDoesNotHoldTheOthersPollsBack) {
  WireRig rig(120, 20);
  rig.start();
  rig.run_for(milliseconds(100));
  const auto counters = rig.stack->counters();
  rig.silent.insert("d60");
  const TimePoint from = rig.now;
  rig.run_for(std::chrono::seconds(1));
  const double polls = static_cast<double>(wire_bits(rig.wire, from, rig.now, true)) / kBitrate;
  EXPECT_GE(polls, 0.90) << "share of the bus the other drives' polls used";
  EXPECT_FALSE(rig.stack->status("a60")->online);
  EXPECT_GE(rig.stack->counters().timeouts - counters.timeouts, 1) << "d60 timed out";
  EXPECT_LE(rig.stack->counters().timeouts - counters.timeouts, 3) << "only d60 timed out (each try once)";
  std::printf("one of 120 drives silent: polls %.1f%% of the bus\n", 100 * polls);
}

// A command to a drive that has gone silent holds the polls back for kCommandAnswerWindow (10 ms)
// after each of its tries, not until its timeout: while its three tries run out (50 ms each), the
// other drives' polls still fill most of the bus.
TEST(Uim342PollWire, ACommandToASilentDriveHoldsThePollsBackOnlyBriefly) {
  WireRig rig(120, 20);
  rig.start();
  rig.run_for(milliseconds(100));
  rig.silent.insert("d60");
  const TimePoint from = rig.now;
  const auto id = rig.execute(kEnable, "a60");
  ASSERT_TRUE(rig.run_until([&] { return rig.terminal(id).has_value(); }, milliseconds(500)));
  EXPECT_EQ(rig.terminal(id)->status, kFailed);
  const Duration tries = rig.now - from;
  EXPECT_GE(tries, milliseconds(150)) << "three tries of 50 ms";
  const double polls = static_cast<double>(wire_bits(rig.wire, from, rig.now, true)) /
                       (kBitrate * std::chrono::duration<double>(tries).count());
  EXPECT_GE(polls, 0.70) << "share of the bus the polls used while the ENABLE went unanswered";
  std::printf("ENABLE of a silent drive, %.0f ms of tries: polls %.1f%% of the bus meanwhile\n",
              std::chrono::duration<double, std::milli>(tries).count(), 100 * polls);
}

}  // namespace
}  // namespace motion::gateway
