// The Gateway's position record across its own restarts: one gateway process after the other on
// the same record file, the driver's statuses given by hand.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <memory>

#include <motionlcm/event_t.hpp>

#include "motion/gateway/gateway.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/reply_error.hpp"
#include "motion/testing/lcm_url.hpp"

namespace motion::gateway {
namespace {

using std::chrono::milliseconds;

const char* kConfig = R"(
buses:
  - {name: can0, transport: simcan:can0}
drives:
  - {name: xd, family: uim342, bus: can0, node_id: 5}
axes:
  - {name: x, drive: xd, steps_per_unit: 100, limits: {min: -100, max: 100, velocity: 1, acceleration: 1}}
)";

// Takes every command and answers none (the test answers for it).
class SilentDriver : public BusDriver {
 public:
  void start() override {}
  void execute(const motionlcm::gateway_command_t& /*command*/) override {}
  void fire(std::int64_t /*trigger_id*/) override {}
  [[nodiscard]] std::vector<motionlcm::bus_stats_t> statistics() const override { return {}; }
  [[nodiscard]] bool ready() const override { return true; }
};

// One gateway process: its own node, health and Gateway on the shared record file.
struct Process {
  Process(EventLoop& loop, const config::Config& config, const std::string& url, const std::string& record)
      : node(loop, {url, "GR_"}),
        health(loop, node, "gateway:can0", "gateway"),
        gateway(loop, node, health, config, "can0") {
    gateway.set_position_record(record);
    gateway.attach(std::make_unique<SilentDriver>());
  }
  lcm::Node node;
  lcm::HealthPublisher health;
  Gateway gateway;
};

struct GatewayRecord : ::testing::Test {
  GatewayRecord()
      : config(*config::load_string(kConfig).config),
        url(testing::unique_lcm_url(13)),
        dir(std::filesystem::temp_directory_path() / ("gateway-record-test-" + std::to_string(::getpid()))),
        listener(loop, {url, "GR_"}) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    listener.subscribe<motionlcm::axis_state_t>(
        lcm::channels::kAxisState,
        [this](const motionlcm::axis_state_t& s, const std::string&) { states.push_back(s); });
    listener.subscribe<motionlcm::event_t>(
        lcm::channels::kEvent, [this](const motionlcm::event_t& e, const std::string&) { events.push_back(e); });
    listener.subscribe<motionlcm::gateway_reply_t>(
        lcm::channels::kGatewayReply,
        [this](const motionlcm::gateway_reply_t& r, const std::string&) { replies.push_back(r); });
  }
  ~GatewayRecord() override { std::filesystem::remove_all(dir); }

  std::unique_ptr<Process> start() {
    states.clear();
    events.clear();
    replies.clear();
    return std::make_unique<Process>(loop, config, url, (dir / "can0.positions").string());
  }
  void pump_until(const std::function<bool()>& done, milliseconds within = milliseconds(3000)) {
    const auto deadline = loop.now() + within;
    while (!done() && loop.now() < deadline) loop.run_once(milliseconds(5));
  }
  // The driver reports x online, at rest at `counts`; waits for the state it makes.
  const motionlcm::axis_state_t& report(Process& p, std::int64_t counts, bool homed, bool read = true) {
    DriveStatus s;
    s.online = true;
    s.position_read = read;
    s.enabled = true;
    s.position_counts = counts;
    s.target_counts = counts;
    s.homed = homed;
    const std::size_t before = states.size();
    p.gateway.axis_status("x", s);
    pump_until([&] { return states.size() > before; });
    pump_until([] { return false; }, milliseconds(100));  // and whatever else followed
    return states.back();
  }
  motionlcm::gateway_reply_t move(Process& p) {
    motionlcm::gateway_command_t c{};
    c.bus = "can0";
    c.command_id = 42;
    c.kind = motionlcm::gateway_command_t::ARM_MOVE;
    motionlcm::axis_command_t a{};
    a.axis = "x";
    a.target_counts = 100;
    c.axes = {a};
    c.num_axes = 1;
    p.node.publish(lcm::channels::gateway_command("can0"), c);
    pump_until([&] { return !replies.empty(); });
    return replies.empty() ? motionlcm::gateway_reply_t{} : replies.back();
  }
  bool lost_event() const {
    return std::any_of(events.begin(), events.end(), [](const motionlcm::event_t& e) {
      return e.axis == "x" && e.kind == motionlcm::event_t::REBOOT &&
             e.text.find("position lost / not homed") != std::string::npos;
    });
  }

