#include "motion/gateway/can_bus_driver.hpp"

#include <gtest/gtest.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <deque>
#include <functional>

#include <motionlcm/event_t.hpp>

namespace motion::gateway {
namespace {

using motionlcm::gateway_reply_t;
using std::chrono::milliseconds;

// An in-memory transport: frames pushed by the test become readable through an eventfd.
class MemoryTransport : public can::Transport {
 public:
  MemoryTransport() : fd_(::eventfd(0, EFD_NONBLOCK)) {}
  ~MemoryTransport() override { ::close(fd_); }
  std::string name() const override { return "mem"; }
  int fd() const override { return fd_; }
  std::error_code send(const can::Frame& f) override {
    sent.push_back(f);
    if (echo) {  // own echo, as SocketCAN with CAN_RAW_RECV_OWN_MSGS: back once "sent"
      can::Frame back = f;
      back.timestamp_us = next_echo_us;
      push(back);
    }
    return {};
  }
  std::optional<can::Frame> receive() override {
    std::uint64_t n;
    (void)::read(fd_, &n, sizeof n);
    if (inbox.empty()) return std::nullopt;
    auto f = inbox.front();
    inbox.pop_front();
    return f;
  }
  std::error_code set_filters(const std::vector<can::Filter>&) override { return {}; }
  std::error_code set_own_echo(bool) override { return {}; }
  can::BusState state() const override { return can::BusState::kErrorActive; }
  can::Statistics statistics() const override { return {}; }
  void push(const can::Frame& f) {
    inbox.push_back(f);
    std::uint64_t one = 1;
    (void)::write(fd_, &one, sizeof one);
  }
  void raise(can::BusState s) { emit_bus_event({s, 0x40, "test"}); }

  std::vector<can::Frame> sent;
  std::deque<can::Frame> inbox;
  bool echo = false;
  std::int64_t next_echo_us = 0;  // timestamp of the echoes

 private:
  int fd_;
};

// A stack that takes frames of one format and replies as the test scripts it.
class FakeStack : public CanStack {
 public:
  FakeStack(CanStackContext ctx, bool extended, std::vector<std::string> axes)
      : ctx_(std::move(ctx)), extended_(extended), axes_(std::move(axes)) {}
  std::string family() const override { return extended_ ? "ext" : "std"; }
  std::vector<std::string> axes() const override { return axes_; }
  void start(TimePoint) override { started = true; }
  bool on_frame(const can::Frame& f, TimePoint) override {
    if (f.extended != extended_) return false;
    frames.push_back(f);
    return true;
  }
  void on_transmitted(const can::Frame& f, TimePoint) override { transmitted.push_back(f); }
  TimePoint process(TimePoint now) override {
    ++process_calls;
    if (wake_at && now >= *wake_at) {
      woke = true;
      wake_at.reset();
    }
    return wake_at.value_or(kNever);
  }
  void execute(const motionlcm::gateway_command_t& c, TimePoint) override {
    commands.push_back(c);
    for (const auto status : replies_in_execute) reply(c.command_id, status);
  }
  void fire(std::int64_t id, TimePoint) override {
    fired.push_back(id);
    if (on_fire) on_fire(id);
  }
  bool ready() const override { return is_ready; }
  void add_statistics(motionlcm::bus_stats_t& s) const override { s.timeouts += 3; }
  void reply(std::int64_t id, std::int8_t status, std::int64_t trigger_utime = 0, const std::string& mechanism = {}) {
    gateway_reply_t r{};
    r.command_id = id;
    r.status = status;
    r.trigger_utime = trigger_utime;
    r.start_mechanism = mechanism;
    ctx_.out->command_reply(r);
  }
  bool send(const can::Frame& f) { return ctx_.send(f); }
  void mark_start(std::int64_t id, const can::Frame& f) { ctx_.start_frame(id, f); }

  bool started = false;
  bool is_ready = true;
  bool woke = false;
  int process_calls = 0;
  std::optional<TimePoint> wake_at;
  std::vector<can::Frame> frames;
  std::vector<can::Frame> transmitted;  // echoes of our frames (on_transmitted)
  std::vector<motionlcm::gateway_command_t> commands;
  std::vector<std::int64_t> fired;
  std::vector<std::int8_t> replies_in_execute;           // sent from inside execute(), in this order
  std::function<void(std::int64_t trigger_id)> on_fire;  // runs inside fire()

