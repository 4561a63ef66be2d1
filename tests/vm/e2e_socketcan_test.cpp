// End to end over real SocketCAN, inside the QEMU VM of tools/vm/socketcan-vm (ctest
// socketcan_vm_e2e, label vm): the lab of tests/vm/vm-lab.yaml on vcan0.
//
//   client (this test) -> motion-coordinator -> motion-gateway --bus can0 (SocketCAN on vcan0)
//   -> vcan0 -> motion-sim --simulate-socketcan (x, y: UIM342 in group 20; a, b: UC57 CANopen;
//   one CAN_RAW socket per drive)
//
// LCM runs over multicast on lo. The simulated drives' reports (SIM_REPORT) are the ground truth
// of which frame started them; an independent CAN_RAW listener on vcan0 and candump (can-utils)
// count the start frames on the wire: x and y start on one group-addressed BG frame, a and b on
// one SYNC. Processes start once for the suite and are killed at its end (ProcessGroup).
// Outside the VM (MOTION_IN_VM unset) every test skips: the host kernel may lack AF_CAN.
// Timeouts are generous: the VM is emulated (TCG, one vCPU for every process).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <motionlcm/sim_report_t.hpp>

#include "motion/can/socketcan.hpp"
#include "motion/client/client.hpp"
#include "motion/config/config.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/testing/process_group.hpp"

namespace motion::testing {
namespace {

using client::Client;
using motionlcm::reply_t;
using motionlcm::request_t;
using motionlcm::sim_report_t;
using std::chrono::seconds;
using Values = std::map<std::string, double>;

constexpr const char* kInterface = "vcan0";
constexpr const char* kBus = "can0";
constexpr int kGroupId = 20;              // x-drive and y-drive in vm-lab.yaml
constexpr std::uint32_t kSyncId = 0x080;  // CANopen SYNC (COB-ID 80h)
constexpr auto kStartTimeout = seconds(60);
constexpr auto kRequestTimeout = seconds(45);

// LCM in-class constants are never ODR-used: copied into values.
std::int8_t st(std::int8_t s) { return s; }
std::int8_t started_kind() { return sim_report_t::MOTION_STARTED; }

bool in_vm() {
  const char* v = std::getenv("MOTION_IN_VM");
  return v != nullptr && std::string(v) == "1";
}

// The lab configuration: $MOTION_VM_LAB_CONFIG (the VM runner puts it next to the programs),
// else the source tree's.
std::string lab_config() {
  const char* path = std::getenv("MOTION_VM_LAB_CONFIG");
  return path != nullptr ? path : source_path("tests/vm/vm-lab.yaml");
}

// SimpleCAN 3.0 (gateway/uim342 identifier.hpp): a BG (function code 16h) from the host
// (producer 4) to group `group`, 29-bit.
bool is_bg_to_group(std::uint32_t id, bool extended, int group) {
  if (!extended) return false;
  const std::uint32_t producer = ((id >> 24) & 0x1F) | ((id >> 11) & 0x60);
  const std::uint32_t consumer = ((id >> 19) & 0x1F) | ((id >> 9) & 0x60);
  return producer == 4 && consumer == static_cast<std::uint32_t>(group) && (id & 0x7F) == 0x16;
}

// candump -L lines "(1700000000.123456) vcan0 04A00016#00000000": ids with 8 hex digits are
// extended.
int count_candump_bg(const std::string& log, int group) {
  std::istringstream in(log);
  std::string line;
  int count = 0;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string time;
    std::string interface;
    std::string frame;
    if (!(fields >> time >> interface >> frame) || interface != kInterface) continue;
    const auto hash = frame.find('#');
    if (hash == std::string::npos) continue;
    const std::string id = frame.substr(0, hash);
    if (is_bg_to_group(static_cast<std::uint32_t>(std::stoul(id, nullptr, 16)), id.size() == 8, group)) ++count;
  }
  return count;
}

// Every process of the lab, the client, the drives' reports and a CAN_RAW listener on vcan0.
class VmLab {
 public:
  VmLab() : client_(group_.loop(), group_.node(), "vm-e2e-client") {
    auto loaded = config::load_file(config_path_);
    if (!loaded.ok()) throw std::runtime_error(loaded.error_text());
    config_ = *loaded.config;
    group_.node().subscribe<sim_report_t>(lcm::channels::kSimReport,
                                          [this](const sim_report_t& r, const std::string&) { reports_.push_back(r); });
  }
  ~VmLab() {
    if (listener_.is_open()) group_.loop().unwatch(listener_.fd());
  }
  VmLab(const VmLab&) = delete;
  VmLab& operator=(const VmLab&) = delete;