  config::Config config;
  std::string url;
  std::filesystem::path dir;
  EventLoop loop;
  lcm::Node listener;
  std::vector<motionlcm::axis_state_t> states;
  std::vector<motionlcm::event_t> events;
  std::vector<motionlcm::gateway_reply_t> replies;
};

TEST_F(GatewayRecord, WithoutARecordNothingChanges) {
  auto first = start();
  const auto s = report(*first, 0, false);
  EXPECT_NE(s.fault_code, motionlcm::axis_state_t::POSITION_LOST);
  EXPECT_FALSE(lost_event());
  first.reset();  // a gateway that stopped has written its record (off its loop thread before)
  EXPECT_TRUE(std::filesystem::exists(dir / "can0.positions"));  // written from now on
}

TEST_F(GatewayRecord, ARestartWhereTheDriveStillIsKeepsItHomed) {
  report(*start(), 7680, true);
  auto second = start();
  // Online before its position is read (0 is no reading): not compared.
  EXPECT_NE(report(*second, 0, false, false).fault_code, motionlcm::axis_state_t::POSITION_LOST);
  const auto s = report(*second, 7680, false);  // the driver's own homed flag was forgotten
  EXPECT_TRUE(s.homed);
  EXPECT_NE(s.fault_code, motionlcm::axis_state_t::POSITION_LOST);
  EXPECT_FALSE(lost_event());
}

TEST_F(GatewayRecord, ADriveBackAtZeroLostItsPositionOverAnyNumberOfRestartsUntilItIsSet) {
  report(*start(), 7680, true);
  auto second = start();
  const auto s = report(*second, 0, false);
  EXPECT_EQ(s.fault_code, motionlcm::axis_state_t::POSITION_LOST);
  EXPECT_FALSE(s.homed);
  EXPECT_NE(
      s.fault_text.find(
          "xd powered up or was reset while no gateway ran, detected by the position record: it answers at 0 counts"),
      std::string::npos)
      << s.fault_text;
  // A UIM342 (xd) keeps a set origin in its driver: the gateway's restart alone may explain it.
  EXPECT_NE(s.fault_text.find("or the origin offset (SET_POSITION or homing offset) the previous gateway process kept"),
            std::string::npos)
      << s.fault_text;
  EXPECT_TRUE(lost_event());
  const auto refused = move(*second);
  EXPECT_EQ(refused.status, std::int8_t{motionlcm::gateway_reply_t::FAILED});
  EXPECT_EQ(refused.error_code, error_code(ReplyError::kPositionLost)) << refused.reason;
  EXPECT_NE(refused.reason.find("axis x lost its position"), std::string::npos) << refused.reason;
  second.reset();

  // Restarted again, the drive where it now stands: still lost (the record says so).
  auto third = start();
  EXPECT_EQ(report(*third, 0, false).fault_code, motionlcm::axis_state_t::POSITION_LOST);
  // Its position set (SET_POSITION DONE): valid, and the record says so for the next process.
  motionlcm::gateway_command_t set{};
  set.bus = "can0";
  set.command_id = 43;
  set.kind = motionlcm::gateway_command_t::SET_POSITION;
  motionlcm::axis_command_t a{};
  a.axis = "x";
  set.axes = {a};
  set.num_axes = 1;
  third->node.publish(lcm::channels::gateway_command("can0"), set);
  pump_until([] { return false; }, milliseconds(100));  // the driver has it; it answers DONE:
  motionlcm::gateway_reply_t done{};
  done.command_id = 43;
  done.status = motionlcm::gateway_reply_t::DONE;
  third->gateway.command_reply(done);
  EXPECT_NE(report(*third, 0, false).fault_code, motionlcm::axis_state_t::POSITION_LOST);
  third.reset();
  auto fourth = start();
  EXPECT_NE(report(*fourth, 0, false).fault_code, motionlcm::axis_state_t::POSITION_LOST);
}

}  // namespace
}  // namespace motion::gateway