 private:
  CanStackContext ctx_;
  bool extended_;
  std::vector<std::string> axes_;
};

struct Recorder : GatewayOutput {
  void axis_status(const std::string&, const DriveStatus&) override {}
  void axis_event(const std::string& axis, const DriveEvent& e) override { events.emplace_back(axis, e); }
  void command_reply(gateway_reply_t r) override { replies.push_back(r); }
  std::vector<std::pair<std::string, DriveEvent>> events;
  std::vector<gateway_reply_t> replies;
};

struct CanBusDriverTest : ::testing::Test {
  CanBusDriverTest() {
    auto t = std::make_unique<MemoryTransport>();
    transport = t.get();
    driver = std::make_unique<CanBusDriver>(loop, "can0", std::move(t), out);
    auto a = std::make_unique<FakeStack>(driver->context(), true, std::vector<std::string>{"x", "y"});
    auto b = std::make_unique<FakeStack>(driver->context(), false, std::vector<std::string>{"a"});
    uim = a.get();
    cop = b.get();
    driver->add_stack(std::move(a));
    driver->add_stack(std::move(b));
    driver->start();
  }
  motionlcm::gateway_command_t command(std::int64_t id, const std::vector<std::string>& axes) {
    motionlcm::gateway_command_t c{};
    c.command_id = id;
    c.bus = "can0";
    c.kind = motionlcm::gateway_command_t::ARM_MOVE;
    for (auto& name : axes) {
      motionlcm::axis_command_t a{};
      a.axis = name;
      c.axes.push_back(a);
    }
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    return c;
  }

