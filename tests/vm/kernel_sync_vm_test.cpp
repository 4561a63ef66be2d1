// kernel_sync in the QEMU VM (tools/vm/socketcan-vm): the gateway's CAN bus driver on vcan0 with
// the kernel's cyclic sender (CAN_BCM), as motion-gateway assembles a socketcan: bus. The
// periodic SYNC comes from the kernel; a second socket on vcan0 sees what is on the wire.
// The VM's clock is emulated (TCG) on a loaded machine: bounds are wide.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "motion/can/socketcan.hpp"
#include "motion/can/socketcan_cyclic.hpp"
#include "motion/canopen/cob_id.hpp"
#include "motion/canopen/sync.hpp"
#include "motion/config/config.hpp"
#include "motion/core/clock.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/gateway/can_bus_driver.hpp"
#include "motion/uc57_driver/uc57_stack.hpp"

namespace motion::gateway {
namespace {

using namespace std::chrono_literals;

constexpr const char* kBus = "vcan0";

struct NullOutput : GatewayOutput {
  void axis_status(const std::string&, const DriveStatus&) override {}
  void axis_event(const std::string&, const DriveEvent&) override {}
  void command_reply(motionlcm::gateway_reply_t reply) override { replies.push_back(std::move(reply)); }
  std::vector<motionlcm::gateway_reply_t> replies;
};

// A stack that is only a SYNC producer, wired to its context as the UC57 stack wires its own.
class SyncStack final : public CanStack {
 public:
  SyncStack(CanStackContext context, Duration period)
      : context_(std::move(context)), producer_([this](const can::Frame& f) { context_.send(f); }, {period, 0}) {
    producer_.use_cyclic_sender({[this](const can::Frame& f, Duration p) { return context_.start_cyclic(f, p); },
                                 [this] { context_.stop_cyclic(canopen::encode_sync({})); },
                                 [this](Duration i) { return context_.retime_cyclic(canopen::encode_sync({}), i); }});
  }
  [[nodiscard]] std::string family() const override { return "sync"; }
  [[nodiscard]] std::vector<std::string> axes() const override { return {"s"}; }
  void start(TimePoint now) override { producer_.start(now); }
  bool on_frame(const can::Frame&, TimePoint) override { return false; }
  void on_cyclic_sent(const can::Frame& frame, TimePoint now) override {
    if (frame.id == canopen::kSyncCobId) producer_.on_cyclic_sync(now);
    if (on_sync) on_sync(producer_.sent());
  }
  TimePoint process(TimePoint now) override { return producer_.process(now); }
  // ARM_MOVE: ARMED at once; its trigger: one SYNC (trigger_now), the command's start frame, then
  // STARTED dated at the hand-off (the driver replaces the date by the SYNC's time on the wire).
  void execute(const motionlcm::gateway_command_t& command, TimePoint) override {
    armed_ = command.command_id;
    reply(motionlcm::gateway_reply_t::ARMED, 0);
  }
  void fire(std::int64_t, TimePoint now) override {
    producer_.trigger_now(now);
    context_.start_frame(armed_, canopen::encode_sync({}));
    reply(motionlcm::gateway_reply_t::STARTED, wall_time_us());
  }
  [[nodiscard]] bool ready() const override { return true; }
  void add_statistics(motionlcm::bus_stats_t&) const override {}

  canopen::SyncProducer& producer() { return producer_; }
  std::function<void(std::uint64_t sent)> on_sync;

