// Uim342Stack start-up (identification, setup, micro-steps over a restart, group ids), polling
// paced to what the bus carries, request timeouts on a busy wire, offline drives and their return
// (bench: uim342_stack_fixture.hpp).
#include <fmt/format.h>

#include "motion/can_frame/bit_timing.hpp"
#include "uim342_stack_fixture.hpp"

namespace motion::gateway::test {
namespace {

TEST_F(Uim342StackTest, StartIdentifiesAppliesSetupAndBecomesReady) {
  EXPECT_FALSE(stack->ready());
  EXPECT_EQ(stack->axes(), (std::vector<std::string>{"x", "y", "z"}));
  stack->start(now);
  settle();
  EXPECT_TRUE(stack->ready());
  const auto x = sent_to(5);
  ASSERT_FALSE(x.empty());
  EXPECT_EQ(x.front(), uim342::request::get(FC::kML));  // §5.4 identification first
  const auto has = [&](const uim342::Instruction& i) { return std::find(x.begin(), x.end(), i) != x.end(); };
  EXPECT_TRUE(has(uim342::request::get(uim342::ProtocolParameter::kGroupId)));
  // MT[0] / QE[4] already at the configured 16 / 3200: read, not rewritten (no restart).
  EXPECT_TRUE(has(uim342::request::get(uim342::MotorDriver::kMicrostepping)));
  EXPECT_TRUE(has(uim342::request::get(uim342::QuadratureEncoder::kCountsPerRevolution)));
  EXPECT_FALSE(has(uim342::request::set(uim342::MotorDriver::kMicrostepping, 16)));
  EXPECT_EQ(count_sent(5, FC::kSY), 0u);
  EXPECT_TRUE(has(uim342::request::set(uim342::MotorDriver::kWorkingCurrent, 20)));
  EXPECT_TRUE(has(uim342::request::set(uim342::InitialConfig::kAccelerationUnit, 0)));
  EXPECT_TRUE(has(uim342::request::set(uim342::InitialConfig::kClosedLoop, 0)));
  EXPECT_TRUE(has(uim342::request::set(uim342::InformationEnable::kPositionReached, true)));
  EXPECT_TRUE(has(uim342::request::set(uim342::InformationEnable::kIn1Change, true)));
  EXPECT_EQ(drives.at(7).word(FC::kMT, 1), 15);  // z: 1.5 A
  EXPECT_EQ(count_sent(7, FC::kPP), 0u);         // z has no group id
  EXPECT_TRUE(has_event(event_t::ONLINE, "x"));

  motionlcm::bus_stats_t stats{};
  stack->add_statistics(stats);
  EXPECT_EQ(stats.drives_online, 3);
  EXPECT_EQ(stats.drives_total, 3);

  // Polling at the bus's poll rate (20 Hz): MS[0] and MS[1] per node, status published.
  clear_records();
  run_for(milliseconds(50));
  EXPECT_EQ(count_sent(5, FC::kMS), 2u);
  EXPECT_EQ(count_sent(7, FC::kMS), 2u);
  ASSERT_FALSE(out.statuses.empty());
  EXPECT_TRUE(out.statuses.back().second.online);
  EXPECT_EQ(out.statuses.back().second.sample_utime, kEpochUs + 10'050'000);
  run_for(milliseconds(100));
  EXPECT_EQ(count_sent(5, FC::kMS), 6u);
}

// §5.9, §5.7: micro-steps apply only when stored with the driver off and the drive restarted.
// A drive at 8 gets MO=0, MT[0]=16, QE[4]=3200, SY[1], in that order, and is ready only after the
// read-back following the restart agrees.
TEST_F(Uim342StackTest, MicroStepsAreStoredWithTheDriverOffAndTheDriveRestartedBeforeReady) {
  drives.erase(5);
  drives.emplace(5, test::FakeDrive{5, 20, 8});
  stack->start(now);
  settle();
  EXPECT_FALSE(stack->ready());
  const auto x = sent_to(5);
  const auto index_of = [&](const uim342::Instruction& i) { return std::find(x.begin(), x.end(), i) - x.begin(); };
  const auto off = index_of(uim342::request::driver_on(false));
  const auto mt = index_of(uim342::request::set(uim342::MotorDriver::kMicrostepping, 16));
  const auto qe = index_of(uim342::request::set(uim342::QuadratureEncoder::kCountsPerRevolution, 3200));
  const auto sy = index_of(uim342::request::system(uim342::SystemOperation::kReboot));
  ASSERT_LT(sy, static_cast<std::ptrdiff_t>(x.size()));
  EXPECT_LT(off, mt);
  EXPECT_LT(mt, qe);
  EXPECT_LT(qe, sy);
  EXPECT_TRUE(has_event(event_t::REBOOT, "x"));
  run_for(milliseconds(1100));  // reboot_wait, then identified, set up and read back
  EXPECT_TRUE(stack->ready());
  EXPECT_EQ(drives.at(5).reboots, 1);
  EXPECT_EQ(drives.at(5).word(FC::kMT, 0), 16);
}

// A drive that does not keep MT[0] over the restart: CONFIG_MISMATCH naming drive and value,
// never ready, and no second restart (no EEPROM write loop).
TEST_F(Uim342StackTest, MicroStepsNotKeptOverTheRestartAreAnErrorNotALoop) {
  drives.erase(5);
  drives.emplace(5, test::FakeDrive{5, 20, 8});
  drives.at(5).keeps_micro_steps = false;
  stack->start(now);
  settle();
  run_for(milliseconds(5000));
  EXPECT_FALSE(stack->ready());
  EXPECT_EQ(drives.at(5).reboots, 1);
  const auto* mismatch = find_event(event_t::CONFIG_MISMATCH);
  ASSERT_NE(mismatch, nullptr);
  EXPECT_NE(mismatch->text.find("x-drive (node 5) reads MT[0] 0 / QE[4] 3200"), std::string::npos) << mismatch->text;
  EXPECT_NE(mismatch->text.find("configured micro_steps 16"), std::string::npos) << mismatch->text;
}

// §5.24 polling that fills the bus. 120 drives x (MS[0] + MS[1]) at 20 Hz need ~1.1 s of wire
// per second at 1 Mbit/s: more than the bus carries. Each drive is then polled as often as the
// bus allows (one poll of every drive back to back), and the stack says so once at start. How
// full the bus really gets is measured on a bit-timed wire in uim342_poll_test.cpp.
TEST_F(Uim342StackTest, PollingIsSlowedToWhatTheBusCarriesAndSaysSo) {
  std::string yaml = "buses:\n  - {name: can0, transport: \"simcan:can0\", bitrate: 1000000, poll_hz: 20}\ndrives:\n";
  for (int node = 5; node < 125; ++node)
    yaml += fmt::format("  - {{name: d{0}, family: uim342, bus: can0, node_id: {0}}}\n", node);
  build(yaml.c_str());
  const auto cycle = [](std::size_t polled) {
    // One poll of a drive: two requests and two ACKs, the longest ACK 8 bytes (MS[1]).
    const auto request = uim342::instruction_frame(5, uim342::request::get(uim342::MotionStatusIndex::kKinematics));
    const auto ack = uim342::reply_frame(5, uim342::Reply{FC::kMS, uim342::MotionKinematics{-1, -1}});
    return 2 * (can::frame_duration(*request, 1'000'000) + can::frame_duration(*ack, 1'000'000)) *
           static_cast<std::int64_t>(polled);
  };
  ASSERT_GT(cycle(120), milliseconds(50));  // more than the configured 50 ms period
  // The whole bus, not 3/4 of it: node ids differ in stuff bits by a few per frame.
  EXPECT_GE(stack->poll_period(), cycle(120) * 97 / 100);
  EXPECT_LT(stack->poll_period(), cycle(120) * 103 / 100);
  stack->start(now);
  const auto* warning = find_event(event_t::CONFIG_MISMATCH);
  ASSERT_NE(warning, nullptr);
  EXPECT_EQ(warning->severity, kWarning);
  EXPECT_NE(warning->text.find("bus can0: polling 120 UIM342 drives at 20.0 Hz needs"), std::string::npos)
      << warning->text;
  EXPECT_NE(warning->text.find("polls fill the bus, commands go first"), std::string::npos) << warning->text;
  EXPECT_EQ(std::count_if(out.events.begin(), out.events.end(), [](const auto& e) { return e.first.empty(); }), 1);

  // Three drives fit: the configured rate, nothing said.
  build(kLab);
  clear_records();
  EXPECT_EQ(stack->poll_period(), milliseconds(50));
  stack->start(now);
  settle();
  EXPECT_EQ(find_event(event_t::CONFIG_MISMATCH), nullptr);
}

// A request's timeout counts from when it was handed to the transport plus the wire time of
// the requests in flight ahead of it (each with its ACK): a queue on a busy bus is not a silent
// drive. Three requests in flight at 1 Mbit/s: ~0.2 ms of wire each.
TEST_F(Uim342StackTest, RequestTimeoutAllowsForTheRequestsAheadOnTheWire) {
  start_and_set_up();
  for (auto& [id, d] : drives) d.silent = true;
  execute(command(gateway_command_t::ENABLE, {"x", "y", "z"}));
  ASSERT_EQ(count_sent(5, FC::kMO) + count_sent(6, FC::kMO) + count_sent(7, FC::kMO), 3u);
  run_for(milliseconds(50) + std::chrono::microseconds(150));
  EXPECT_EQ(stack->counters().retries, 0);  // at exactly request_timeout_ms they would all be retried
  run_for(milliseconds(2));
  EXPECT_EQ(stack->counters().retries, 3);
  for (auto& [id, d] : drives) d.silent = false;
  run_for(milliseconds(60));  // the second retries are answered: the command ends DONE
}

TEST_F(Uim342StackTest, WrongGroupIdIsWrittenAndTheDriveRebooted) {
  drives.erase(6);
  drives.emplace(6, test::FakeDrive{6, 10});  // factory group 10
  stack->start(now);
  settle();
  EXPECT_FALSE(stack->ready());
  EXPECT_EQ(count_sent(6, FC::kSY), 1u);
  EXPECT_TRUE(has_event(event_t::REBOOT, "y"));
  run_for(milliseconds(1001));  // reboot_wait, then identified and set up again
  EXPECT_EQ(drives.at(6).group(), 20);
  EXPECT_TRUE(stack->ready());
  EXPECT_EQ(count_sent(6, FC::kML), 2u);
}

TEST_F(Uim342StackTest, SilentNodeIsOfflineRetriedWithBackOffAndRecovers) {
  drives.at(7).silent = true;
  stack->start(now);
  settle();
  run_for(milliseconds(160));  // 3 tries of 50 ms
  EXPECT_EQ(count_sent(7, FC::kML), 3u);
  EXPECT_FALSE(stack->ready());
  const auto* offline = find_event(event_t::OFFLINE);
  ASSERT_NE(offline, nullptr);
  EXPECT_EQ(offline->text,
            "z-drive (node 7) offline: z-drive (node 7) did not answer ML after 3 tries; retrying in 500 ms");
  ASSERT_TRUE(stack->status("z").has_value());
  EXPECT_FALSE(stack->status("z")->online);
  motionlcm::bus_stats_t stats{};
  stack->add_statistics(stats);
  EXPECT_EQ(stats.drives_online, 2);
  EXPECT_EQ(stats.timeouts, 1);
  EXPECT_EQ(stats.retries, 2);

  // Back-off: 500 ms, then 1000 ms; one OFFLINE event only.
  sent.clear();
  run_for(milliseconds(600));
  EXPECT_EQ(count_sent(7, FC::kML), 3u);
  run_for(milliseconds(600));
  EXPECT_EQ(count_sent(7, FC::kML), 3u);
  run_for(milliseconds(600));
  EXPECT_EQ(count_sent(7, FC::kML), 6u);
  EXPECT_EQ(std::count_if(out.events.begin(), out.events.end(),
                          [](const auto& e) { return e.second.kind == event_t::OFFLINE; }),
            1);

  const auto refused = execute(command(gateway_command_t::ENABLE, {"z"}));
  EXPECT_EQ(last_reply(refused).error_code, error_code(ReplyError::kAxisOffline));

  drives.at(7).silent = false;
  run_for(milliseconds(2100));
  EXPECT_TRUE(stack->ready());
  EXPECT_TRUE(stack->status("z")->online);
}

// A drive found running a move at set-up (a previous gateway process's, whose request ended when
// the coordinator lost that gateway) refuses set-up values with §2.3 0x3D: it is stopped (ST,
// §5.12) with a GATEWAY_RESTARTED event, then identified and set up again at rest, and ready.
TEST_F(Uim342StackTest, ADriveFoundRunningAtSetUpIsStoppedThenSetUpAgain) {
  drives.at(7).refuse[FC::kMT] = uim342::DriveErrc::kNotAllowedWhileRunning;
  stack->start(now);
  settle();
  EXPECT_EQ(count_sent(7, FC::kST), 1u);
  EXPECT_TRUE(has_event(event_t::GATEWAY_RESTARTED, "z"));
  EXPECT_FALSE(has_event(event_t::CONFIG_MISMATCH, "z")) << "a running motor is not a wrong set-up value";
  EXPECT_FALSE(stack->ready());
  drives.at(7).refuse.clear();  // at rest now
  run_for(milliseconds(1001));  // then identified and set up again
  EXPECT_EQ(count_sent(7, FC::kML), 2u);
  EXPECT_EQ(drives.at(7).word(FC::kMT, 1), 15);  // the set-up applied
  EXPECT_TRUE(stack->ready());
  EXPECT_TRUE(stack->status("z")->online);
}

}  // namespace
}  // namespace motion::gateway::test