  EventLoop loop;
  Recorder out;
  MemoryTransport* transport = nullptr;
  std::unique_ptr<CanBusDriver> driver;
  FakeStack* uim = nullptr;
  FakeStack* cop = nullptr;
};

TEST_F(CanBusDriverTest, FramesGoToTheStackOfTheirFormat) {
  EXPECT_TRUE(uim->started);
  transport->push(*can::parse_cansend("04280095#01"));
  transport->push(*can::parse_cansend("701#05"));
  loop.run_once(milliseconds(10));
  ASSERT_EQ(uim->frames.size(), 1u);
  ASSERT_EQ(cop->frames.size(), 1u);
  EXPECT_EQ(uim->frames[0].id, 0x04280095u);
  EXPECT_EQ(cop->frames[0].id, 0x701u);
  EXPECT_TRUE(uim->send(*can::parse_cansend("601#40")));
  EXPECT_EQ(transport->sent.size(), 1u);
}

TEST_F(CanBusDriverTest, CommandIsSplitAndRepliesAreCombined) {
  driver->execute(command(5, {"x", "a", "y"}));
  ASSERT_EQ(uim->commands.size(), 1u);
  ASSERT_EQ(cop->commands.size(), 1u);
  EXPECT_EQ(uim->commands[0].num_axes, 2);
  EXPECT_EQ(cop->commands[0].axes[0].axis, "a");

  uim->reply(5, gateway_reply_t::ARMED);
  EXPECT_TRUE(out.replies.empty());  // the CANopen part is not armed yet
  cop->reply(5, gateway_reply_t::ARMED);
  ASSERT_EQ(out.replies.size(), 1u);
  EXPECT_EQ(out.replies[0].status, std::int8_t{gateway_reply_t::ARMED});

  driver->fire(9);
  EXPECT_EQ(uim->fired, std::vector<std::int64_t>{9});
  EXPECT_EQ(cop->fired, std::vector<std::int64_t>{9});
  uim->reply(5, gateway_reply_t::STARTED, 1000, "group-bg");
  cop->reply(5, gateway_reply_t::STARTED, 1130, "sync");
  ASSERT_EQ(out.replies.size(), 2u);
  EXPECT_EQ(out.replies[1].trigger_utime, 1000);
  EXPECT_EQ(out.replies[1].start_mechanism, "group-bg+sync");
  EXPECT_DOUBLE_EQ(out.replies[1].predicted_skew_us, 130.0);
}

// A reply belongs to the part of the stack that sends it: one stack's second DONE (from inside its
// execute()) is refused, not taken for the other stack's, and the command is DONE once, when the
// other stack is done too.
TEST_F(CanBusDriverTest, AStacksSecondTerminalReplyIsNotTheOtherStacks) {
  uim->replies_in_execute = {gateway_reply_t::DONE, gateway_reply_t::DONE};
  auto c = command(12, {"x", "a"});
  c.kind = motionlcm::gateway_command_t::ENABLE;
  driver->execute(c);
  EXPECT_TRUE(out.replies.empty()) << "DONE before the CANopen part was done";
  cop->reply(12, gateway_reply_t::DONE);
  ASSERT_EQ(out.replies.size(), 1u);
  EXPECT_EQ(out.replies[0].status, std::int8_t{gateway_reply_t::DONE});
}

// Own echo: a STARTED reply waits for the echo of the command's start frame and carries its time
// (when the frame was on the wire), not the stack's hand-off time; echoes never reach the stacks
// as received frames, but every stack hears of them through on_transmitted() (UIM342 polls are
// paced by it).
TEST_F(CanBusDriverTest, StartedIsDatedByTheEchoOfTheStartFrame) {
  transport->echo = true;
  transport->next_echo_us = 5'000;
  ASSERT_TRUE(uim->send(*can::parse_cansend("04280095#01")));  // a first echo: echoes work
  loop.run_once(milliseconds(10));
  EXPECT_TRUE(uim->frames.empty()) << "an echo went to the stack";
  ASSERT_EQ(uim->transmitted.size(), 1u);
  EXPECT_EQ(uim->transmitted[0], *can::parse_cansend("04280095#01"));
  EXPECT_EQ(cop->transmitted.size(), 1u) << "every stack hears of every echo";

  driver->execute(command(6, {"x"}));
  uim->reply(6, gateway_reply_t::ARMED);
  driver->fire(1);
  transport->next_echo_us = 7'777;
  const auto bg = *can::parse_cansend("00A80014#");
  ASSERT_TRUE(uim->send(bg));
  uim->mark_start(6, bg);
  uim->reply(6, gateway_reply_t::STARTED, 1000, "group-bg");  // dated at the hand-off
  ASSERT_EQ(out.replies.size(), 1u) << "STARTED went out before its start frame's echo";
  loop.run_once(milliseconds(10));
  ASSERT_EQ(out.replies.size(), 2u);
  EXPECT_EQ(out.replies[1].status, std::int8_t{gateway_reply_t::STARTED});
  EXPECT_EQ(out.replies[1].trigger_utime, 7'777);
  EXPECT_TRUE(uim->frames.empty());
}

// The stacks' frames of one fire reach the transport back to back, after every stack has fired:
// nothing a stack does after its start frames (its replies, its bookkeeping) comes between them
// and the next stack's. The STARTED replies still carry their start frames' echoes.
TEST_F(CanBusDriverTest, StartFramesOfAllStacksAreHandedOverTogetherAfterTheyFired) {
  transport->echo = true;
  transport->next_echo_us = 5'000;
  ASSERT_TRUE(uim->send(*can::parse_cansend("04280095#01")));  // a first echo: echoes work
  loop.run_once(milliseconds(10));
  const std::size_t before = transport->sent.size();
  driver->execute(command(8, {"x", "a"}));
  uim->reply(8, gateway_reply_t::ARMED);
  cop->reply(8, gateway_reply_t::ARMED);
  const auto bg = *can::parse_cansend("00A80014#");
  const auto image = *can::parse_cansend("201#1F00");
  const auto sync = *can::parse_cansend("080#");
  std::vector<std::size_t> handed_at_fire;  // frames the transport had when each stack fired
  uim->on_fire = [&](std::int64_t) {
    handed_at_fire.push_back(transport->sent.size() - before);
    EXPECT_TRUE(uim->send(bg));
    uim->mark_start(8, bg);
    uim->reply(8, gateway_reply_t::STARTED, 1000, "group-bg");
  };
  cop->on_fire = [&](std::int64_t) {
    handed_at_fire.push_back(transport->sent.size() - before);
    EXPECT_TRUE(cop->send(image));
    EXPECT_TRUE(cop->send(sync));
    cop->mark_start(8, sync);
    cop->reply(8, gateway_reply_t::STARTED, 1100, "sync");
  };
  driver->fire_ordered(3, {8});
  EXPECT_EQ(handed_at_fire, (std::vector<std::size_t>{0, 0}))
      << "a stack's frames were handed over before the other fired";
  // Each stack's frames in its order, the stacks one after the other.
  const std::vector<can::Frame> handed(transport->sent.begin() + static_cast<std::ptrdiff_t>(before),
                                       transport->sent.end());
  EXPECT_TRUE(handed == (std::vector<can::Frame>{bg, image, sync}) ||
              handed == (std::vector<can::Frame>{image, sync, bg}))
      << handed.size() << " frames";
  EXPECT_EQ(out.replies.size(), 1u) << "STARTED went out before its start frames' echoes";
  loop.run_once(milliseconds(10));
  ASSERT_EQ(out.replies.size(), 2u);
  EXPECT_EQ(out.replies[1].status, std::int8_t{gateway_reply_t::STARTED});
  EXPECT_EQ(out.replies[1].trigger_utime, 5'000);
  // Outside a fire a frame goes to the transport at once.
  EXPECT_TRUE(uim->send(bg));
  EXPECT_EQ(transport->sent.size(), before + 4);
}

// A start frame whose echo never comes (lost, bus off): the reply goes out after 50 ms anyway,
// with the hand-off time.
TEST_F(CanBusDriverTest, StartedWithoutItsEchoGoesOutAfterTheWait) {
  transport->echo = true;
  ASSERT_TRUE(uim->send(*can::parse_cansend("04280095#01")));
  loop.run_once(milliseconds(10));
  transport->echo = false;
  driver->execute(command(7, {"x"}));
  const auto bg = *can::parse_cansend("00A80014#");
  ASSERT_TRUE(uim->send(bg));
  uim->mark_start(7, bg);
  uim->reply(7, gateway_reply_t::STARTED, 1234, "group-bg");
  EXPECT_TRUE(out.replies.empty());
  const auto until = loop.now() + milliseconds(200);
  while (out.replies.empty() && loop.now() < until) loop.run_once(milliseconds(10));
  ASSERT_EQ(out.replies.size(), 1u);
  EXPECT_EQ(out.replies[0].trigger_utime, 1234);
}

TEST_F(CanBusDriverTest, FirstFailureIsReportedOnce) {
  driver->execute(command(6, {"x", "a"}));
  cop->reply(6, gateway_reply_t::FAILED);
  uim->reply(6, gateway_reply_t::ARMED);
  ASSERT_EQ(out.replies.size(), 1u);
  EXPECT_EQ(out.replies[0].status, std::int8_t{gateway_reply_t::FAILED});
}

TEST_F(CanBusDriverTest, AxisWithoutAStackFailsWithAReason) {
  driver->execute(command(7, {"x", "q"}));
  ASSERT_EQ(out.replies.size(), 1u);
  EXPECT_EQ(out.replies[0].status, std::int8_t{gateway_reply_t::FAILED});
  EXPECT_NE(out.replies[0].reason.find("axis 'q'"), std::string::npos);
  EXPECT_TRUE(uim->commands.empty());
}

TEST_F(CanBusDriverTest, StackDeadlineWakesTheDriver) {
  uim->wake_at = loop.now() + milliseconds(20);
  transport->push(*can::parse_cansend("04280095#01"));  // any event reschedules
  const auto end = loop.now() + milliseconds(500);
  while (!uim->woke && loop.now() < end) loop.run_once(milliseconds(50));
  EXPECT_TRUE(uim->woke);
}

// Over a start's traffic hold the stacks are not asked for their own traffic (process(): polls,
// SYNCs, timeouts), though the frames that arrive are still handed to them; their deadlines are
// kept for after it. The fire ends the hold, and so does a command (a stop must not wait for it).
TEST_F(CanBusDriverTest, AHoldBeforeAStartKeepsTheStacksOwnTrafficUntilTheFireOrACommand) {
  for (const bool end_by_command : {false, true}) {
    SCOPED_TRACE(end_by_command ? "ended by a command" : "ended by the fire");
    const TimePoint now = loop.now();
    driver->hold_traffic(now, now + milliseconds(500));
    const int calls = uim->process_calls;
    uim->wake_at = now + milliseconds(5);  // a poll due inside the hold
    transport->push(*can::parse_cansend("04280095#01"));
    const auto until = now + milliseconds(40);
    while (loop.now() < until) loop.run_once(milliseconds(5));
    EXPECT_FALSE(uim->frames.empty()) << "a frame that arrived was not read";
    uim->frames.clear();
    EXPECT_EQ(uim->process_calls, calls) << "the stack was asked for its traffic inside the hold";
    EXPECT_FALSE(uim->woke);
    if (end_by_command) {
      driver->execute(command(40, {"x"}));
    } else {
      driver->fire(41);
    }
    EXPECT_GT(uim->process_calls, calls);
    EXPECT_TRUE(uim->woke) << "the deadline due inside the hold is done at its end";
    uim->woke = false;
  }
  // A hold whose fire never comes ends by itself, shortly after its end.
  const TimePoint now = loop.now();
  driver->hold_traffic(now, now + milliseconds(20));
  uim->wake_at = now + milliseconds(1);
  transport->push(*can::parse_cansend("04280095#01"));
  loop.run_once(milliseconds(5));
  EXPECT_FALSE(uim->woke);
  const auto deadline = now + milliseconds(500);
  while (!uim->woke && loop.now() < deadline) loop.run_once(milliseconds(5));
  EXPECT_TRUE(uim->woke);
  EXPECT_GE(loop.now() - now, milliseconds(20));
}

TEST_F(CanBusDriverTest, BusOffBecomesAnEventAndNotReady) {
  EXPECT_TRUE(driver->ready());
  transport->raise(can::BusState::kBusOff);
  ASSERT_EQ(out.events.size(), 1u);
  EXPECT_EQ(out.events[0].second.kind, std::int16_t{motionlcm::event_t::BUS_OFF});
  EXPECT_FALSE(driver->ready());
  transport->raise(can::BusState::kErrorActive);
  EXPECT_EQ(out.events.back().second.kind, std::int16_t{motionlcm::event_t::BUS_RECOVERED});
  EXPECT_TRUE(driver->ready());
  EXPECT_EQ(driver->statistics()[0].timeouts, 6);  // both stacks add theirs
}

}  // namespace
}  // namespace motion::gateway