 private:
  void reply(std::int8_t status, std::int64_t trigger_utime) {
    motionlcm::gateway_reply_t r{};
    r.command_id = armed_;
    r.status = status;
    r.trigger_utime = trigger_utime;
    r.start_mechanism = "sync";
    context_.out->command_reply(r);
  }
  std::int64_t armed_ = 0;
  CanStackContext context_;
  canopen::SyncProducer producer_;
};

// The gateway side (driver + kernel sender on vcan0) and a watcher of SYNCs on the wire.
struct KernelSyncVm : ::testing::Test {
  void SetUp() override {
    if (std::getenv("MOTION_IN_VM") == nullptr) GTEST_SKIP() << "runs in the VM only (tools/vm/socketcan-vm)";
    auto transport = std::make_unique<can::SocketCanTransport>();
    ASSERT_FALSE(transport->open(kBus));
    driver = std::make_unique<CanBusDriver>(loop, "can0", std::move(transport), out);
    auto cyclic = std::make_unique<can::SocketCanCyclic>();
    ASSERT_FALSE(cyclic->open(kBus));
    driver->use_cyclic(std::move(cyclic));
    can::SocketCanOptions only_sync;
    only_sync.filters = {{canopen::kSyncCobId, 0x7FF, false, true}};
    ASSERT_FALSE(watcher.open(kBus, only_sync));
    loop.watch(watcher.fd(), [this] {
      while (auto f = watcher.receive()) wire.push_back(f->timestamp_us);
    });
  }
  void TearDown() override {
    if (watcher.fd() >= 0) loop.unwatch(watcher.fd());
  }
  void run_for(Duration d) {
    const TimePoint end = loop.now() + d;
    while (loop.now() < end) loop.run_once(end - loop.now());
  }
  static std::int64_t median_gap(const std::vector<std::int64_t>& stamps) {
    std::vector<std::int64_t> gaps;
    for (std::size_t i = 1; i < stamps.size(); ++i) gaps.push_back(stamps[i] - stamps[i - 1]);
    if (gaps.empty()) return 0;
    std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2), gaps.end());
    return gaps[gaps.size() / 2];
  }
  // Count over the stamped span and the median gap match `period_us` (bounds as BcmSendsPeriodicSync).
  static void expect_periodic(const std::vector<std::int64_t>& stamps, std::int64_t period_us) {
    ASSERT_GE(stamps.size(), 2U);
    const double expected = static_cast<double>(stamps.back() - stamps.front()) / static_cast<double>(period_us) + 1;
    EXPECT_GE(static_cast<double>(stamps.size()), expected * 0.8) << stamps.size() << " SYNCs";
    EXPECT_LE(static_cast<double>(stamps.size()), expected * 1.2) << stamps.size() << " SYNCs";
    EXPECT_GE(median_gap(stamps), period_us * 8 / 10);
    EXPECT_LE(median_gap(stamps), period_us * 12 / 10);
  }

  EventLoop loop;
  NullOutput out;
  std::unique_ptr<CanBusDriver> driver;
  can::SocketCanTransport watcher;
  std::vector<std::int64_t> wire;  // SYNC receive times on the watcher (wall clock, us)
};

