// The UIM242 serial line in one process over a real pseudo-terminal: motion-sim's side
// (sim::SerialLineHost with uim242_line_factory(): a simulated UIM2501 with two UIM242s, nodes 5
// and 6) and the gateway's (Uim242BusDriver: Uim242BusCore in the serial poll-loop shell) on ONE
// EventLoop, byte for byte as between the processes. Covers what the shells add to the passive
// cores: the pty rendezvous, the reply latency, the timers, and a hang-up of the line (every
// running command fails naming the line, the drives go offline, and come back when it returns).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <functional>
#include <map>

#include <motionlcm/event_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>

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
  void axis_status(const std::string& axis, const gateway::DriveStatus& s) override { status[axis] = s; }
  void axis_event(const std::string& axis, const gateway::DriveEvent& e) override { events.emplace_back(axis, e); }
  void command_reply(gateway_reply_t r) override { replies.push_back(std::move(r)); }
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
        "  - {name: rs232, transport: 'simserial:rs232', baud: 57600, request_timeout_ms: 50, retries: 1, poll_hz: 20}\n"
        "drives:\n"
        "  - {name: u1-drive, family: uim242, bus: rs232, node_id: 5, setup: {micro_steps: 16, current_a: 1.0}}\n"
        "  - {name: u2-drive, family: uim242, bus: rs232, node_id: 6, setup: {micro_steps: 16, current_a: 1.0}}\n"
        "axes:\n"
        "  - {name: u1, drive: u1-drive, unit: mm, steps_per_unit: 160, limits: {min: -100, max: 100, velocity: 30, acceleration: 150}}\n"
        "  - {name: u2, drive: u2-drive, unit: mm, steps_per_unit: 160, limits: {min: -100, max: 100, velocity: 30, acceleration: 150}}\n"
        "simulation: {runtime_dir: '" + dir_.string() + "', reply_latency_us: 200}\n";
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
    host_ = sim::SerialLineHost::open(loop_, config_, config_.buses[0], {{config::Family::kUim242, sim::uim242_line_factory()}},
                                      [this](motionlcm::sim_report_t r) { reports_.push_back(std::move(r)); }, error);
    ASSERT_TRUE(host_) << error.message();
  }
  bool run_until(const std::function<bool()>& done, milliseconds limit = milliseconds(5000)) {
    return testing::pump_until(loop_, done, limit);
  }
  gateway_command_t command(std::int64_t id, std::int8_t kind, std::vector<motionlcm::axis_command_t> axes, std::int64_t trigger = 0) {
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
  ASSERT_TRUE(run_until([&] { return out_.status["u1"].position_counts == 800 && out_.status["u2"].position_counts == -800; }));
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

}  // namespace
}  // namespace motion
