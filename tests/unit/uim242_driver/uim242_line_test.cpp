// The UIM242 serial line in one process over a real pseudo-terminal: motion-sim's side
// (sim::SerialLineHost with uim242_line_factory(): a simulated UIM2501 with two UIM242s, nodes 5
// and 6) and the gateway's (Uim242BusDriver: Uim242Stack in the serial poll-loop shell) on ONE
// EventLoop, byte for byte as between the processes. Covers what the shells add to the passive
// cores: the pty rendezvous, the reply latency, the timers, and a hang-up of the line (every
// running command fails naming the line, the drives go offline, and come back when it returns);
// and what needs both sides: the stall notification the set-up enables, homing (the state before
// DONE, the switch RTCN), noise on the line.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <map>

#include <motionlcm/event_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>
#include <motionlcm/param_t.hpp>
#include <motionlcm/sim_control_t.hpp>

#include "motion/lcm/reply_error.hpp"
#include "motion/sim/serial_line_host.hpp"
#include "motion/sim/uim242_gateway_sim.hpp"
#include "motion/testing/pump.hpp"
#include "motion/uim242_driver/uim242_bus_driver.hpp"

namespace motion {
namespace {

using motionlcm::event_t;
using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using std::chrono::milliseconds;

std::int8_t st(std::int8_t s) { return s; }

struct Recorder final : gateway::GatewayOutput {
  std::map<std::string, gateway::DriveStatus> status;
  std::vector<std::pair<std::string, gateway::DriveEvent>> events;
  std::vector<gateway_reply_t> replies;
  std::map<std::int64_t, std::map<std::string, gateway::DriveStatus>>
      status_at_end;  // what was published by each terminal reply
  void axis_status(const std::string& axis, const gateway::DriveStatus& s) override { status[axis] = s; }
  void axis_event(const std::string& axis, const gateway::DriveEvent& e) override { events.emplace_back(axis, e); }
  void command_reply(gateway_reply_t r) override {
    if (r.status == st(gateway_reply_t::DONE) || r.status == st(gateway_reply_t::FAILED))
      status_at_end[r.command_id] = status;
    replies.push_back(std::move(r));
  }
  [[nodiscard]] const gateway_reply_t* find(std::int64_t id, std::int8_t s) const {
    for (const auto& r : replies) {
      if (r.command_id == id && r.status == s) return &r;
    }
    return nullptr;
  }
  [[nodiscard]] int terminals(std::int64_t id) const {
    return static_cast<int>(std::count_if(replies.begin(), replies.end(), [id](const gateway_reply_t& r) {
      return r.command_id == id && (r.status == st(gateway_reply_t::DONE) || r.status == st(gateway_reply_t::FAILED));
    }));
  }
  [[nodiscard]] bool online(const std::string& axis) const { return status.contains(axis) && status.at(axis).online; }
};

class Uim242Line : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("uim242-line-" + std::to_string(::getpid()) + "-" +
                                                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
    const std::string yaml =
        "buses:\n"
        "  - {name: rs232, transport: 'simserial:rs232', baud: 57600, request_timeout_ms: 50, retries: 1, poll_hz: "
        "20}\n"
        "drives:\n"
        "  - {name: u1-drive, family: uim242, bus: rs232, node_id: 5, setup: {micro_steps: 16, current_a: 1.0}}\n"
        "  - {name: u2-drive, family: uim242, bus: rs232, node_id: 6, setup: {micro_steps: 16, current_a: 1.0}}\n"
        "axes:\n"
        "  - {name: u1, drive: u1-drive, unit: mm, steps_per_unit: 160, invert: true,\n"
        "     limits: {min: -100, max: 100, velocity: 30, acceleration: 150}, homing: {method: current-position, "
        "offset: 2.5}}\n"
        "  - {name: u2, drive: u2-drive, unit: mm, steps_per_unit: 160,\n"
        "     limits: {min: -100, max: 100, velocity: 30, acceleration: 150}, homing: {method: switch, input: 1, "
        "velocity: -5, offset: -1}}\n"
        "simulation: {runtime_dir: '" +
        dir_.string() + "', reply_latency_us: 200}\n";
    auto loaded = config::load_string(yaml);
    ASSERT_TRUE(loaded.ok()) << loaded.error_text();
    config_ = *loaded.config;
    open_sim();
    driver_ = uim242_driver::Uim242BusDriver::create(loop_, config_, config_.buses[0], out_);
    driver_->reopen_period = milliseconds(20);
    driver_->start();
    ASSERT_TRUE(run_until([&] { return driver_->ready(); })) << "drives not online and set up";
  }
  void TearDown() override {
    driver_.reset();
    host_.reset();
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  void open_sim() {
    std::error_code error;
    host_ = sim::SerialLineHost::open(
        loop_, config_, config_.buses[0], {{config::Family::kUim242, sim::uim242_line_factory()}},
        [this](motionlcm::sim_report_t r) { reports_.push_back(std::move(r)); }, error);
    ASSERT_TRUE(host_) << error.message();
  }
  bool run_until(const std::function<bool()>& done, milliseconds limit = milliseconds(5000)) {
    return testing::pump_until(loop_, done, limit);
  }
  gateway_command_t command(std::int64_t id, std::int8_t kind, std::vector<motionlcm::axis_command_t> axes,
                            std::int64_t trigger = 0) {
    gateway_command_t c{};
    c.command_id = id;
    c.bus = "rs232";
    c.kind = kind;
    c.trigger_id = trigger;
    c.axes = std::move(axes);
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    return c;
  }
  static motionlcm::axis_command_t axis(const std::string& name, std::int64_t target = 0, double velocity = 1600) {
    motionlcm::axis_command_t a{};
    a.axis = name;
    a.target_counts = target;
    a.velocity = velocity;
    a.acceleration = 16000;
    a.deceleration = 16000;
    return a;
  }
  bool ended(std::int64_t id) { return out_.terminals(id) > 0; }
  bool sim_control(const std::string& drive, std::int8_t action, std::int32_t value = 0, std::int32_t level = 0,
                   const std::string& bus = {}) {
    motionlcm::sim_control_t c{};
    c.drive = drive;
    c.bus = bus;
    c.action = action;
    c.value = value;
    c.level = level;
    return host_->control(c);
  }
  std::size_t starts_of(const std::string& drive) const {
    return static_cast<std::size_t>(
        std::count_if(reports_.begin(), reports_.end(), [&](const motionlcm::sim_report_t& r) {
          return r.drive == drive && r.kind == st(motionlcm::sim_report_t::MOTION_STARTED);
        }));
  }
  bool saw_event(const std::string& axis, std::int16_t kind, const std::string& text) const {
    return std::any_of(out_.events.begin(), out_.events.end(), [&](const auto& e) {
      return e.first == axis && e.second.kind == kind && e.second.text.find(text) != std::string::npos;
    });
  }
  gateway_command_t param(std::int64_t id, std::int8_t kind, const std::string& mnemonic, std::int32_t subindex,
                          std::int64_t value = 0) {
    auto c = command(id, kind, {axis("u1")});
    c.param.space = motionlcm::param_t::UIM242_INSTRUCTION;
    c.param.mnemonic = mnemonic;
    c.param.subindex = subindex;
    c.param.value = value;
    return c;
  }
  void enable(const std::string& axis_name, std::int64_t id) {
    driver_->execute(command(id, gateway_command_t::ENABLE, {axis(axis_name)}));
    ASSERT_TRUE(run_until([&] { return ended(id); }));
    ASSERT_NE(out_.find(id, gateway_reply_t::DONE), nullptr);
  }

  std::filesystem::path dir_;
  config::Config config_;
  EventLoop loop_;
  Recorder out_;
  std::vector<motionlcm::sim_report_t> reports_;
  std::unique_ptr<sim::SerialLineHost> host_;
  std::unique_ptr<uim242_driver::Uim242BusDriver> driver_;
};

TEST_F(Uim242Line, DrivesComeOnlineOverThePtyAndOneGlobalSpeedStartsBoth) {
  EXPECT_EQ(host_->link_path(), (dir_ / "rs232.tty").string());
  EXPECT_EQ(host_->drive_count(), 2u);
  EXPECT_TRUE(out_.online("u1") && out_.online("u2"));
  const auto stats = driver_->statistics().at(0);
  EXPECT_EQ(stats.state, "open");
  EXPECT_EQ(stats.drives_online, 2);
  EXPECT_GT(stats.rx_frames, 0);

  driver_->execute(command(1, gateway_command_t::ENABLE, {axis("u1"), axis("u2")}));
  ASSERT_TRUE(run_until([&] { return ended(1); }));
  ASSERT_NE(out_.find(1, gateway_reply_t::DONE), nullptr);
  ASSERT_TRUE(run_until([&] { return out_.status["u1"].enabled && out_.status["u2"].enabled; }));

  driver_->execute(command(2, gateway_command_t::ARM_MOVE, {axis("u1", 800), axis("u2", -800)}));
  ASSERT_TRUE(run_until([&] { return ended(2); }));
  ASSERT_NE(out_.find(2, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
  const auto* started = out_.find(2, gateway_reply_t::STARTED);
  ASSERT_NE(started, nullptr);
  EXPECT_EQ(started->start_mechanism, "broadcast");
  std::vector<motionlcm::sim_report_t> starts;
  for (const auto& r : reports_) {
    if (r.kind == st(motionlcm::sim_report_t::MOTION_STARTED)) starts.push_back(r);
  }
  ASSERT_EQ(starts.size(), 2u);
  EXPECT_EQ(starts[0].frame_utime, starts[1].frame_utime) << "not started by the one gSPD frame";
  ASSERT_TRUE(
      run_until([&] { return out_.status["u1"].position_counts == 800 && out_.status["u2"].position_counts == -800; }));
}

// A controller that stops answering goes offline and is tried again each second (`MDL η;`, one
// timeout each time). While a move of the line awaits its trigger it is not tried: the exchange
// would hold the line until its timeout, far beyond the start wait the line announces. After the
// start it is tried again.
TEST_F(Uim242Line, ASilentControllerIsNotTriedWhileAMoveAwaitsItsTrigger) {
  ASSERT_NO_FATAL_FAILURE(enable("u1", 1));
  ASSERT_TRUE(sim_control("u2-drive", motionlcm::sim_control_t::SILENCE, 1));
  ASSERT_TRUE(run_until([&] { return !out_.online("u2"); }, milliseconds(3000)));
  const auto timeouts = [&] { return driver_->statistics().at(0).timeouts; };
  const auto before = timeouts();
  ASSERT_TRUE(run_until([&] { return timeouts() > before; }, milliseconds(3000))) << "u2 tried again";
  constexpr std::int64_t kTrigger = 41;
  driver_->execute(command(2, gateway_command_t::ARM_MOVE, {axis("u1", 320)}, kTrigger));
  ASSERT_TRUE(run_until([&] { return out_.find(2, gateway_reply_t::ARMED) != nullptr || ended(2); }));
  ASSERT_NE(out_.find(2, gateway_reply_t::ARMED), nullptr) << out_.replies.back().reason;
  run_until([] { return false; }, milliseconds(300));  // an identification under way ends
  const auto armed = timeouts();
  run_until([] { return false; }, milliseconds(2500));
  EXPECT_EQ(timeouts(), armed) << "u2 was tried while the move awaited its trigger";
  driver_->fire(kTrigger);
  ASSERT_TRUE(run_until([&] { return ended(2); }));
  EXPECT_NE(out_.find(2, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
  const auto fired = timeouts();
  EXPECT_TRUE(run_until([&] { return timeouts() > fired; }, milliseconds(3000))) << "u2 tried again after the start";
}

// No exchange longer than the line's start wait begins while a move of the line awaits its
// trigger: a second move armed meanwhile (u2, for another trigger) is loaded after the first one
// started, and then both run to their targets.
TEST_F(Uim242Line, ASecondMoveIsLoadedOnlyOnceTheMoveAwaitingItsTriggerStarted) {
  ASSERT_NO_FATAL_FAILURE(enable("u1", 1));
  ASSERT_NO_FATAL_FAILURE(enable("u2", 2));
  driver_->execute(command(3, gateway_command_t::ARM_MOVE, {axis("u1", 320)}, 41));
  ASSERT_TRUE(run_until([&] { return out_.find(3, gateway_reply_t::ARMED) != nullptr || ended(3); }));
  ASSERT_NE(out_.find(3, gateway_reply_t::ARMED), nullptr) << out_.replies.back().reason;
  driver_->execute(command(4, gateway_command_t::ARM_MOVE, {axis("u2", -320)}, 42));
  run_until([] { return false; }, milliseconds(500));
  EXPECT_EQ(out_.find(4, gateway_reply_t::ARMED), nullptr) << "u2 was loaded while u1's move awaited its trigger";
  EXPECT_FALSE(ended(4)) << out_.replies.back().reason;
  driver_->fire(41);
  ASSERT_TRUE(run_until([&] { return out_.find(4, gateway_reply_t::ARMED) != nullptr || ended(4); }));
  ASSERT_NE(out_.find(4, gateway_reply_t::ARMED), nullptr) << out_.replies.back().reason;
  ASSERT_TRUE(run_until([&] { return ended(3); }));
  EXPECT_NE(out_.find(3, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
  driver_->fire(42);
  ASSERT_TRUE(run_until([&] { return ended(4); }));
  EXPECT_NE(out_.find(4, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
  ASSERT_TRUE(
      run_until([&] { return out_.status["u1"].position_counts == 320 && out_.status["u2"].position_counts == -320; }));
}

TEST_F(Uim242Line, HangUpFailsTheArmedMoveTakesTheDrivesOfflineAndTheyReturn) {
  driver_->execute(command(1, gateway_command_t::ENABLE, {axis("u1")}));
  ASSERT_TRUE(run_until([&] { return ended(1); }));
  driver_->execute(command(2, gateway_command_t::ARM_MOVE, {axis("u1", 1600)}, 99));
  ASSERT_TRUE(run_until([&] { return out_.find(2, gateway_reply_t::ARMED) != nullptr; }));

  host_.reset();  // motion-sim went away: the gateway's side of the pty reads EIO
  ASSERT_TRUE(run_until([&] { return ended(2); }));
  const auto* failed = out_.find(2, gateway_reply_t::FAILED);
  ASSERT_NE(failed, nullptr);
  EXPECT_NE(failed->reason.find("serial line of bus rs232 lost"), std::string::npos) << failed->reason;
  EXPECT_FALSE(out_.online("u1"));
  EXPECT_FALSE(out_.online("u2"));
  EXPECT_FALSE(driver_->ready());
  EXPECT_TRUE(std::any_of(out_.events.begin(), out_.events.end(), [](const auto& e) {
    return e.first == "u2" && e.second.kind == std::int16_t{event_t::OFFLINE};
  }));
  // A command meanwhile ends at once, naming the drive.
  driver_->execute(command(3, gateway_command_t::STOP, {axis("u2")}));
  ASSERT_TRUE(run_until([&] { return ended(3); }));
  ASSERT_NE(out_.find(3, gateway_reply_t::FAILED), nullptr);
  EXPECT_NE(out_.find(3, gateway_reply_t::FAILED)->reason.find("u2-drive (node 6)"), std::string::npos);

  open_sim();
  ASSERT_TRUE(run_until([&] { return driver_->ready(); })) << "drives not back after the line returned";
  EXPECT_TRUE(out_.online("u1") && out_.online("u2"));
  // The failed move is not fired later, and every command ended exactly once.
  driver_->fire(99);
  run_until([] { return false; }, milliseconds(100));
  for (const std::int64_t id : {1, 2, 3}) EXPECT_EQ(out_.terminals(id), 1) << id;
}

// S34CON.STALL is 0000 on a new controller, which silences the stall RTCN whatever MCFG.STLIE
// says: the set-up binds "notify only", so a stall ends the move as a stall, not as "stopped
// short" two polls later.
TEST_F(Uim242Line, StallNotificationFailsTheMoveAndFaultsTheAxis) {
  ASSERT_NO_FATAL_FAILURE(enable("u1", 1));
  constexpr std::int64_t kFarAway = 16000;  // 10 s at 1600 pps: stalled long before the end
  driver_->execute(command(2, gateway_command_t::ARM_MOVE, {axis("u1", kFarAway)}));
  ASSERT_TRUE(
      run_until([&] { return out_.find(2, gateway_reply_t::STARTED) != nullptr && starts_of("u1-drive") == 1; }));
  ASSERT_TRUE(sim_control("u1-drive", motionlcm::sim_control_t::STALL));
  ASSERT_TRUE(run_until([&] { return ended(2); }));
  const auto* failed = out_.find(2, gateway_reply_t::FAILED);
  ASSERT_NE(failed, nullptr);
  EXPECT_NE(failed->reason.find("u1-drive (node 5): stall notification"), std::string::npos) << failed->reason;
  EXPECT_TRUE(saw_event("u1", std::int16_t{event_t::STALL}, "u1-drive (node 5)"));
  EXPECT_TRUE(out_.status["u1"].fault);
  EXPECT_FALSE(out_.status["u2"].fault);

  // FAULT_RESET: cleared in the state before its DONE (a move right after it is not refused).
  driver_->execute(command(3, gateway_command_t::FAULT_RESET, {axis("u1")}));
  ASSERT_TRUE(run_until([&] { return ended(3); }));
  ASSERT_NE(out_.find(3, gateway_reply_t::DONE), nullptr);
  EXPECT_FALSE(out_.status_at_end.at(3).at("u1").fault);
}

// The axis state a command leads to goes out before its DONE: a move planned right after HOME
// starts from the home position, not from the last poll. The offset is the command's (the
// coordinator's, in counts with the axis's direction): u1 is inverted, 2.5 mm is -400 counts.
TEST_F(Uim242Line, HomeAppliesTheCommandsOffsetAndPublishesItBeforeDone) {
  ASSERT_NO_FATAL_FAILURE(enable("u1", 1));
  driver_->execute(command(2, gateway_command_t::ARM_MOVE, {axis("u1", 800)}));
  ASSERT_TRUE(run_until([&] { return ended(2); }));
  ASSERT_TRUE(run_until([&] { return out_.status["u1"].position_counts == 800 && !out_.status["u1"].moving; }));
  ASSERT_FALSE(out_.status["u1"].homed);

  constexpr std::int64_t kHome = -400;
  driver_->execute(command(3, gateway_command_t::HOME, {axis("u1", kHome)}));
  ASSERT_TRUE(run_until([&] { return ended(3); }));
  ASSERT_NE(out_.find(3, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
  const auto& at_done = out_.status_at_end.at(3).at("u1");
  EXPECT_TRUE(at_done.homed);
  EXPECT_EQ(at_done.position_counts, kHome);
  // The drive's own counter says so too (polled back, not the gateway's bookkeeping).
  const auto polled = out_.status["u1"].sample_utime;
  ASSERT_TRUE(run_until([&] { return out_.status["u1"].sample_utime > polled; }));
  EXPECT_EQ(out_.status["u1"].position_counts, kHome);
}

// Switch homing: the falling edge of S1 resets and e-stops the drive (action 1100), its RTCN
// ends the homing. The e-stop keeps the homing speed as the desired speed: without the `SPD 0;`
// at the end, the next `ENA;` would run the axis on past the switch.
TEST_F(Uim242Line, SwitchHomingEndsAtTheSwitchAndTheAxisStaysThere) {
  ASSERT_NO_FATAL_FAILURE(enable("u2", 1));
  constexpr std::int64_t kHome = -160;  // offset -1 mm
  driver_->execute(command(2, gateway_command_t::HOME, {axis("u2", kHome, -800)}));
  ASSERT_TRUE(run_until([&] { return starts_of("u2-drive") == 1; })) << "the homing run did not start";
  ASSERT_FALSE(ended(2));
  ASSERT_TRUE(sim_control("u2-drive", motionlcm::sim_control_t::SET_INPUT, 1, 0));
  ASSERT_TRUE(run_until([&] { return ended(2); }));
  ASSERT_NE(out_.find(2, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
  EXPECT_TRUE(saw_event("u2", std::int16_t{event_t::INPUT_EDGE}, "input S1 falling"));
  EXPECT_TRUE(out_.status_at_end.at(2).at("u2").homed);
  EXPECT_EQ(out_.status_at_end.at(2).at("u2").position_counts, kHome);

  ASSERT_NO_FATAL_FAILURE(enable("u2", 3));
  run_until([] { return false; }, milliseconds(300));  // a few polls
  EXPECT_EQ(starts_of("u2-drive"), 1u) << "the axis ran again after ENA";
  EXPECT_EQ(out_.status["u2"].position_counts, kHome);
  EXPECT_FALSE(out_.status["u2"].moving);
}

// Noise on the line (motion-sim's LINE_NOISE), between frames and inside a reply: counted as
// protocol errors, the lost reply is retried, the drives stay online and a move still arrives.
TEST_F(Uim242Line, LineNoiseIsCountedAndTheDrivesStayOnline) {
  constexpr std::int32_t kNoiseBytes = 40;
  const auto errors = [&] { return driver_->statistics().at(0).errors; };
  const auto before = errors();
  ASSERT_TRUE(sim_control({}, motionlcm::sim_control_t::LINE_NOISE, kNoiseBytes, 0, "rs232"));
  ASSERT_TRUE(run_until([&] { return errors() > before; }));
  const auto between = errors();
  ASSERT_TRUE(sim_control({}, motionlcm::sim_control_t::LINE_NOISE, kNoiseBytes, 1, "rs232"));
  ASSERT_TRUE(run_until([&] { return errors() > between; }));
  EXPECT_FALSE(sim_control({}, motionlcm::sim_control_t::LINE_NOISE, kNoiseBytes, 0, "other-bus"));

  EXPECT_TRUE(out_.online("u1") && out_.online("u2"));
  ASSERT_NO_FATAL_FAILURE(enable("u1", 1));
  driver_->execute(command(2, gateway_command_t::ARM_MOVE, {axis("u1", 800)}));
  ASSERT_TRUE(run_until([&] { return ended(2); }));
  ASSERT_NE(out_.find(2, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
  EXPECT_TRUE(out_.online("u1") && out_.online("u2"));
}

// A register-addressed write (SCF register, STG port) carries one 16-bit register: a wider
// value or a register that does not exist is refused, not narrowed into another one.
TEST_F(Uim242Line, RegisterWriteBeyondItsRegisterIsRefusedNotNarrowed) {
  constexpr std::int64_t kTooWide = 70000;  // would go out as 70000 - 65536 = 4464
  driver_->execute(param(1, gateway_command_t::PARAM_WRITE, "SCF", 0, kTooWide));
  ASSERT_TRUE(run_until([&] { return ended(1); }));
  const auto* refused = out_.find(1, gateway_reply_t::FAILED);
  ASSERT_NE(refused, nullptr);
  EXPECT_NE(refused->reason.find("u1-drive (node 5): value 70000 outside the range of SCF"), std::string::npos)
      << refused->reason;
  driver_->execute(param(2, gateway_command_t::PARAM_WRITE, "STG", 258, 10));  // port 258 would be port 2
  ASSERT_TRUE(run_until([&] { return ended(2); }));
  ASSERT_NE(out_.find(2, gateway_reply_t::FAILED), nullptr);
  EXPECT_NE(out_.find(2, gateway_reply_t::FAILED)->reason.find("STG has no register 258"), std::string::npos);

  // Nothing reached the drive: S12CON and the S3 sampling interval are as they were.
  driver_->execute(param(3, gateway_command_t::PARAM_READ, "SCF", 0));
  driver_->execute(param(4, gateway_command_t::PARAM_READ, "STG", 2));
  ASSERT_TRUE(run_until([&] { return ended(3) && ended(4); }));
  ASSERT_NE(out_.find(3, gateway_reply_t::DONE), nullptr);
  EXPECT_EQ(out_.find(3, gateway_reply_t::DONE)->param.value, 0);
  ASSERT_NE(out_.find(4, gateway_reply_t::DONE), nullptr);
  EXPECT_EQ(out_.find(4, gateway_reply_t::DONE)->param.value, 0);
}

// Two armed moves on one trigger, every axis already at its target: the trigger ends each at
// once (DONE, start mechanism "none"), which removes it from the list fire() walks.
TEST_F(Uim242Line, TriggerOfTwoMovesAlreadyAtTheirTargetsEndsBothOnce) {
  ASSERT_NO_FATAL_FAILURE(enable("u1", 1));
  ASSERT_NO_FATAL_FAILURE(enable("u2", 2));
  constexpr std::int64_t kTrigger = 7;
  driver_->execute(command(3, gateway_command_t::ARM_MOVE, {axis("u1", 0)}, kTrigger));
  driver_->execute(command(4, gateway_command_t::ARM_MOVE, {axis("u2", 0)}, kTrigger));
  ASSERT_TRUE(run_until([&] { return out_.find(3, gateway_reply_t::ARMED) && out_.find(4, gateway_reply_t::ARMED); }));
  driver_->fire(kTrigger);
  ASSERT_TRUE(run_until([&] { return ended(3) && ended(4); }));
  for (const std::int64_t id : {3, 4}) {
    ASSERT_NE(out_.find(id, gateway_reply_t::DONE), nullptr) << id;
    ASSERT_NE(out_.find(id, gateway_reply_t::STARTED), nullptr) << id;
    EXPECT_EQ(out_.find(id, gateway_reply_t::STARTED)->start_mechanism, "none");
    EXPECT_EQ(out_.terminals(id), 1) << id;
  }
  EXPECT_EQ(starts_of("u1-drive") + starts_of("u2-drive"), 0u);
}

// A one-count move at a crawl (1 count/s, 1 count/s²: 2 s on the trapezoid) shows no position
// change and a speed that reads 0 for many polls while it runs: it is not "stopped short" before
// its planned time has passed, and ends DONE at the count.
TEST_F(Uim242Line, ASlowOneCountMoveIsNotTakenForAStopBeforeItsPlannedTime) {
  ASSERT_NO_FATAL_FAILURE(enable("u2", 1));
  auto crawl = axis("u2", 1, 1);
  crawl.acceleration = 1;
  crawl.deceleration = 1;
  driver_->execute(command(2, gateway_command_t::ARM_MOVE, {crawl}));
  ASSERT_TRUE(run_until([&] { return ended(2); }, milliseconds(8000)));
  ASSERT_NE(out_.find(2, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
  EXPECT_EQ(out_.status["u2"].position_counts, 1);
}

// A controller keeps its desired speed while disabled and ENA runs the motor at it again: an
// e-stopped (one gOFF for the whole line) or disabled (OFF to one drive) jog must not resume
// when the axes are enabled again.
TEST_F(Uim242Line, AJogStoppedByEstopOrDisableDoesNotResumeOnEnable) {
  for (const bool whole_line : {true, false}) {
    SCOPED_TRACE(whole_line ? "ESTOP of every drive" : "DISABLE of one drive");
    const std::int64_t base = whole_line ? 10 : 20;
    ASSERT_NO_FATAL_FAILURE(enable("u1", base + 1));
    ASSERT_NO_FATAL_FAILURE(enable("u2", base + 2));
    driver_->execute(command(base + 3, gateway_command_t::JOG, {axis("u1", 0, 800)}));
    ASSERT_TRUE(run_until([&] { return ended(base + 3) && out_.status["u1"].moving; }));
    if (whole_line) {
      driver_->execute(command(base + 4, gateway_command_t::ESTOP, {axis("u1"), axis("u2")}));
    } else {
      driver_->execute(command(base + 4, gateway_command_t::DISABLE, {axis("u1")}));
    }
    ASSERT_TRUE(run_until([&] { return ended(base + 4); }));
    ASSERT_NE(out_.find(base + 4, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
    ASSERT_TRUE(run_until([&] { return !out_.status["u1"].moving; }));
    ASSERT_NO_FATAL_FAILURE(enable("u1", base + 5));
    const auto at = out_.status["u1"].position_counts;
    run_until([] { return false; }, milliseconds(400));
    EXPECT_FALSE(out_.status["u1"].moving);
    EXPECT_EQ(out_.status["u1"].position_counts, at) << "the jog resumed after ENA";
  }
}

// A jog is a position move onto the last count inside the axis limit (u2: 100 mm = 16000 counts):
// nothing stops it, and it ends exactly there by the drive's own ramp. With less than one count
// to go it fails naming the limit and nothing moves; a STOP while the jog waits for rest ends the
// jog and nothing of it reaches the drive afterwards.
TEST_F(Uim242Line, AJogRunsOntoTheLastCountInsideItsLimitByItself) {
  ASSERT_NO_FATAL_FAILURE(enable("u2", 1));
  driver_->execute(command(2, gateway_command_t::SET_POSITION, {axis("u2", 15800)}));
  ASSERT_TRUE(run_until([&] { return ended(2); }));
  driver_->execute(command(3, gateway_command_t::JOG, {axis("u2", 0, 3200)}));
  ASSERT_TRUE(run_until([&] { return ended(3); }));
  ASSERT_NE(out_.find(3, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
  ASSERT_TRUE(run_until([&] { return out_.status["u2"].moving; }));
  ASSERT_TRUE(run_until([&] { return !out_.status["u2"].moving && out_.status["u2"].position_counts == 16000; }))
      << "the jog ended at " << out_.status["u2"].position_counts;
  run_until([] { return false; }, milliseconds(200));
  EXPECT_EQ(out_.status["u2"].position_counts, 16000);

  driver_->execute(command(4, gateway_command_t::JOG, {axis("u2", 0, 3200)}));
  ASSERT_TRUE(run_until([&] { return ended(4); }));
  const auto* refused = out_.find(4, gateway_reply_t::FAILED);
  ASSERT_NE(refused, nullptr) << "a jog with no count to go was accepted";
  EXPECT_EQ(refused->error_code, error_code(ReplyError::kOutsideLimits));
  EXPECT_NE(
      refused->reason.find("jog toward 100 mm refused: it stands at 16000 counts, less than one count from that limit"),
      std::string::npos)
      << refused->reason;

  driver_->execute(command(5, gateway_command_t::JOG, {axis("u2", 0, -3200)}));
  driver_->execute(command(6, gateway_command_t::STOP, {axis("u2")}));
  ASSERT_TRUE(run_until([&] { return ended(5) && ended(6); }));
  ASSERT_NE(out_.find(5, gateway_reply_t::FAILED), nullptr) << "the jog was not ended by the STOP";
  ASSERT_NE(out_.find(6, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
  run_until([] { return false; }, milliseconds(300));
  EXPECT_FALSE(out_.status["u2"].moving);
  EXPECT_EQ(out_.status["u2"].position_counts, 16000) << "the stopped jog started after its STOP";
}

// A command id still in use is refused (FAILED, naming the id), as by the CAN stacks and the
// ADAM master; the command that has it goes on and ends once.
TEST_F(Uim242Line, ReusedCommandIdIsRefusedAndTheRunningCommandGoesOn) {
  ASSERT_NO_FATAL_FAILURE(enable("u1", 1));
  constexpr std::int64_t kTrigger = 9;
  driver_->execute(command(2, gateway_command_t::ARM_MOVE, {axis("u1", 800)}, kTrigger));
  ASSERT_TRUE(run_until([&] { return out_.find(2, gateway_reply_t::ARMED) != nullptr; }));
  driver_->execute(command(2, gateway_command_t::ARM_MOVE, {axis("u1", 1600)}, kTrigger));
  const auto* refused = out_.find(2, gateway_reply_t::FAILED);
  ASSERT_NE(refused, nullptr) << "a reused command id was accepted";
  EXPECT_NE(refused->reason.find("command id 2 is already in progress"), std::string::npos) << refused->reason;
  EXPECT_EQ(refused->error_code, error_code(ReplyError::kMalformedRequest));
  run_until([] { return false; }, milliseconds(100));
  const auto armed = std::count_if(out_.replies.begin(), out_.replies.end(), [](const gateway_reply_t& r) {
    return r.command_id == 2 && r.status == st(gateway_reply_t::ARMED);
  });
  EXPECT_EQ(armed, 1);
  driver_->fire(kTrigger);
  ASSERT_TRUE(run_until([&] { return out_.find(2, gateway_reply_t::DONE) != nullptr; }));
  EXPECT_EQ(out_.status["u1"].position_counts, 800) << "the first command's target";
  EXPECT_EQ(starts_of("u1-drive"), 1u);
}

// STOP mid-move: DONE only at rest, with the position the drive really stopped at published not
// moving; a move armed right after it from there ends exactly at its target (its relative STP is
// computed from a position read at rest, not from one read while the motor still decelerated).
TEST_F(Uim242Line, StopMidMoveThenMoveAtOnceEndsExactlyAtTheTarget) {
  ASSERT_NO_FATAL_FAILURE(enable("u1", 1));
  auto far = axis("u1", 16000, 3200);
  far.acceleration = far.deceleration = 4000;  // 0.8 s of braking from 3200 pps
  driver_->execute(command(2, gateway_command_t::ARM_MOVE, {far}));
  ASSERT_TRUE(run_until([&] { return out_.find(2, gateway_reply_t::STARTED) != nullptr; }));
  ASSERT_TRUE(
      run_until([&] { return out_.status["u1"].position_counts > 1000 && out_.status["u1"].velocity_counts > 2000; }));
  driver_->execute(command(3, gateway_command_t::STOP, {axis("u1")}));
  ASSERT_TRUE(run_until([&] { return ended(3); }));
  ASSERT_NE(out_.find(3, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
  ASSERT_NE(out_.find(2, gateway_reply_t::FAILED), nullptr);
  const auto& at_stop = out_.status_at_end.at(3).at("u1");
  EXPECT_FALSE(at_stop.moving);
  // Ground truth: where the simulated drive reported its motion finished.
  const auto finished = std::find_if(reports_.rbegin(), reports_.rend(), [](const motionlcm::sim_report_t& r) {
    return r.drive == "u1-drive" && r.kind == st(motionlcm::sim_report_t::MOTION_FINISHED);
  });
  ASSERT_NE(finished, reports_.rend()) << "STOP ended before the drive was at rest";
  EXPECT_EQ(at_stop.position_counts, finished->position_counts) << "published position at STOP's DONE is stale";

  constexpr std::int64_t kTarget = 4000;
  driver_->execute(command(4, gateway_command_t::ARM_MOVE, {axis("u1", kTarget, 3200)}));
  ASSERT_TRUE(run_until([&] { return ended(4); }));
  ASSERT_NE(out_.find(4, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
  ASSERT_TRUE(run_until([&] {
    return !out_.status["u1"].moving && out_.status["u1"].sample_utime > out_.status_at_end.at(4).at("u1").sample_utime;
  }));
  EXPECT_EQ(out_.status["u1"].position_counts, kTarget) << "polled back from the drive";
}

// A switch homing run that ends without its edge (stopped here) unbinds the reset + e-stop action
// it put on the switch: S12CON reads back as it was before the homing.
TEST_F(Uim242Line, StoppedSwitchHomingRestoresTheSensorRegister) {
  ASSERT_NO_FATAL_FAILURE(enable("u2", 1));
  driver_->execute(command(2, gateway_command_t::HOME, {axis("u2", -160, -800)}));
  ASSERT_TRUE(run_until([&] { return starts_of("u2-drive") == 1; }));
  driver_->execute(command(3, gateway_command_t::STOP, {axis("u2")}));
  ASSERT_TRUE(run_until([&] { return ended(2) && ended(3); }));
  ASSERT_NE(out_.find(2, gateway_reply_t::FAILED), nullptr);
  EXPECT_FALSE(out_.status["u2"].homed);
  auto read = param(4, gateway_command_t::PARAM_READ, "SCF", 0);
  read.axes = {axis("u2")};
  driver_->execute(read);
  ASSERT_TRUE(run_until([&] { return ended(4); }));
  ASSERT_NE(out_.find(4, gateway_reply_t::DONE), nullptr);
  EXPECT_EQ(out_.find(4, gateway_reply_t::DONE)->param.value, 0) << "S1 still bound to reset + e-stop";
  // Crossing the switch now neither zeroes the position nor reports homed.
  const auto before = out_.status["u2"].position_counts;
  ASSERT_TRUE(sim_control("u2-drive", motionlcm::sim_control_t::SET_INPUT, 1, 0));
  run_until([] { return false; }, milliseconds(200));
  EXPECT_EQ(out_.status["u2"].position_counts, before);
  EXPECT_FALSE(out_.status["u2"].homed);
}

}  // namespace
}  // namespace motion

namespace motion {
namespace {

// SET_OUTPUTS drives P4 with `DOU η;` (EN §7 #7): DONE once the controller acknowledged it, the
// published outputs show the new level, and `DOU;` (#8) reads it back from the drive. The
// command's data outlives execute() (the gateway's LCM handler hands it a temporary). Random lab
// seeds 2 and 4: the gateway stopped heartbeating on SET_OUTPUTS.
TEST_F(Uim242Line, SetOutputsDrivesP4AndReadsItBack) {
  for (const std::int32_t level : {1, 0}) {
    const std::int64_t id = 10 + level;
    {
      auto a = axis("u1");
      a.output_mask = 1;
      a.output_value = level;
      driver_->execute(command(id, gateway_command_t::SET_OUTPUTS, {a}));  // the command dies here
    }
    ASSERT_TRUE(run_until([&] { return ended(id); })) << "level " << level;
    const auto* done = out_.find(id, gateway_reply_t::DONE);
    ASSERT_NE(done, nullptr) << out_.replies.back().reason;
    EXPECT_EQ(out_.status_at_end.at(id).at("u1").outputs, level);
    driver_->execute(param(20 + level, gateway_command_t::PARAM_READ, "DOU", 0));
    ASSERT_TRUE(run_until([&] { return ended(20 + level); }));
    ASSERT_NE(out_.find(20 + level, gateway_reply_t::DONE), nullptr) << out_.replies.back().reason;
    EXPECT_EQ(out_.find(20 + level, gateway_reply_t::DONE)->param.value, level);
  }
  // Only P4 exists: any other bit is refused at once, nothing sent.
  auto a = axis("u1");
  a.output_mask = 2;
  a.output_value = 2;
  driver_->execute(command(30, gateway_command_t::SET_OUTPUTS, {a}));
  const auto* refused = out_.find(30, gateway_reply_t::FAILED);
  ASSERT_NE(refused, nullptr);
  EXPECT_EQ(refused->error_code, error_code(ReplyError::kUnsupported));
}

}  // namespace
}  // namespace motion