  ::testing::AssertionResult start(const std::vector<std::string>& axes) {
    if (const auto ec = listener_.open(kInterface))
      return ::testing::AssertionFailure() << "listener on " << kInterface << ": " << ec.message();
    group_.loop().watch(listener_.fd(), [this] {
      while (auto frame = listener_.receive()) frames_.push_back(*frame);
    });
    // candump first, so it is up long before the first move. /bin/sh drops the --lcm-url the
    // group appends ($1, $2 of the script).
    candump_ = group_.start({"candump", "/bin/sh", {"-c", std::string("exec candump -L ") + kInterface, "sh"}, {}});
    group_.start({"sim", "motion-sim", {"--config", config_path_, "--simulate-socketcan"}, {}});
    group_.start({std::string("gateway:") + kBus, "motion-gateway", {"--config", config_path_, "--bus", kBus}, {}});
    group_.start({"coordinator", "motion-coordinator", {"--config", config_path_}, {}});
    for (const std::string name : {"sim", "gateway:can0", "coordinator"}) {
      if (!group_.wait_for_heartbeat(name, kStartTimeout, true))
        return ::testing::AssertionFailure() << "no heartbeat from " << name;
    }
    if (!group_.wait_for_heartbeat("coordinator", kStartTimeout))
      return ::testing::AssertionFailure() << "the coordinator never heard the gateway";
    const bool online = client_.wait_until(
        [&] {
          return std::all_of(axes.begin(), axes.end(), [&](const std::string& axis) {
            const auto it = client_.axes().find(axis);
            return it != client_.axes().end() && it->second.online;
          });
        },
        kStartTimeout);
    if (!online) {
      auto failure = ::testing::AssertionFailure() << "axes not online within " << kStartTimeout.count() << " s:";
      for (const auto& axis : axes)
        failure << " " << axis << (client_.axes().contains(axis) ? "(state seen)" : "(no state)");
      return failure;
    }
    return ::testing::AssertionSuccess();
  }

  reply_t call(request_t request, std::vector<reply_t>* seen = nullptr) {
    return client_.call(std::move(request), kRequestTimeout, [seen](const reply_t& r) {
      if (seen != nullptr) seen->push_back(r);
    });
  }

  // Stops candump (SIGTERM: it flushes and exits) and returns what it printed.
  std::string stop_candump() {
    if (candump_ > 0) group_.stop(candump_);
    candump_ = -1;
    return group_.log_of("candump");
  }

  [[nodiscard]] std::vector<sim_report_t> starts_of(const std::string& drive) const {
    std::vector<sim_report_t> out;
    for (const auto& r : reports_) {
      if (r.drive == drive && r.kind == started_kind()) out.push_back(r);
    }
    return out;
  }
  void clear() {
    reports_.clear();
    frames_.clear();
  }
  [[nodiscard]] const std::vector<can::Frame>& frames() const { return frames_; }
  double position(const std::string& axis) { return client_.axes().at(axis).position; }
  double tolerance(const std::string& axis) const { return 1.0 / config_.find_axis(axis)->steps_per_unit + 1e-9; }
  Client& client() { return client_; }
  ProcessGroup& group() { return group_; }

 private:
  std::string config_path_ = lab_config();
  ProcessGroup group_;
  config::Config config_;
  Client client_;
  can::SocketCanTransport listener_;
  pid_t candump_ = -1;
  std::vector<sim_report_t> reports_;
  std::vector<can::Frame> frames_;
};

bool saw(const std::vector<reply_t>& replies, std::int8_t status) {
  return std::any_of(replies.begin(), replies.end(), [&](const reply_t& r) { return r.status == status; });
}

class SocketCanE2e : public ::testing::Test {
 protected:
  static void TearDownTestSuite() { lab_.reset(); }  // kills every process of the lab

  void SetUp() override {
    if (!in_vm()) GTEST_SKIP() << "needs SocketCAN and vcan0: run inside tools/vm/socketcan-vm (ctest -L vm)";
    if (!lab_) {
      lab_ = std::make_unique<VmLab>();
      started_ = lab_->start({"x", "y", "a", "b"});
      if (!started_) lab_->group().print_logs();
    }
    ASSERT_TRUE(started_);
    lab_->clear();
  }
  void TearDown() override {
    if (HasFailure() && lab_) lab_->group().print_logs();
  }

