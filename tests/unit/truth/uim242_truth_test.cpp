// UIM242 ICF (manual §5.1: an ICFG write is burned into EEPROM "and the controller will auto
// reboot", for a time not given). Under a simulated reboot of 0 ms and of 500 ms, set-up writes
// ICF once per controller, waits the reboot out, reads the value back and becomes ready; a second
// gateway start finds ICFG as configured and writes nothing. Then a synchronized move (one
// trigger) lands both controllers on their targets (simulator ground truth).
#include <gtest/gtest.h>

#include <motionlcm/event_t.hpp>

#include "bench.hpp"
#include "motion/sim/uim242_gateway_sim.hpp"
#include "motion/uim242_driver/uim242_stack.hpp"

namespace motion::truth {
namespace {

using motionlcm::gateway_command_t;

constexpr const char* kLine = R"(
buses:
  - {name: rs232, transport: "simserial:rs232", baud: 57600, request_timeout_ms: 50, retries: 1, poll_hz: 20}
drives:
  - {name: u1-drive, family: uim242, bus: rs232, node_id: 5, setup: {micro_steps: 16, current_a: 1.0, icfg: 1}}
  - {name: u2-drive, family: uim242, bus: rs232, node_id: 6, setup: {micro_steps: 16, current_a: 1.0, icfg: 1}}
axes:
  - {name: u1, drive: u1-drive, unit: mm, steps_per_unit: 160, limits: {min: -100, max: 100, velocity: 30, acceleration: 150}}
  - {name: u2, drive: u2-drive, unit: mm, steps_per_unit: 160, limits: {min: -100, max: 100, velocity: 30, acceleration: 150}}
simulation:
  variants: {u1-drive: {reboot_ms: REBOOT}, u2-drive: {reboot_ms: REBOOT}}
)";

std::string lab(const std::string& reboot_ms) {
  std::string yaml = kLine;
  for (auto at = yaml.find("REBOOT"); at != std::string::npos; at = yaml.find("REBOOT")) yaml.replace(at, 6, reboot_ms);
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
}

INSTANTIATE_TEST_SUITE_P(Variants, Uim242Reboot, ::testing::Values("0", "500"),
                         [](const ::testing::TestParamInfo<std::string>& p) { return "reboot_ms_" + p.param; });

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
