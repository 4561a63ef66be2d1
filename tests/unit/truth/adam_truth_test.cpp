// ADAM table start (manual §8.44 0x009A working speed, §8.64 0x00D8 target speed, §8.65, §8.54
// "after sending, it is necessary to send a save command", §8.69 Save = 0.1 s flash erase). Under
// every simulated variant — the table entry runs at 0x009A, at 0x00D8 or at one shared setpoint;
// the drive executes only saved table data or any — a synchronized move (one broadcast "execute
// table") lands both drives on their targets and runs at the planned speed (the simulator's
// start/finish times), and each drive took exactly one Save per move; a HOME then runs c1 onto its
// simulated switch. A disarmed move leaves nothing a foreign broadcast execute could start.
#include <gtest/gtest.h>

#include <cmath>
#include <ostream>

#include "bench.hpp"
#include "motion/adam/rtu.hpp"
#include "motion/adam/table.hpp"
#include "motion/adam_driver/adam_stack.hpp"
#include "motion/sim/adam_line_sim.hpp"

namespace motion::truth {
namespace {

using motionlcm::gateway_command_t;

constexpr const char* kLine = R"(
buses:
  - {name: rs485, transport: "simserial:rs485", baud: 115200, parity: none, request_timeout_ms: 100, retries: 1, poll_hz: 10}
drives:
  - {name: c1-drive, family: adam-modbus, bus: rs485, node_id: 1, setup: {subdivision: 16, current_a: 2.0}}
  - {name: c2-drive, family: adam-modbus, bus: rs485, node_id: 2, setup: {subdivision: 16, current_a: 2.0}}
axes:
  - {name: c1, drive: c1-drive, unit: mm, steps_per_unit: 320, limits: {min: -200, max: 200, velocity: 100, acceleration: 400},
     homing: {method: switch, input: 3, velocity: -10}}
  - {name: c2, drive: c2-drive, unit: mm, steps_per_unit: 320, limits: {min: -200, max: 200, velocity: 100, acceleration: 400}}
simulation:
  variants:
    c1-drive: {table_speed_register: SPEED, table_needs_save: SAVE}
    c2-drive: {table_speed_register: SPEED, table_needs_save: SAVE}
)";

struct Variant {
  std::string speed;
  std::string save;
};
void PrintTo(const Variant& v, std::ostream* os) {
  *os << "table_speed_register " << v.speed << ", table_needs_save " << v.save;
}

SerialBench::CoreFactory adam_core(SerialBench& bench) {
  return [&bench](std::function<void(std::span<const std::uint8_t>)> send, gateway::GatewayOutput& out) {
    auto settings = adam_driver::settings_from_config(*bench.config, *bench.config->find_bus("rs485"));
    return std::make_unique<adam_driver::AdamStack>(
        settings,
        [send = std::move(send)](std::span<const std::uint8_t> bytes) {
          send(bytes);
          return true;
        },
        out, [](TimePoint) { return std::int64_t{1'700'000'000'000'000}; });
  };
}

class AdamTable : public ::testing::TestWithParam<Variant> {};

TEST_P(AdamTable, SynchronizedMoveRunsAtThePlannedSpeedAndLands) {
  std::string yaml = kLine;
  for (auto at = yaml.find("SPEED"); at != std::string::npos; at = yaml.find("SPEED"))
    yaml.replace(at, 5, GetParam().speed);
  for (auto at = yaml.find("SAVE"); at != std::string::npos; at = yaml.find("SAVE"))
    yaml.replace(at, 4, GetParam().save);
  SerialBench bench(yaml, "rs485", sim::adam_line_factory());
  bench.attach(adam_core(bench));
  ASSERT_TRUE(bench.run_until([&] { return bench.core->ready(); }, std::chrono::seconds(5)));
  auto& line = dynamic_cast<sim::AdamLineSim&>(*bench.device);

  // 450 rpm (not the 300 rpm factory value of 0x009A) at 3200 pulses/rev = 24000 counts/s, ramps
  // of 0.25 s; 10 and 5 revolutions.
  constexpr double kSpeed = 24000;
  constexpr double kRate = 96000;
  const auto move =
      bench.execute(command(gateway_command_t::ARM_MOVE, "rs485",
                            {axis_move("c1", 32000, kSpeed, kRate), axis_move("c2", -16000, kSpeed, kRate)}, 5));
  bench.run_for(std::chrono::milliseconds(400));  // loaded and saved (0.1 s flash erase each)
  bench.core->fire(5, bench.now);
  const auto done = bench.finish(move);
  ASSERT_EQ(done.status, kDone) << done.reason;
  // What the stack reported is what the drives did: one broadcast frame started both.
  EXPECT_EQ(bench.mechanism_of(move), "broadcast");
  ASSERT_EQ(bench.reports_of("c1-drive", kStarted).size(), 1u);
  ASSERT_EQ(bench.reports_of("c2-drive", kStarted).size(), 1u);
  EXPECT_EQ(bench.reports_of("c1-drive", kStarted)[0].frame_utime,
            bench.reports_of("c2-drive", kStarted)[0].frame_utime);
  for (const auto& [drive, target] :
       {std::pair{std::string("c1-drive"), 32000}, std::pair{std::string("c2-drive"), -16000}}) {
    SCOPED_TRACE(drive);
    EXPECT_EQ(line.position(drive, bench.now), target);
    const auto started = bench.reports_of(drive, kStarted);
    const auto finished = bench.reports_of(drive, kFinished);
    ASSERT_EQ(started.size(), 1u);
    ASSERT_EQ(finished.size(), 1u);
    const double seconds = static_cast<double>(finished[0].frame_utime - started[0].frame_utime) * 1e-6;
    const double planned = std::abs(target) / kSpeed + kSpeed / kRate;  // trapezoid, equal ramps
    EXPECT_NEAR(seconds, planned, 0.01) << "ran at another speed than planned";
    EXPECT_EQ(line.saves(drive), 1) << "one Save per move, never a retried one";
  }

  // HOME c1 (switch on input 3, toward min at 10 mm/s = 3200 counts/s = 60 rpm): the simulated
  // switch is where the drive powered up (0x00C9 homing, §8.48: assumed). The drive runs from
  // 32000 counts onto it, stops and counts 0 there.
  const std::size_t starts_before = bench.reports_of("c1-drive", kStarted).size();
  motionlcm::axis_command_t home = axis_move("c1", 0, -3200, 0);
  const auto homed = bench.execute(command(gateway_command_t::HOME, "rs485", {home}));
  const auto home_done = bench.finish(homed, std::chrono::seconds(30));
  ASSERT_EQ(home_done.status, kDone) << home_done.reason;
  const auto started = bench.reports_of("c1-drive", kStarted);
  const auto finished = bench.reports_of("c1-drive", kFinished);
  ASSERT_EQ(started.size(), starts_before + 1) << "no search run";
  EXPECT_EQ(started.back().position, 32000) << "the search did not start where the move ended";
  EXPECT_EQ(finished.back().position, 0) << "the search did not end on the switch";
  const double seconds = static_cast<double>(finished.back().frame_utime - started.back().frame_utime) * 1e-6;
  EXPECT_GT(seconds, 32000.0 / 3200 - 0.5) << "the search ran faster than its 60 rpm";
  EXPECT_EQ(line.position("c1-drive", bench.now), 0);
  std::printf("%s %s: HOME c1 from 32000 counts: %.2f s onto the switch at 0\n", GetParam().speed.c_str(),
              GetParam().save.c_str(), seconds);
}

// A released move (DISARM: the coordinator's, or the gateway's own at its arm expiry) leaves the
// drive nothing to start: table entry 0 held the move's target (saved), and a broadcast "execute
// table data" (0x00DD to address 0, manual §8.54, §5) from anyone would run it. After the DISARM
// such a broadcast moves neither drive; the next synchronized move runs as usual.
TEST(AdamRelease, ADisarmedMoveLeavesNothingAForeignBroadcastExecuteCouldStart) {
  std::string yaml = kLine;
  for (auto at = yaml.find("SPEED"); at != std::string::npos; at = yaml.find("SPEED")) yaml.replace(at, 5, "0x009A");
  for (auto at = yaml.find("SAVE"); at != std::string::npos; at = yaml.find("SAVE")) yaml.replace(at, 4, "true");
  SerialBench bench(yaml, "rs485", sim::adam_line_factory());
  bench.attach(adam_core(bench));
  ASSERT_TRUE(bench.run_until([&] { return bench.core->ready(); }, std::chrono::seconds(5)));
  auto& line = dynamic_cast<sim::AdamLineSim&>(*bench.device);
  const auto arm = [&](std::int64_t trigger) {
    return bench.execute(command(gateway_command_t::ARM_MOVE, "rs485",
                                 {axis_move("c1", 32000, 24000, 96000), axis_move("c2", -16000, 24000, 96000)},
                                 trigger));
  };
  const auto armed = arm(5);
  bench.run_for(std::chrono::milliseconds(400));  // loaded and saved
  const auto released = bench.execute(
      command(gateway_command_t::DISARM, "rs485", {axis_move("c1", 0, 0, 0), axis_move("c2", 0, 0, 0)}, 5));
  ASSERT_EQ(bench.finish(released).status, kDone);
  ASSERT_EQ(bench.finish(armed).status, kFailed);
  bench.run_for(std::chrono::milliseconds(400));  // the table entries set back and saved

  // Someone else's broadcast "execute table data", the gateway's own start frame.
  const auto execute = adam::table_execute_broadcast();
  ASSERT_TRUE(execute);
  const auto frame = adam::rtu::encode_request(execute.value());
  ASSERT_TRUE(frame);
  bench.device->receive(frame.value(), bench.now);
  bench.run_for(std::chrono::seconds(2));
  for (const auto* drive : {"c1-drive", "c2-drive"}) {
    EXPECT_EQ(line.position(drive, bench.now), 0) << drive << " ran the released move";
    for (const auto& r : bench.reports_of(drive, kStarted))
      EXPECT_EQ(r.target, r.position) << drive << " started from " << r.position << " to " << r.target;
  }

  // The next move runs as usual.
  const auto again = arm(6);
  bench.run_for(std::chrono::milliseconds(400));
  bench.core->fire(6, bench.now);
  const auto done = bench.finish(again);
  ASSERT_EQ(done.status, kDone) << done.reason;
  EXPECT_EQ(line.position("c1-drive", bench.now), 32000);
  EXPECT_EQ(line.position("c2-drive", bench.now), -16000);
}

// A drive that stops answering mid-move may still hear: a STOP naming it sends its ramped stop
// all the same (every STOP does, answered or not), the drive stops (ground truth), and the STOP
// ends FAILED saying the stop is not confirmed.
TEST(AdamUnanswering, AStopStillReachesADriveThatHearsButDoesNotAnswer) {
  std::string yaml = kLine;
  for (auto at = yaml.find("SPEED"); at != std::string::npos; at = yaml.find("SPEED")) yaml.replace(at, 5, "0x009A");
  for (auto at = yaml.find("SAVE"); at != std::string::npos; at = yaml.find("SAVE")) yaml.replace(at, 4, "true");
  SerialBench bench(yaml, "rs485", sim::adam_line_factory());
  bench.attach(adam_core(bench));
  ASSERT_TRUE(bench.run_until([&] { return bench.core->ready(); }, std::chrono::seconds(5)));
  auto& line = dynamic_cast<sim::AdamLineSim&>(*bench.device);
  const auto move =
      bench.execute(command(gateway_command_t::ARM_MOVE, "rs485", {axis_move("c1", 96000, 24000, 96000)}));
  bench.run_for(std::chrono::milliseconds(800));
  const std::int64_t before = line.position("c1-drive", bench.now);
  ASSERT_GT(before, 0) << "the move did not start";
  bench.mute = [](std::span<const std::uint8_t>) { return true; };
  const auto stop = bench.execute(command(gateway_command_t::STOP, "rs485", {axis_move("c1", 0, 0, 0)}));
  const auto stopped = bench.finish(stop);
  EXPECT_EQ(stopped.status, kFailed);
  EXPECT_NE(stopped.reason.find("not confirmed"), std::string::npos) << stopped.reason;
  EXPECT_TRUE(bench.out.terminal(move).has_value());
  bench.run_for(std::chrono::seconds(1));
  const std::int64_t rested = line.position("c1-drive", bench.now);
  bench.run_for(std::chrono::milliseconds(200));
  EXPECT_EQ(line.position("c1-drive", bench.now), rested) << "the drive did not get its stop";
  EXPECT_LT(rested, 96000);
  std::printf("c1 muted mid-move, STOP: \"%s\"; at rest at %lld pulses (target 96000)\n", stopped.reason.c_str(),
              static_cast<long long>(rested));
}

INSTANTIATE_TEST_SUITE_P(Variants, AdamTable,
                         ::testing::Values(Variant{"0x009A", "true"}, Variant{"0x009A", "false"},
                                           Variant{"0x00D8", "true"}, Variant{"0x00D8", "false"},
                                           Variant{"shared", "true"}, Variant{"shared", "false"}),
                         [](const ::testing::TestParamInfo<Variant>& p) {
                           return "speed_" + (p.param.speed == "shared" ? p.param.speed : p.param.speed.substr(2)) +
                                  "_needs_save_" + p.param.save;
                         });

}  // namespace
}  // namespace motion::truth
