// UIM242 ICF (manual §5.1: an ICFG write is burned into EEPROM "and the controller will auto
// reboot", for a time not given). Under a simulated reboot of 0 ms and of 500 ms, set-up writes
// ICF once per controller, waits the reboot out, reads the value back and becomes ready; a second
// gateway start finds ICFG as configured and writes nothing. Then a synchronized move (one
// trigger) lands both controllers on their targets (simulator ground truth). A controller found
// moving by a starting gateway is stopped before its set-up is written.
#include <gtest/gtest.h>

#include <cmath>

#include <motionlcm/event_t.hpp>

#include "bench.hpp"
#include "motion/gateway/serial_line.hpp"
#include "motion/sim/uim242_gateway_sim.hpp"
#include "motion/uim242/feedback.hpp"
#include "motion/uim242/instruction.hpp"
#include "motion/uim242_driver/uim242_stack.hpp"

namespace motion::truth {
namespace {

using motionlcm::gateway_command_t;

constexpr const char* kLine = R"(
buses:
  - {name: rs232, transport: "simserial:rs232", baud: 57600, request_timeout_ms: 50, retries: 1, poll_hz: 20}
drives:
  - {name: u1-drive, family: uim242, bus: rs232, node_id: 5, setup: {micro_steps: 16, current_a: 1.0, icfg: 1ANSWER}}
  - {name: u2-drive, family: uim242, bus: rs232, node_id: 6, setup: {micro_steps: 16, current_a: 1.0, icfg: 1ANSWER}}
axes:
  - {name: u1, drive: u1-drive, unit: mm, steps_per_unit: 160, limits: {min: -100, max: 100, velocity: 30, acceleration: 150}}
  - {name: u2, drive: u2-drive, unit: mm, steps_per_unit: 160, limits: {min: -100, max: 100, velocity: 30, acceleration: 150},
     homing: {method: switch, input: 1, velocity: -5, offset: -1}}
simulation:
  home_switches: {u2-drive: -1600}
  variants: {u1-drive: {reboot_ms: REBOOT, spd0_position_move: SPD0}, u2-drive: {reboot_ms: REBOOT, spd0_position_move: SPD0}}
)";

// `answer`: the set-up key spd0_position_move ("" = not configured: detected).
std::string lab(const std::string& reboot_ms, const std::string& spd0 = "holds", const std::string& answer = "") {
  std::string yaml = kLine;
  const auto put = [&yaml](const std::string& key, const std::string& value) {
    for (auto at = yaml.find(key); at != std::string::npos; at = yaml.find(key)) yaml.replace(at, key.size(), value);
  };
  put("REBOOT", reboot_ms);
  put("SPD0", spd0);
  put("ANSWER", answer.empty() ? "" : ", spd0_position_move: " + answer);
  return yaml;
}

SerialBench::CoreFactory uim242_core(SerialBench& bench) {
  return [&bench](std::function<void(std::span<const std::uint8_t>)> send, gateway::GatewayOutput& out) {
    uim242_driver::CoreContext context;
    context.send = std::move(send);
    context.out = &out;
    return std::make_unique<uim242_driver::Uim242Stack>(*bench.config, "rs232", context);
  };
}

// HOME u2 (S1 falling, toward min at 5 mm/s = 800 counts/s, offset -1 mm = -160 counts): the
// axis runs from where it stands onto the simulated switch edge (-1600 counts from power-up),
// stops there (sensor action reset + e-stop, sampled every millisecond: within one count past the
// edge) and counts from the offset.
void expect_homes_on_its_switch(SerialBench& bench, const std::string& label) {
  auto& line = dynamic_cast<sim::Uim242GatewaySim&>(*bench.device);
  const std::int64_t before = line.physical_position("u2-drive", bench.now);
  ASSERT_GT(before, -1600) << "u2 starts on the switch";
  const std::size_t starts_before = bench.reports_of("u2-drive", kStarted).size();
  motionlcm::axis_command_t home = axis_move("u2", -160, -800, 0);
  const auto id = bench.execute(command(gateway_command_t::HOME, "rs232", {home}));
  const auto done = bench.finish(id);
  ASSERT_EQ(done.status, kDone) << done.reason;
  const std::int64_t after = line.physical_position("u2-drive", bench.now);
  EXPECT_EQ(bench.reports_of("u2-drive", kStarted).size(), starts_before + 1) << "no search run";
  EXPECT_LE(after, -1600) << "stopped before the switch edge";
  EXPECT_GE(after, -1601) << "ran past the switch edge";
  EXPECT_EQ(line.position("u2-drive", bench.now), -160) << "the offset is not where the switch is";
  EXPECT_FALSE(line.moving("u2-drive", bench.now));
  std::printf("%s: HOME u2 from %lld counts: stopped at %lld (switch edge -1600), counter %lld\n", label.c_str(),
              static_cast<long long>(before), static_cast<long long>(after),
              static_cast<long long>(line.position("u2-drive", bench.now)));
}

class Uim242Reboot : public ::testing::TestWithParam<std::string> {};

TEST_P(Uim242Reboot, IcfIsWrittenOnceTheRebootWaitedOutAndAMoveLands) {
  SerialBench bench(lab(GetParam()), "rs232", sim::uim242_line_factory());
  bench.attach(uim242_core(bench));
  ASSERT_TRUE(bench.run_until([&] { return bench.core->ready(); }, std::chrono::seconds(10)))
      << "never ready; mismatches: " << bench.out.event_text(motionlcm::event_t::CONFIG_MISMATCH);
  auto& line = dynamic_cast<sim::Uim242GatewaySim&>(*bench.device);
  EXPECT_EQ(line.icf_writes("u1-drive"), 1);
  EXPECT_EQ(line.icf_writes("u2-drive"), 1);
  EXPECT_EQ(bench.out.event_text(motionlcm::event_t::OFFLINE), "") << "the reboot was taken for a dead drive";

  // A gateway restart finds ICFG as configured: no EEPROM write, no reboot.
  bench.attach(uim242_core(bench));
  ASSERT_TRUE(bench.run_until([&] { return bench.core->ready(); }, std::chrono::seconds(5)));
  EXPECT_EQ(line.icf_writes("u1-drive"), 1);
  EXPECT_EQ(line.icf_writes("u2-drive"), 1);

  const auto enabled =
      bench.execute(command(gateway_command_t::ENABLE, "rs232", {axis_move("u1", 0, 0, 0), axis_move("u2", 0, 0, 0)}));
  ASSERT_EQ(bench.finish(enabled).status, kDone) << bench.finish(enabled).reason;
  const auto move = bench.execute(command(gateway_command_t::ARM_MOVE, "rs232",
                                          {axis_move("u1", 1600, 3200, 16000), axis_move("u2", -800, 3200, 16000)}, 9));
  bench.run_for(std::chrono::milliseconds(300));
  bench.core->fire(9, bench.now);
  const auto done = bench.finish(move);
  ASSERT_EQ(done.status, kDone) << done.reason;
  // Equal speeds: one global `gSPD` started both, as reported.
  const auto u1 = bench.reports_of("u1-drive", kStarted);
  const auto u2 = bench.reports_of("u2-drive", kStarted);
  ASSERT_EQ(u1.size(), 1u);
  ASSERT_EQ(u2.size(), 1u);
  EXPECT_EQ(u1[0].frame_utime, u2[0].frame_utime) << "reported " << bench.mechanism_of(move);
  EXPECT_EQ(bench.mechanism_of(move), "broadcast");
  EXPECT_EQ(line.position("u1-drive", bench.now), 1600);
  EXPECT_EQ(line.position("u2-drive", bench.now), -800);
  expect_homes_on_its_switch(bench, "reboot_ms " + GetParam());
}

INSTANTIATE_TEST_SUITE_P(Variants, Uim242Reboot, ::testing::Values("0", "500"),
                         [](const ::testing::TestParamInfo<std::string>& p) { return "reboot_ms_" + p.param; });

// Move start (docs/protocols.md, UIM242 #3): what a controller does with `STP n;` loaded at
// desired speed 0 is not shown by the manuals. Under every simulated reading, found by the first
// move's probe or configured, two armed moves (one speed: one global start; two speeds: axis by
// axis) leave the shafts still until the trigger, land exactly, and STARTED's time, mechanism and
// skew cover the simulated controllers' real start times.
struct Spd0Case {
  std::string variant;  // simulation.variants spd0_position_move
  std::string answer;   // set-up spd0_position_move ("": detected)
};

class Uim242Spd0 : public ::testing::TestWithParam<Spd0Case> {};

TEST_P(Uim242Spd0, ArmedMovesHoldUntilTheTriggerAndLand) {
  const auto& param = GetParam();
  SerialBench bench(lab("0", param.variant, param.answer), "rs232", sim::uim242_line_factory());
  bench.attach(uim242_core(bench));
  ASSERT_TRUE(bench.run_until([&] { return bench.core->ready(); }, std::chrono::seconds(10)));
  auto& line = dynamic_cast<sim::Uim242GatewaySim&>(*bench.device);
  auto& core = dynamic_cast<uim242_driver::Uim242Stack&>(*bench.core);
  const auto enabled =
      bench.execute(command(gateway_command_t::ENABLE, "rs232", {axis_move("u1", 0, 0, 0), axis_move("u2", 0, 0, 0)}));
  ASSERT_EQ(bench.finish(enabled).status, kDone);
  const bool holds = (param.answer.empty() ? param.variant : param.answer) == "holds";

  struct Round {
    std::int64_t u1, u2;
    double v1, v2;
    const char* mechanism;
  };
  for (const Round& round : {Round{1600, -800, 3200, 3200, "broadcast"}, Round{0, 0, 3200, 1600, "sequential"}}) {
    const std::int64_t trigger = round.u1 != 0 ? 9 : 10;
    const auto move = bench.execute(
        command(gateway_command_t::ARM_MOVE, "rs232",
                {axis_move("u1", round.u1, round.v1, 16000), axis_move("u2", round.u2, round.v2, 16000)}, trigger));
    ASSERT_TRUE(bench.run_until(
        [&] {
          return std::any_of(bench.out.replies.begin(), bench.out.replies.end(), [&](const auto& r) {
            return r.command_id == move && r.status == motionlcm::gateway_reply_t::ARMED;
          });
        },
        std::chrono::seconds(2)))
        << "never armed: " << (bench.out.terminal(move) ? bench.out.terminal(move)->reason : "");
    // Armed: nothing moves until the trigger.
    const std::int64_t u1_armed = line.position("u1-drive", bench.now);
    const std::int64_t u2_armed = line.position("u2-drive", bench.now);
    const std::size_t reports_armed = bench.reports.size();
    bench.run_for(std::chrono::milliseconds(200));
    EXPECT_EQ(line.position("u1-drive", bench.now), u1_armed) << "u1 moved before the trigger";
    EXPECT_EQ(line.position("u2-drive", bench.now), u2_armed) << "u2 moved before the trigger";
    EXPECT_EQ(bench.reports.size(), reports_armed) << "a controller started before the trigger";
    const std::int64_t fired_us =
        std::chrono::duration_cast<std::chrono::microseconds>(bench.now.time_since_epoch()).count();
    bench.core->fire(trigger, bench.now);
    const auto done = bench.finish(move);
    ASSERT_EQ(done.status, kDone) << done.reason;
    EXPECT_EQ(line.position("u1-drive", bench.now), round.u1);
    EXPECT_EQ(line.position("u2-drive", bench.now), round.u2);
    const auto started = std::find_if(bench.out.replies.begin(), bench.out.replies.end(), [&](const auto& r) {
      return r.command_id == move && r.status == motionlcm::gateway_reply_t::STARTED;
    });
    ASSERT_NE(started, bench.out.replies.end());
    EXPECT_EQ(started->start_mechanism, std::string(holds ? "" : "crawl_") + round.mechanism);
    // The simulated controllers' starts (the `;` that set each shaft moving) lie within STARTED's
    // span: from its time to its time + the predicted skew.
    std::vector<std::int64_t> starts;
    for (const auto& r : bench.reports) {
      if (r.kind == kStarted && r.frame_utime >= fired_us) starts.push_back(r.frame_utime);
    }
    ASSERT_EQ(starts.size(), 2u);
    const auto [first, last] = std::minmax_element(starts.begin(), starts.end());
    // The bench's wire delivers an instruction as its first character leaves; the core times it
    // at its last character's end: one instruction (at most 16 characters) earlier at most.
    const auto instruction_us = std::chrono::duration_cast<std::chrono::microseconds>(
                                    gateway::serial_line_settings(*bench.config->find_bus("rs232")).wire_time(16))
                                    .count();
    EXPECT_GE(*first, started->trigger_utime - instruction_us);
    EXPECT_LE(*last, started->trigger_utime + std::llround(started->predicted_skew_us));
    EXPECT_GE(*first, fired_us);
    std::printf(
        "spd0_position_move %s (set-up %s): %s, STARTED %s at +%lld us, skew %.0f us; controllers started "
        "at +%lld and +%lld us\n",
        param.variant.c_str(), param.answer.empty() ? "detect" : param.answer.c_str(), round.mechanism,
        started->start_mechanism.c_str(), static_cast<long long>(started->trigger_utime - fired_us),
        started->predicted_skew_us, static_cast<long long>(*first - fired_us),
        static_cast<long long>(*last - fired_us));
  }
  // A jog is a position move to the axis limit: it runs (and stops) under every reading too.
  const auto jog = bench.execute(command(gateway_command_t::JOG, "rs232", {axis_move("u1", 0, 1600, 16000)}));
  ASSERT_EQ(bench.finish(jog).status, kDone) << bench.finish(jog).reason;
  bench.run_for(std::chrono::milliseconds(300));
  const auto stop = bench.execute(command(gateway_command_t::STOP, "rs232", {axis_move("u1", 0, 0, 0)}));
  ASSERT_EQ(bench.finish(stop).status, kDone) << bench.finish(stop).reason;
  EXPECT_GT(line.position("u1-drive", bench.now), 300) << "the jog did not run";
  EXPECT_FALSE(line.moving("u1-drive", bench.now));
  EXPECT_EQ(core.spd0_position_move("u1-drive"), param.answer.empty() ? param.variant : param.answer);
  expect_homes_on_its_switch(bench, "spd0_position_move " + param.variant);
  EXPECT_EQ(core.spd0_position_move("u2-drive"), param.answer.empty() ? param.variant : param.answer);
}

INSTANTIATE_TEST_SUITE_P(
    Variants, Uim242Spd0,
    ::testing::Values(Spd0Case{"holds", ""}, Spd0Case{"runs_at_last_speed", ""}, Spd0Case{"refused", ""},
                      Spd0Case{"runs_at_last_speed", "runs_at_last_speed"}, Spd0Case{"refused", "refused"}),
    [](const ::testing::TestParamInfo<Spd0Case>& p) {
      return p.param.variant + (p.param.answer.empty() ? "_detected" : "_configured_" + p.param.answer);
    });

// A global start shorter than the longest form the coordinator's schedule counts (`gSPD 65535;`)
// ends when that one would. The gateway fires it start_delay() after its reserved time and it
// goes at once, with no second wake-up of the loop; fired at the reserved time, it waits the
// difference itself. Either way its last character ends at the same instant.
TEST(Uim242StartDelay, AShorterGlobalSpeedIsFiredItsShortfallLateAndGoesAtOnce) {
  for (const bool fired_late : {true, false}) {
    SCOPED_TRACE(fired_late ? "fired at the start delay" : "fired at the reserved time");
    SerialBench bench(lab("0"), "rs232", sim::uim242_line_factory());
    bench.attach(uim242_core(bench));
    ASSERT_TRUE(bench.run_until([&] { return bench.core->ready(); }, std::chrono::seconds(10)));
    const auto enabled = bench.execute(
        command(gateway_command_t::ENABLE, "rs232", {axis_move("u1", 0, 0, 0), axis_move("u2", 0, 0, 0)}));
    ASSERT_EQ(bench.finish(enabled).status, kDone);
    const auto move =
        bench.execute(command(gateway_command_t::ARM_MOVE, "rs232",
                              {axis_move("u1", 1600, 3200, 16000), axis_move("u2", -800, 3200, 16000)}, 9));
    ASSERT_TRUE(bench.run_until(
        [&] {
          return std::any_of(bench.out.replies.begin(), bench.out.replies.end(), [&](const auto& r) {
            return r.command_id == move && r.status == motionlcm::gateway_reply_t::ARMED;
          });
        },
        std::chrono::seconds(2)));
    const TimePoint at = bench.now + std::chrono::milliseconds(50);
    bench.core->reserve_line(at, bench.now);
    const Duration character = gateway::serial_line_settings(*bench.config->find_bus("rs232")).wire_time(1);
    const Duration delay = bench.core->start_delay(9);
    EXPECT_EQ(delay, character) << "gSPD 3200; is one character shorter than gSPD 65535;";
    EXPECT_EQ(bench.core->start_delay(10), Duration::zero()) << "no move is armed with trigger 10";
    bench.run_for(at + (fired_late ? delay : Duration::zero()) - bench.now);
    const std::size_t mark = bench.sent.size();
    const std::size_t writes = bench.sent_at.size();
    bench.core->fire(9, bench.now);
    const TimePoint next = bench.core->process(bench.now);
    if (!fired_late) {
      EXPECT_EQ(bench.sent.size(), mark) << "a shorter form went before its time";
      EXPECT_EQ(next, at + delay);
      bench.run_for(next - bench.now);
      bench.core->process(bench.now);
    }
    ASSERT_GT(bench.sent_at.size(), writes);
    EXPECT_EQ(std::string(bench.sent.begin() + static_cast<std::ptrdiff_t>(mark), bench.sent.end()), "gSPD 3200;");
    EXPECT_EQ(bench.sent_at[writes], at + delay) << "written at once when fired then";
    ASSERT_EQ(bench.finish(move).status, kDone);
  }
}

// A gateway that starts while a controller runs (its predecessor's move, README "Safety and
// faults", slow restart) stops it before writing its set-up: on the line the controller gets
// `FBK;`, then `STP 0;`, then `FBK;` until it reports speed 0, and only then its set-up writes
// (micro-steps, current, MCFG ...: not changed under a running motor). It ends at rest short of the
// old target, set up, with a GATEWAY_RESTARTED event, and moves again.
TEST(Uim242Restart, AControllerFoundMovingIsStoppedAndAtRestBeforeItsSetUpIsWritten) {
  SerialBench bench(lab("0"), "rs232", sim::uim242_line_factory());
  bench.attach(uim242_core(bench));
  ASSERT_TRUE(bench.run_until([&] { return bench.core->ready(); }, std::chrono::seconds(10)));
  auto& line = dynamic_cast<sim::Uim242GatewaySim&>(*bench.device);
  const auto enabled = bench.execute(command(gateway_command_t::ENABLE, "rs232", {axis_move("u1", 0, 0, 0)}));
  ASSERT_EQ(bench.finish(enabled).status, kDone);
  const auto move = bench.execute(command(gateway_command_t::ARM_MOVE, "rs232", {axis_move("u1", 16000, 3200, 16000)}));
  bench.run_for(std::chrono::milliseconds(800));
  ASSERT_TRUE(line.moving("u1-drive", bench.now))
      << bench.out.terminal(move).value_or(motionlcm::gateway_reply_t{}).reason;

  // The gateway process dies (nothing more from it) and another one starts: the controller runs on.
  const std::size_t from = bench.sent.size();
  bench.attach(uim242_core(bench));
  ASSERT_TRUE(bench.run_until([&] { return bench.core->ready(); }, std::chrono::seconds(10)))
      << bench.out.event_text(motionlcm::event_t::CONFIG_MISMATCH);
  EXPECT_FALSE(line.moving("u1-drive", bench.now));
  EXPECT_LT(line.position("u1-drive", bench.now), 16000) << "ran on to its old target";
  EXPECT_NE(bench.out.event_text(motionlcm::event_t::GATEWAY_RESTARTED).find("u1-drive (node 5): found moving"),
            std::string::npos)
      << bench.out.event_text(motionlcm::event_t::GATEWAY_RESTARTED);

  // What node 5 got on the line since the restart, in order.
  uim242::InstructionSplitter splitter;
  const std::span<const std::uint8_t> wire(bench.sent);
  int selected = 0;
  std::vector<uim242::Instruction> to_u1;
  std::string listing;
  for (const auto& chunk : splitter.push(wire.subspan(from))) {
    const auto in = uim242::parse_instruction(chunk.text);
    ASSERT_TRUE(in) << chunk.text;
    if (in.value().mnemonic == uim242::Mnemonic::kADR && in.value().value) {
      selected = static_cast<int>(*in.value().value);
      continue;
    }
    if (selected != 5 || in.value().global) continue;
    to_u1.push_back(in.value());
    listing += chunk.text + ";";
  }
  const auto first = [&](auto&& pred) {
    return static_cast<std::size_t>(std::find_if(to_u1.begin(), to_u1.end(), pred) - to_u1.begin());
  };
  const std::size_t stop =
      first([](const uim242::Instruction& i) { return i.mnemonic == uim242::Mnemonic::kSTP && i.value == 0; });
  const std::size_t setup = first([](const uim242::Instruction& i) {
    return i.value && (i.mnemonic == uim242::Mnemonic::kMCS || i.mnemonic == uim242::Mnemonic::kCUR ||
                       i.mnemonic == uim242::Mnemonic::kMCF || i.mnemonic == uim242::Mnemonic::kSCF ||
                       i.mnemonic == uim242::Mnemonic::kICF || i.mnemonic == uim242::Mnemonic::kMMS);
  });
  ASSERT_LT(stop, to_u1.size()) << "never stopped: " << listing;
  ASSERT_LT(setup, to_u1.size()) << "never set up: " << listing;
  EXPECT_LT(stop, setup) << "set-up written before the stop: " << listing;
  const auto checked = std::find_if(to_u1.begin() + static_cast<std::ptrdiff_t>(stop), to_u1.end(),
                                    [](const uim242::Instruction& i) { return i.mnemonic == uim242::Mnemonic::kFBK; });
  EXPECT_LT(checked - to_u1.begin(), static_cast<std::ptrdiff_t>(setup)) << "standstill not read: " << listing;
  std::printf("restart while u1 runs, node 5's instructions: %s\n", listing.c_str());

  // And it moves again.
  const auto enabled_again = bench.execute(command(gateway_command_t::ENABLE, "rs232", {axis_move("u1", 0, 0, 0)}));
  ASSERT_EQ(bench.finish(enabled_again).status, kDone);
  const auto again = bench.execute(command(gateway_command_t::ARM_MOVE, "rs232", {axis_move("u1", 0, 3200, 16000)}));
  ASSERT_EQ(bench.finish(again).status, kDone) << bench.finish(again).reason;
  EXPECT_EQ(line.position("u1-drive", bench.now), 0);
}

// A controller that stops answering mid-move may still hear: once the stack calls it offline, a
// STOP naming it still sends `STP 0;`, the controller stops (ground truth), and the STOP ends
// FAILED saying the stop is not confirmed.
TEST(Uim242Unanswering, AStopStillReachesAControllerThatHearsButDoesNotAnswer) {
  SerialBench bench(lab("0"), "rs232", sim::uim242_line_factory());
  bench.attach(uim242_core(bench));
  ASSERT_TRUE(bench.run_until([&] { return bench.core->ready(); }, std::chrono::seconds(10)));
  auto& line = dynamic_cast<sim::Uim242GatewaySim&>(*bench.device);
  const auto enabled = bench.execute(command(gateway_command_t::ENABLE, "rs232", {axis_move("u1", 0, 0, 0)}));
  ASSERT_EQ(bench.finish(enabled).status, kDone);
  const auto move = bench.execute(command(gateway_command_t::ARM_MOVE, "rs232", {axis_move("u1", 16000, 3200, 16000)}));
  bench.run_for(std::chrono::milliseconds(500));
  ASSERT_TRUE(line.moving("u1-drive", bench.now));
  // Controller 5 goes quiet; the UIM2501 gateway still answers its selection (ADR).
  bench.mute = [](std::span<const std::uint8_t> bytes) {
    const auto frame = uim242::parse_frame(bytes);
    return frame && frame.value().node == 5 && frame.value().message_id != uim242::message::kSelect;
  };
  ASSERT_TRUE(
      bench.run_until([&] { return bench.out.event_text(motionlcm::event_t::OFFLINE).find("u1") != std::string::npos; },
                      std::chrono::seconds(3)))
      << "never called offline";
  ASSERT_TRUE(bench.out.terminal(move).has_value()) << "the move did not end with its drive offline";
  ASSERT_TRUE(line.moving("u1-drive", bench.now)) << "stopped by something else";
  const auto stop = bench.execute(command(gateway_command_t::STOP, "rs232", {axis_move("u1", 0, 0, 0)}));
  const auto stopped = bench.finish(stop);
  EXPECT_EQ(stopped.status, kFailed);
  EXPECT_NE(stopped.reason.find("STP 0 sent all the same, not confirmed"), std::string::npos) << stopped.reason;
  bench.run_for(std::chrono::seconds(2));
  EXPECT_FALSE(line.moving("u1-drive", bench.now)) << "the controller did not get its stop";
  EXPECT_LT(line.position("u1-drive", bench.now), 16000);
  std::printf("u1 muted mid-move, STOP: \"%s\"; at rest at %lld counts (target 16000)\n", stopped.reason.c_str(),
              static_cast<long long>(line.position("u1-drive", bench.now)));
}

// STO (manual #42): "wait 20ms before sending other instructions" after it. A read queued right
// behind the STO goes out only 20 ms after the STO's reply.
TEST(Uim242Sto, NothingIsSentWithin20msAfterAnSto) {
  SerialBench bench(lab("0"), "rs232", sim::uim242_line_factory());
  bench.attach(uim242_core(bench));
  ASSERT_TRUE(bench.run_until([&] { return bench.core->ready(); }, std::chrono::seconds(10)));
  auto sto = command(gateway_command_t::PARAM_WRITE, "rs232", {axis_move("u1", 0, 0, 0)});
  sto.param.space = motionlcm::param_t::UIM242_INSTRUCTION;
  sto.param.mnemonic = "STO";
  sto.param.value = 0;
  auto read = command(gateway_command_t::PARAM_READ, "rs232", {axis_move("u2", 0, 0, 0)});
  read.param.space = motionlcm::param_t::UIM242_INSTRUCTION;
  read.param.mnemonic = "MCF";
  const auto sto_id = bench.execute(sto);
  const auto read_id = bench.execute(read);
  std::optional<TimePoint> stored;
  for (int i = 0; i < 500 && !bench.out.terminal(read_id); ++i) {
    bench.run_for(std::chrono::microseconds(200));
    if (!stored && bench.out.terminal(sto_id)) stored = bench.now;
  }
  ASSERT_TRUE(stored.has_value());
  ASSERT_TRUE(bench.out.terminal(read_id).has_value());
  EXPECT_EQ(bench.out.terminal(sto_id)->status, kDone);
  const auto after =
      std::find_if(bench.sent_at.begin(), bench.sent_at.end(), [&](TimePoint t) { return t >= *stored; });
  ASSERT_NE(after, bench.sent_at.end());
  const TimePoint read_sent = *after;
  EXPECT_GE(read_sent - *stored, std::chrono::milliseconds(19));
}

}  // namespace
}  // namespace motion::truth