// The UC57 stack as motion-gateway builds it on a socketcan: bus (its drive is absent: only its
// probes and the SYNC go out).
TEST_F(KernelSyncVm, Uc57StackSyncComesFromTheKernelAndSentMatchesTheWire) {
  const auto loaded = config::load_string(R"(lcm:
  url: "udpm://239.255.76.67:7667?ttl=0"
buses:
  - {name: can0, transport: "socketcan:vcan0", bitrate: 1000000, poll_hz: 50}
drives:
  - {name: ad, family: uc57, bus: can0, node_id: 9}
axes:
  - {name: a, drive: ad, steps_per_unit: 10, limits: {min: -100, max: 100, velocity: 10, acceleration: 100}}
)");
  ASSERT_TRUE(loaded.ok()) << loaded.error_text();
  const config::Config& config = *loaded.config;
  auto stack = std::make_unique<uc57_driver::Uc57Stack>(config, config.buses[0], driver->context());
  auto* uc57 = stack.get();
  ASSERT_EQ(uc57->sync_period(), 20ms);
  driver->add_stack(std::move(stack));
  driver->start();
  run_for(1500ms);
  EXPECT_TRUE(uc57->kernel_sync_running());
  expect_periodic(wire, 20'000);
  EXPECT_GE(wire.size(), 30U) << "about 75 SYNCs in 1.5 s";
  // Counted as the driver saw them: the watcher may have one more (sent after the last read).
  EXPECT_LE(uc57->syncs_sent(), wire.size());
  EXPECT_GE(uc57->syncs_sent() + 1, wire.size());
}

TEST_F(KernelSyncVm, TriggerNowSendsOneSyncAndRestartsThePeriodStopSilencesTheBus) {
  constexpr auto kPeriod = 40ms;
  auto owned = std::make_unique<SyncStack>(driver->context(), kPeriod);
  SyncStack* stack = owned.get();
  driver->add_stack(std::move(owned));
  std::int64_t trigger_us = 0;
  std::int64_t stop_us = 0;
  std::uint64_t sent_at_stop = 0;
  stack->on_sync = [&](std::uint64_t sent) {
    // Half a period after the 10th SYNC: one SYNC now, the period from it. After the 20th: stop.
    if (sent == 10) {
      loop.call_after(kPeriod / 2, [&] {
        trigger_us = wall_time_us();
        stack->producer().trigger_now(loop.now());
      });
    }
    if (sent == 20) {
      stack->producer().stop();
      stop_us = wall_time_us();
      sent_at_stop = stack->producer().sent();
    }
  };
  driver->start();
  run_for(kPeriod * 24);
  ASSERT_NE(stop_us, 0) << wire.size() << " SYNCs, " << stack->producer().sent() << " seen by the driver";
  ASSERT_NE(trigger_us, 0);

  // Every SYNC on the wire was counted by the producer, and none came after the stop.
  EXPECT_EQ(stack->producer().sent(), wire.size());
  EXPECT_EQ(sent_at_stop, wire.size());
  EXPECT_TRUE(std::all_of(wire.begin(), wire.end(), [&](std::int64_t t) { return t <= stop_us; }))
      << "TX_DELETE at stop: nothing after it";
  EXPECT_FALSE(stack->producer().cyclic());

  // The trigger's SYNC: the first stamped after trigger_now, half a period after the one before
  // it, a whole period before the next (the period restarted), and it is the only one in that gap.
  const auto first_after = std::find_if(wire.begin(), wire.end(), [&](std::int64_t t) { return t >= trigger_us; });
  ASSERT_NE(first_after, wire.end());
  ASSERT_NE(first_after, wire.begin());
  ASSERT_NE(first_after + 1, wire.end());
  const std::int64_t period_us = std::chrono::duration_cast<std::chrono::microseconds>(kPeriod).count();
  const std::int64_t before = *first_after - *(first_after - 1);
  const std::int64_t after = *(first_after + 1) - *first_after;
  EXPECT_LT(*first_after - trigger_us, period_us / 4) << "the trigger's SYNC goes out at once";
  EXPECT_GE(before, period_us / 4) << "half a period after the previous SYNC";
  EXPECT_LE(before, period_us * 3 / 4);
  EXPECT_GE(after, period_us * 8 / 10) << "the period restarts from the trigger's SYNC";
  EXPECT_LE(after, period_us * 12 / 10);
  // Before and after the trigger the kernel keeps the period.
  expect_periodic(std::vector<std::int64_t>(wire.begin(), first_after), period_us);
  expect_periodic(std::vector<std::int64_t>(first_after, wire.end()), period_us);
}

// A start whose SYNC the kernel's restarted job sent: STARTED carries that frame's time on the wire.
TEST_F(KernelSyncVm, StartedCarriesTheTimeOfTheKernelsStartSync) {
  auto owned = std::make_unique<SyncStack>(driver->context(), 20ms);
  driver->add_stack(std::move(owned));
  driver->start();
  run_for(100ms);  // the kernel's job runs
  motionlcm::gateway_command_t arm{};
  arm.command_id = 42;
  arm.bus = "can0";
  arm.kind = motionlcm::gateway_command_t::ARM_MOVE;
  arm.trigger_id = 7;
  arm.axes.resize(1);
  arm.axes[0].axis = "s";
  arm.num_axes = 1;
  driver->execute(arm);
  const std::int64_t before_us = wall_time_us();
  driver->fire(7);
  run_for(100ms);
  const auto started = std::find_if(out.replies.begin(), out.replies.end(),
                                    [](const auto& r) { return r.status == motionlcm::gateway_reply_t::STARTED; });
  ASSERT_NE(started, out.replies.end());
  const auto start_sync = std::find_if(wire.begin(), wire.end(), [&](std::int64_t t) { return t >= before_us; });
  ASSERT_NE(start_sync, wire.end());
  EXPECT_EQ(started->trigger_utime, *start_sync) << "the kernel's receive time of the start SYNC";
}

// The kernel's timer re-arms from when it ran: its SYNCs come late by its wake-up latency each
// period. After a window of SYNCs the producer shortens the job's interval by the mean lateness
// (SETTIMER without STARTTIMER: no extra frame, the phase kept).
TEST_F(KernelSyncVm, TheKernelsLatenessIsTakenOutOfTheInterval) {
  constexpr auto kPeriod = 5ms;
  auto owned = std::make_unique<SyncStack>(driver->context(), kPeriod);
  SyncStack* stack = owned.get();
  driver->add_stack(std::move(owned));
  std::int64_t retimed_us = 0;
  stack->on_sync = [&](std::uint64_t) {
    if (retimed_us == 0 && stack->producer().cyclic_interval() != Duration::zero()) retimed_us = wall_time_us();
  };
  driver->start();
  run_for(kPeriod * (3 * canopen::SyncProducer::kDriftWindow + 20));
  stack->producer().stop();
  run_for(50ms);
  ASSERT_NE(retimed_us, 0) << "no interval change after " << wire.size() << " SYNCs";
  EXPECT_LT(stack->producer().cyclic_interval(), kPeriod) << "the kernel is never early";
  EXPECT_GE(stack->producer().cyclic_interval(), kPeriod / 2);
  EXPECT_EQ(stack->producer().sent(), wire.size());
  // No frame of its own at the change: the SYNCs around it keep the period.
  const auto at = std::find_if(wire.begin(), wire.end(), [&](std::int64_t t) { return t >= retimed_us; });
  ASSERT_NE(at, wire.end());
  ASSERT_NE(at, wire.begin());
  const std::int64_t period_us = std::chrono::duration_cast<std::chrono::microseconds>(kPeriod).count();
  EXPECT_GE(*at - *(at - 1), period_us / 2) << "the change sent no frame of its own";
  expect_periodic(std::vector<std::int64_t>(wire.begin(), wire.end()), period_us);
}

// A gateway that ends leaves no kernel job behind: closing the BCM socket deletes its jobs.
TEST_F(KernelSyncVm, NoSyncOnceTheDriverIsGone) {
  driver->add_stack(std::make_unique<SyncStack>(driver->context(), 10ms));
  driver->start();
  run_for(200ms);
  ASSERT_GE(wire.size(), 5U);
  driver.reset();
  run_for(50ms);  // one may have been in flight
  const std::size_t after_close = wire.size();
  run_for(300ms);
  EXPECT_EQ(wire.size(), after_close) << "a SYNC after the driver was gone";
}

// An interface removed and created again (an adapter replugged): the BCM socket is opened again on
// the new one and the job goes on there.
TEST(KernelSyncReplug, TheJobGoesOnOnTheRecreatedInterface) {
  if (std::getenv("MOTION_IN_VM") == nullptr) GTEST_SKIP() << "runs in the VM only (tools/vm/socketcan-vm)";
  const auto shell = [](const std::string& command) { ASSERT_EQ(std::system(command.c_str()), 0) << command; };
  shell("ip link add dev vcan1 type vcan && ip link set up dev vcan1");
  EventLoop loop;
  NullOutput out;
  const auto run_for = [&](Duration d) {
    const TimePoint end = loop.now() + d;
    while (loop.now() < end) loop.run_once(end - loop.now());
  };
  {
    auto transport = std::make_unique<can::SocketCanTransport>();
    ASSERT_FALSE(transport->open("vcan1"));
    CanBusDriver driver(loop, "can1", std::move(transport), out);
    auto cyclic = std::make_unique<can::SocketCanCyclic>();
    ASSERT_FALSE(cyclic->open("vcan1"));
    driver.use_cyclic(std::move(cyclic));
    auto owned = std::make_unique<SyncStack>(driver.context(), 20ms);
    SyncStack* stack = owned.get();
    driver.add_stack(std::move(owned));
    driver.start();
    run_for(200ms);
    ASSERT_TRUE(stack->producer().cyclic());
    shell("ip link del dev vcan1");
    run_for(100ms);
    shell("ip link add dev vcan1 type vcan && ip link set up dev vcan1");
    can::SocketCanTransport watcher;
    ASSERT_FALSE(watcher.open("vcan1"));
    std::vector<std::int64_t> seen;
    loop.watch(watcher.fd(), [&] {
      while (auto f = watcher.receive()) {
        if (f->id == canopen::kSyncCobId) seen.push_back(f->timestamp_us);
      }
    });
    const std::uint64_t sent_before = stack->producer().sent();
    run_for(500ms);
    loop.unwatch(watcher.fd());
    EXPECT_GE(seen.size(), 10U) << "about 25 SYNCs on the new vcan1";
    EXPECT_GE(stack->producer().sent() - sent_before, 10U) << "and the driver saw them";
  }
  shell("ip link del dev vcan1");
}

}  // namespace
}  // namespace motion::gateway