  void enable(const std::vector<std::string>& axes) {
    const auto enabled = lab_->call(Client::make(request_t::ENABLE, axes));
    ASSERT_EQ(enabled.status, st(reply_t::DONE)) << enabled.reason;
  }
  // A synchronized absolute move that must end DONE with every axis at its target.
  void move(const Values& targets) {
    std::vector<reply_t> replies;
    const auto done = lab_->call(Client::make(request_t::MOVE_ABSOLUTE, targets), &replies);
    ASSERT_EQ(done.status, st(reply_t::DONE)) << done.reason;
    EXPECT_TRUE(saw(replies, reply_t::ACCEPTED));
    EXPECT_TRUE(saw(replies, reply_t::STARTED));
    ASSERT_EQ(done.num_axes, static_cast<std::int32_t>(targets.size()));
    for (std::size_t i = 0; i < done.axes.size(); ++i) {
      EXPECT_NEAR(done.positions[i], done.targets[i], lab_->tolerance(done.axes[i])) << done.axes[i];
      EXPECT_NEAR(done.targets[i], targets.at(done.axes[i]), lab_->tolerance(done.axes[i])) << done.axes[i];
    }
    for (const auto& [axis, target] : targets) {
      EXPECT_TRUE(lab_->client().wait_until(
          [&, &a = axis, &t = target] { return std::abs(lab_->position(a) - t) <= lab_->tolerance(a); }, seconds(5)))
          << axis << " reports " << lab_->position(axis) << ", expected " << target;
    }
  }
  // Both drives started exactly once, on the same frame; returns its time stamp.
  std::int64_t common_start(const std::string& first, const std::string& second) {
    const auto a = lab_->starts_of(first);
    const auto b = lab_->starts_of(second);
    EXPECT_EQ(a.size(), 1u) << first;
    EXPECT_EQ(b.size(), 1u) << second;
    if (a.size() != 1 || b.size() != 1) return 0;
    EXPECT_EQ(a[0].frame_utime, b[0].frame_utime) << first << " and " << second << " did not start on the same frame";
    return a[0].frame_utime;
  }

  static std::unique_ptr<VmLab> lab_;
  static bool started_;
};

std::unique_ptr<VmLab> SocketCanE2e::lab_;
bool SocketCanE2e::started_ = false;

// UIM342: x and y (group 20) start on one BG frame to the group, seen once on vcan0.
TEST_F(SocketCanE2e, Uim342GroupMoveStartsOnOneBgFrame) {
  enable({"x", "y"});
  lab_->clear();
  move({{"x", 10.0}, {"y", 5.0}});
  const auto x = lab_->starts_of("x-drive");
  const auto y = lab_->starts_of("y-drive");
  ASSERT_EQ(x.size(), 1u);
  ASSERT_EQ(y.size(), 1u);
  EXPECT_EQ(x[0].target_counts, 6400);
  EXPECT_EQ(y[0].target_counts, 3200);
  const std::int64_t start = common_start("x-drive", "y-drive");

  std::vector<can::Frame> bg;
  for (const auto& f : lab_->frames()) {
    if (is_bg_to_group(f.id, f.extended, kGroupId)) bg.push_back(f);
  }
  ASSERT_EQ(bg.size(), 1u) << "BG frames to group " << kGroupId << " on " << kInterface;
  // Every socket on vcan0 gets the kernel's one time stamp of the frame.
  EXPECT_EQ(bg[0].timestamp_us, start) << "the drives did not start on the BG frame the listener saw";

  const std::string candump = lab_->stop_candump();
  EXPECT_EQ(count_candump_bg(candump, kGroupId), 1) << "candump -L " << kInterface << ":\n" << candump;
}

// UC57 (CANopen CiA 402): a and b get their targets in synchronous RPDOs and start on one SYNC.
TEST_F(SocketCanE2e, Uc57MoveStartsOnOneSync) {
  enable({"a", "b"});
  lab_->clear();
  move({{"a", 180.0}, {"b", -120.0}});
  const std::int64_t start = common_start("a-drive", "b-drive");
  const bool on_a_sync = std::any_of(lab_->frames().begin(), lab_->frames().end(), [&](const can::Frame& f) {
    return !f.extended && f.id == kSyncId && f.timestamp_us == start;
  });
  EXPECT_TRUE(on_a_sync) << "no SYNC on " << kInterface << " at the drives' start time " << start;
}

// Both families in one request on the one bus: one BG for x, y and one SYNC for a, b.
TEST_F(SocketCanE2e, BothFamiliesMoveTogether) {
  enable({"x", "y", "a", "b"});
  lab_->clear();
  move({{"x", 2.0}, {"y", 8.0}, {"a", -90.0}, {"b", 45.0}});
  common_start("x-drive", "y-drive");
  common_start("a-drive", "b-drive");
}

}  // namespace
}  // namespace motion::testing
