// AdamStack (the ADAM Modbus RTU master, passive): every frame it sends is checked byte for byte,
// replies are scripted bytes or come from motion::adam::serve() over a fake register bank, and
// time only moves when the test says so.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include <motionlcm/event_t.hpp>

#include "motion/adam/commands.hpp"
#include "motion/adam/slave.hpp"
#include "motion/adam/status.hpp"
#include "motion/adam_driver/adam_stack.hpp"

namespace motion::adam_driver {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;
using Command = motionlcm::gateway_command_t;
using Reply = motionlcm::gateway_reply_t;

// LCM constants wrapped so that no test ODR-uses them.
constexpr std::int8_t kDone = std::int8_t{Reply::DONE};
constexpr std::int8_t kFailed = std::int8_t{Reply::FAILED};
constexpr std::int8_t kArmed = std::int8_t{Reply::ARMED};
constexpr std::int8_t kStarted = std::int8_t{Reply::STARTED};

std::string hex(const Bytes& b) {
  std::string s;
  char part[4];
  for (const auto byte : b) {
    std::snprintf(part, sizeof part, "%02X ", byte);
    s += part;
  }
  if (!s.empty()) s.pop_back();
  return s;
}
Bytes with_crc(Bytes b) {
  adam::rtu::append_crc(b);
  return b;
}

struct Recorder final : gateway::GatewayOutput {
  std::vector<std::pair<std::string, gateway::DriveStatus>> statuses;
  std::vector<gateway::DriveEvent> events;
  std::vector<Reply> replies;
  std::vector<std::string> lost;  // position_lost: why
  void position_lost(const std::string&, const std::string& why) override { lost.push_back(why); }
  void axis_status(const std::string& axis, const gateway::DriveStatus& s) override { statuses.emplace_back(axis, s); }
  void axis_event(const std::string&, const gateway::DriveEvent& e) override { events.push_back(e); }
  void command_reply(Reply r) override { replies.push_back(std::move(r)); }
  [[nodiscard]] std::vector<Reply> of(std::int64_t id) const {
    std::vector<Reply> out;
    std::copy_if(replies.begin(), replies.end(), std::back_inserter(out),
                 [id](const Reply& r) { return r.command_id == id; });
    return out;
  }
  [[nodiscard]] int terminal(std::int64_t id) const {
    const auto all = of(id);
    return static_cast<int>(
        std::count_if(all.begin(), all.end(), [](const Reply& r) { return r.status == kDone || r.status == kFailed; }));
  }
  [[nodiscard]] bool has_event(std::int16_t kind) const {
    return std::any_of(events.begin(), events.end(), [kind](const auto& e) { return e.kind == kind; });
  }
};

// A drive for the fake line: registers, and instant motion on the commands the driver uses.
struct FakeDrive final : adam::RegisterBank {
  std::vector<std::uint16_t> regs = std::vector<std::uint16_t>(0x10000, 0);
  bool completes_moves = true;
  FakeDrive() {
    regs[0x0024] = 4000;    // subdivision 4000 pulses/rev
    regs[0x0006] = 0x1000;  // X12 in position, idle
  }
  void set_position(std::int32_t p) {
    const auto w = adam::encode32(p);
    regs[4] = w[0];
    regs[5] = w[1];
  }
  [[nodiscard]] std::int32_t position() const { return adam::decode32_signed(regs[4], regs[5]); }
  void set_moving(bool moving) { regs[6] = moving ? 0x0300 : 0x1000; }
  std::optional<adam::rtu::ExceptionCode> read(std::uint16_t start, std::span<std::uint16_t> out) override {
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = regs[start + i];
    return std::nullopt;
  }
  std::optional<adam::rtu::ExceptionCode> write(std::uint16_t start, std::span<const std::uint16_t> values) override {
    for (std::size_t i = 0; i < values.size(); ++i) regs[start + i] = values[i];
    const auto move_to = [&](std::int32_t target) {
      if (completes_moves)
        set_position(target);
      else
        set_moving(true);
    };
    if (start == 0x00DD) {  // execute table entry 0 (absolute) at 300 + 0x00AC
      const std::uint32_t at = 300U + regs[0x00AC];
      move_to(adam::decode32_signed(regs[at], regs[at + 1]));
    }
    if (start == 0x00D0) move_to(adam::decode32_signed(regs[0xD0], regs[0xD1]));
    if (start == 0x00C8) set_moving(false);  // stop
    return std::nullopt;
  }
};

DriveSettings drive(const std::string& name, const std::string& axis, std::uint8_t unit) {
  DriveSettings d;
  d.drive = name;
  d.axis = axis;
  d.unit = unit;
  d.request_timeout = 100ms;
  d.retries = 1;
  d.homing_method = config::HomingMethod::kSwitch;
  return d;
}

class AdamStackTest : public ::testing::Test {
 protected:
  explicit AdamStackTest(std::vector<DriveSettings> drives = {drive("c-drive", "c", 1)}) {
    MasterSettings s;
    s.bus = "rs485";
    s.transport = "simserial:rs485";
    s.poll_period = 100ms;
    s.drives = std::move(drives);
    core = std::make_unique<AdamStack>(
        s,
        [this](std::span<const std::uint8_t> b) {
          sent.emplace_back(b.begin(), b.end());
          return true;
        },
        out, [](TimePoint) { return std::int64_t{1'000'000}; });
  }
  void advance(Duration dt) {
    now += dt;
    core->process(now);
  }
  void reply(const Bytes& bytes) {
    now += 1ms;
    core->on_bytes(bytes, now);
    core->process(now);
  }
  // Answers every frame sent so far (and those the answers cause) from the fake drives.
  void serve_pending() {
    while (answered < sent.size()) {
      const Bytes frame = sent[answered++];
      for (auto& [unit, bank] : banks) {
        const auto result = adam::serve(frame, adam::SlaveConfig{unit, {}, adam::ExceptionMode::kStandard}, bank);
        if (!result.reply.empty()) reply(result.reply);
      }
    }
  }
  // Lets `total` pass in 1 ms steps, the fake drives answering everything.
  void run_for(Duration total) {
    for (Duration t{}; t < total; t += 1ms) {
      serve_pending();
      advance(1ms);
    }
    serve_pending();
  }
  [[nodiscard]] bool was_sent(const std::string& frame) const {
    return std::any_of(sent.begin(), sent.end(), [&](const Bytes& b) { return hex(b) == frame; });
  }
  static Command command(std::int64_t id, std::int8_t kind, const std::vector<std::string>& axes) {
    Command c{};
    c.command_id = id;
    c.kind = kind;
    for (auto& a : axes) {
      motionlcm::axis_command_t ac{};
      ac.axis = a;
      c.axes.push_back(ac);
    }
    c.num_axes = static_cast<std::int32_t>(c.axes.size());
    return c;
  }

  static Command arm(std::int64_t id, std::int64_t trigger, std::vector<std::pair<std::string, std::int64_t>> targets) {
    std::vector<std::string> names;
    names.reserve(targets.size());
    for (auto& [axis, target] : targets) names.push_back(axis);
    Command c = command(id, std::int8_t{Command::ARM_MOVE}, names);
    c.trigger_id = trigger;
    for (std::size_t i = 0; i < targets.size(); ++i) {
      c.axes[i].target_counts = targets[i].second;
      c.axes[i].velocity = 8000;  // 120 rpm at 4000 pulses/rev
      c.axes[i].acceleration = 16000;
      c.axes[i].deceleration = 16000;
    }
    return c;
  }

  TimePoint now = TimePoint{} + 10s;
  Recorder out;
  std::vector<Bytes> sent;
  std::size_t answered = 0;
  std::map<std::uint8_t, FakeDrive> banks;
  std::unique_ptr<AdamStack> core;
};

TEST_F(AdamStackTest, StartUpReadsPowerOnStateAndSubdivisionThenPollsPositionStatusAndAlarm) {
  banks[1];
  core->start(now);
  run_for(20ms);
  ASSERT_GE(sent.size(), 4U);
  EXPECT_EQ(hex(sent[0]), "01 03 00 12 00 01 24 0F");                            // 0x0012 (§8.15)
  EXPECT_EQ(hex(sent[1]), "01 03 00 24 00 02 84 00");                            // 0x0024 subdivision (§8.29)
  EXPECT_EQ(hex(sent[2]), "01 03 00 04 00 04 05 C8");                            // position + status (§8.3, §8.4)
  EXPECT_EQ(hex(sent[3]), hex(with_crc({0x01, 0x03, 0x00, 0xA2, 0x00, 0x02})));  // outputs + alarm
  EXPECT_TRUE(core->ready());
  ASSERT_FALSE(out.statuses.empty());
  EXPECT_TRUE(out.statuses.back().second.online);
  EXPECT_TRUE(out.statuses.back().second.in_position);
  EXPECT_TRUE(out.has_event(std::int16_t{motionlcm::event_t::ONLINE}));
}

TEST_F(AdamStackTest, DriveThatNeverAnswersFailsWithDriveSlaveAndRegisterAfterRetries) {
  core->execute(command(1, std::int8_t{Command::ENABLE}, {"c"}), now);
  ASSERT_EQ(sent.size(), 1U);
  EXPECT_EQ(hex(sent[0]), "01 06 00 D4 00 00 C9 F2");  // enable (§8.67)
  advance(99ms);
  EXPECT_EQ(sent.size(), 1U) << "retried before request_timeout_ms";
  advance(2ms);
  ASSERT_EQ(sent.size(), 2U) << "one retry (retries: 1)";
  EXPECT_EQ(sent[1], sent[0]);
  EXPECT_EQ(out.terminal(1), 0);
  advance(101ms);
  EXPECT_EQ(sent.size(), 2U);
  ASSERT_EQ(out.terminal(1), 1);
  const Reply r = out.of(1).back();
  EXPECT_EQ(r.status, kFailed);
  EXPECT_EQ(r.error_code, error_code(ReplyError::kTimeout));
  EXPECT_NE(r.reason.find("c-drive"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("slave 1"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("0x00D4"), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find("2 attempts"), std::string::npos) << r.reason;
  const auto stats = core->statistics();
  EXPECT_EQ(stats.timeouts, 2);
  EXPECT_EQ(stats.retries, 1);
  EXPECT_EQ(core->process(now), kNever) << "nothing left to do: no timer";
}

TEST_F(AdamStackTest, CrcErrorIsCountedReportedAndRetried) {
  core->execute(command(2, std::int8_t{Command::ENABLE}, {"c"}), now);
  Bytes corrupted = sent[0];
  corrupted.back() ^= 0x01;
  reply(corrupted);
  EXPECT_EQ(sent.size(), 1U) << "a bad-CRC frame is only closed by t3.5 silence";
  advance(2ms);  // > 1.75 ms at 115200 bit/s
  EXPECT_TRUE(out.has_event(std::int16_t{motionlcm::event_t::PROTOCOL_ERROR}));
  EXPECT_NE(out.events.back().text.find("CRC"), std::string::npos) << out.events.back().text;
  advance(2ms);
  ASSERT_EQ(sent.size(), 2U) << "retried after the line was silent again";
  reply(sent[1]);  // FC 0x06 normal reply = echo
  ASSERT_EQ(out.terminal(2), 1);
  EXPECT_EQ(out.of(2).back().status, kDone);
  EXPECT_EQ(core->statistics().errors, 1);
  EXPECT_EQ(core->statistics().retries, 1);
}

TEST_F(AdamStackTest, AReplyDeliveredInPiecesWithPausesLongerThanT35IsJoinedNotACrcError) {
  banks[1].set_position(-123456);
  // A read of 0x0004…0x0007 as the poll makes it: 13 reply bytes, delivered 5 + 4 + 4 with 10 ms
  // between pieces (a USB adapter's latency timer, or a loaded host), each pause > t3.5 (1.75 ms).
  const Bytes request = with_crc({0x01, 0x03, 0x00, 0x04, 0x00, 0x04});
  core->start(now);
  // Answer the start-up reads whole until the first poll of position and status goes out.
  for (int i = 0; i < 50 && !was_sent(hex(request)); ++i) {
    serve_pending();
    advance(1ms);
  }
  ASSERT_TRUE(was_sent(hex(request)));
  ASSERT_EQ(hex(sent.back()), hex(request));
  const auto served = adam::serve(sent.back(), adam::SlaveConfig{1, {}, adam::ExceptionMode::kStandard}, banks[1]);
  ASSERT_EQ(served.reply.size(), 13U);
  answered = sent.size();
  const auto errors_before = core->statistics().errors;
  const std::size_t sent_before = sent.size();
  for (std::size_t at = 0; at < 13;) {
    const std::size_t n = at == 0 ? 5 : 4;
    reply(Bytes(served.reply.begin() + static_cast<std::ptrdiff_t>(at),
                served.reply.begin() + static_cast<std::ptrdiff_t>(at + n)));
    at += n;
    if (at < 13) advance(10ms);
  }
  EXPECT_EQ(core->statistics().errors, errors_before) << "a reply split by pauses was taken for garbage";
  EXPECT_EQ(sent.size(), sent_before) << "the request was repeated";
  EXPECT_FALSE(out.has_event(std::int16_t{motionlcm::event_t::PROTOCOL_ERROR}));
  ASSERT_FALSE(out.statuses.empty());
  EXPECT_EQ(out.statuses.back().second.position_counts, -123456);
}

TEST_F(AdamStackTest, APieceOfAReplyThatNeverCompletesEndsAtTheReplyDeadlineAndIsRetried) {
  core->execute(command(6, std::int8_t{Command::ENABLE}, {"c"}), now);
  reply(Bytes(sent[0].begin(), sent[0].begin() + 3));  // 3 of the echo's 8 bytes, then nothing
  advance(50ms);
  EXPECT_EQ(sent.size(), 1U) << "the piece was closed by silence instead of waiting for the rest";
  advance(51ms);  // request_timeout 100 ms
  ASSERT_EQ(sent.size(), 2U) << "retried at the reply deadline";
  reply(sent[1]);
  ASSERT_EQ(out.terminal(6), 1);
  EXPECT_EQ(out.of(6).back().status, kDone);
  EXPECT_EQ(core->statistics().retries, 1);
}

TEST_F(AdamStackTest, ALateReplyJoinedToTheRetrysReplyIsOneReplyAndOneStrayFrameNotACrcError) {
  core->execute(command(7, std::int8_t{Command::ENABLE}, {"c"}), now);
  advance(101ms);  // no answer within request_timeout: the retry goes out
  ASSERT_EQ(sent.size(), 2U);
  // Then both answers arrive in one read, without a silence between them.
  Bytes both = sent[0];
  both.insert(both.end(), sent[1].begin(), sent[1].end());
  reply(both);
  ASSERT_EQ(out.terminal(7), 1);
  EXPECT_EQ(out.of(7).back().status, kDone);
  advance(2ms);  // the second echo, closed by silence with nothing in flight: a stray frame
  EXPECT_FALSE(std::any_of(out.events.begin(), out.events.end(), [](const auto& e) {
    return e.kind == motionlcm::event_t::OFFLINE || e.text.find("CRC") != std::string::npos;
  }));
  EXPECT_TRUE(out.has_event(std::int16_t{motionlcm::event_t::ONLINE})) << "the decoded echo brings the drive online";
  EXPECT_EQ(core->statistics().errors, 1) << "the stray second echo is counted, once";
}

TEST_F(AdamStackTest, CrcErrorsOnEveryAttemptMarkTheDriveOfflineUntilAReplyDecodes) {
  core->execute(command(2, std::int8_t{Command::ENABLE}, {"c"}), now);
  reply(sent.back());  // heard once: online
  ASSERT_EQ(out.terminal(2), 1);
  const auto onlines = [this] {
    return std::count_if(out.events.begin(), out.events.end(),
                         [](const auto& e) { return e.kind == motionlcm::event_t::ONLINE; });
  };
  ASSERT_EQ(onlines(), 1);
  const std::size_t before = sent.size();
  core->execute(command(3, std::int8_t{Command::ENABLE}, {"c"}), now);
  advance(2ms);  // the line's silence before the next request
  for (int attempt = 0; attempt < 2; ++attempt) {
    ASSERT_EQ(sent.size(), before + static_cast<std::size_t>(attempt + 1));
    Bytes corrupted = sent.back();
    corrupted.back() ^= 0x01;
    reply(corrupted);
    advance(2ms);  // silence closes the frame
    advance(2ms);  // then the retry (or the end)
  }
  ASSERT_EQ(out.terminal(3), 1);
  EXPECT_NE(out.of(3).back().reason.find("CRC error"), std::string::npos) << out.of(3).back().reason;
  ASSERT_TRUE(out.has_event(std::int16_t{motionlcm::event_t::OFFLINE})) << "a drive heard only garbled is not online";
  ASSERT_FALSE(out.statuses.empty());
  EXPECT_FALSE(out.statuses.back().second.online);
  // The next reply that decodes brings it back.
  core->execute(command(4, std::int8_t{Command::ENABLE}, {"c"}), now);
  advance(2ms);
  reply(sent.back());
  EXPECT_EQ(out.terminal(4), 1);
  EXPECT_EQ(onlines(), 2);
}

TEST_F(AdamStackTest, ExceptionReplyFailsAtOnceNamingTheException) {
  Command c = command(3, std::int8_t{Command::PARAM_WRITE}, {"c"});
  c.param.space = std::int8_t{motionlcm::param_t::MODBUS_REGISTER};
  c.param.index = 0x009A;
  c.param.width = 1;
  c.param.value = 600;
  core->execute(c, now);
  ASSERT_EQ(sent.size(), 1U);
  EXPECT_EQ(hex(sent[0]), "01 06 00 9A 02 58 A9 7F");  // working speed 600 rpm (§8.44)
  reply({0x01, 0x86, 0x03, 0x02, 0x61});               // exception 06/03 (not in the manual)
  ASSERT_EQ(out.terminal(3), 1);
  const Reply r = out.of(3).back();
  EXPECT_EQ(r.status, kFailed);
  EXPECT_EQ(r.error_code, error_code(ReplyError::kDriveError));
  EXPECT_NE(r.reason.find("exception 3 (illegal data value)"), std::string::npos) << r.reason;
  advance(500ms);
  EXPECT_EQ(sent.size(), 1U) << "a refusal is not retried";
  EXPECT_TRUE(out.has_event(std::int16_t{motionlcm::event_t::ERROR_REPORT}));
}

TEST_F(AdamStackTest, ParamReadDecodesThirtyTwoBitLowWordFirst) {
  Command c = command(4, std::int8_t{Command::PARAM_READ}, {"c"});
  c.param.space = std::int8_t{motionlcm::param_t::MODBUS_REGISTER};
  c.param.index = 0x006E;  // negative software limit, INT32 (§8.45)
  core->execute(c, now);
  ASSERT_EQ(sent.size(), 1U);
  EXPECT_EQ(hex(sent[0]), "01 03 00 6E 00 02 A5 D6");
  reply({0x01, 0x03, 0x04, 0x00, 0x00, 0x80, 0x00, 0x9B, 0xF3});  // the manual's reply
  ASSERT_EQ(out.terminal(4), 1);
  EXPECT_EQ(out.of(4).back().status, kDone);
  EXPECT_EQ(out.of(4).back().param.value, -2147483648LL);
  EXPECT_EQ(out.of(4).back().param.width, 2);
}

TEST_F(AdamStackTest, UnsupportedParameterSpaceAndUnknownAxisFailWithReasons) {
  Command c = command(5, std::int8_t{Command::PARAM_READ}, {"c"});
  c.param.space = std::int8_t{motionlcm::param_t::CANOPEN_OBJECT};
  core->execute(c, now);
  core->execute(command(6, std::int8_t{Command::ENABLE}, {"nope"}), now);
  ASSERT_EQ(out.terminal(5), 1);
  EXPECT_EQ(out.of(5).back().error_code, error_code(ReplyError::kUnsupported));
  ASSERT_EQ(out.terminal(6), 1);
  EXPECT_EQ(out.of(6).back().error_code, error_code(ReplyError::kUnknownAxis));
  EXPECT_TRUE(sent.empty());
}

class TwoDriveTest : public AdamStackTest {
 protected:
  TwoDriveTest() : AdamStackTest({drive("c-drive", "c", 1), drive("d-drive", "d", 2)}) {
    banks[1];
    banks[2];
    core->start(now);
    run_for(50ms);
  }
};

TEST_F(TwoDriveTest, ArmThenFireStartsEveryAxisWithOneBroadcastExecuteTableFrame) {
  ASSERT_TRUE(core->ready());
  core->execute(arm(10, 77, {{"c", 100000}, {"d", -8000}}), now);
  run_for(80ms);  // 12 acknowledged writes, each followed by t3.5 of silence
  ASSERT_EQ(out.of(10).size(), 1U);
  EXPECT_EQ(out.of(10)[0].status, kArmed);
  // Table entry 0 at register 500 (0x01F4) per drive, low word first (§8.54).
  EXPECT_TRUE(was_sent(hex(with_crc({0x01, 0x10, 0x01, 0xF4, 0x00, 0x02, 0x04, 0x86, 0xA0, 0x00, 0x01}))));
  EXPECT_TRUE(was_sent(hex(with_crc({0x02, 0x10, 0x01, 0xF4, 0x00, 0x02, 0x04, 0xE0, 0xC0, 0xFF, 0xFF}))));
  EXPECT_EQ(banks[1].position(), 0) << "nothing moves before the trigger";
  const std::size_t before = sent.size();
  core->fire(77, now);
  ASSERT_GT(sent.size(), before);
  EXPECT_EQ(hex(sent[before]), "00 06 00 DD 00 00 18 21");  // broadcast 0x00DD (§5, §8.54), the one start frame
  ASSERT_EQ(out.of(10).size(), 2U);
  EXPECT_EQ(out.of(10)[1].status, kStarted);
  EXPECT_EQ(out.of(10)[1].start_mechanism, "broadcast");
  EXPECT_EQ(out.of(10)[1].predicted_skew_us, 0.0);
  EXPECT_GT(out.of(10)[1].trigger_utime, 0);
  serve_pending();  // the broadcast is executed by both fake drives, answered by none
  EXPECT_EQ(banks[1].position(), 100000);
  EXPECT_EQ(banks[2].position(), -8000);
  run_for(300ms);
  ASSERT_EQ(out.terminal(10), 1);
  EXPECT_EQ(out.of(10).back().status, kDone);
  core->fire(77, now);  // a second fire of the same trigger does nothing
  run_for(10ms);
  EXPECT_EQ(out.of(10).size(), 3U);
}

TEST_F(TwoDriveTest, AReservedLineSendsTheBroadcastAtOnceWhereAPollRoundWouldHoldIt) {
  ASSERT_TRUE(core->ready());
  core->execute(arm(10, 77, {{"c", 100000}, {"d", -8000}}), now);
  run_for(80ms);
  ASSERT_EQ(out.of(10).size(), 1U);
  ASSERT_EQ(out.of(10)[0].status, kArmed);
  // When a poll round starts: its first read goes out as the round is due (the line is idle by
  // then in the second round after arming), and the next one a poll period (100 ms) later.
  const auto next_round = [&] {
    const std::size_t mark = sent.size();
    for (int i = 0; i < 200; ++i) {
      serve_pending();
      advance(1ms);
      if (sent.size() > mark) return now;
    }
    return TimePoint{};
  };
  ASSERT_NE(next_round(), TimePoint{});
  run_for(20ms);
  const TimePoint round = next_round();
  ASSERT_NE(round, TimePoint{});
  // The start frame is due 1 ms into the next round, when its first read would hold the line.
  const TimePoint start = round + 101ms;
  core->reserve_line(start, now);
  run_for(round + 95ms - now);       // this round ends
  while (now < start) advance(1ms);  // nothing left to answer: time moves in whole steps
  ASSERT_EQ(now, start);
  const std::size_t before = sent.size();
  core->fire(77, now);
  ASSERT_EQ(sent.size(), before + 1) << "the broadcast waited behind a poll";
  EXPECT_EQ(hex(sent[before]), "00 06 00 DD 00 00 18 21");
  // The polls held back go out after it.
  run_for(20ms);
  EXPECT_GT(sent.size(), before + 1);
}

TEST_F(TwoDriveTest, AMoveToZeroRunWholeBetweenTwoSamplesIsNotAPowerUp) {
  // A long line polled slowly: the sample before the start reads 8000 at rest, the next one 0 at
  // rest (the fake drive arrives at once). The counter at 0 is the move's target, not a power-up.
  banks[1].set_position(8000);
  run_for(250ms);
  const auto last_of_c =
      std::find_if(out.statuses.rbegin(), out.statuses.rend(), [](const auto& s) { return s.first == "c"; });
  ASSERT_NE(last_of_c, out.statuses.rend());
  ASSERT_EQ(last_of_c->second.position_counts, 8000);
  core->execute(arm(15, 0, {{"c", 0}}), now);  // trigger 0: start at once
  run_for(400ms);
  ASSERT_EQ(out.terminal(15), 1);
  EXPECT_EQ(out.of(15).back().status, kDone) << out.of(15).back().reason;
  EXPECT_TRUE(out.lost.empty()) << out.lost.front();
  // Once the move ended, a jump to 0 at rest is a power-up again.
  banks[1].set_position(8000);
  run_for(250ms);
  banks[1].set_position(0);
  run_for(250ms);
  ASSERT_EQ(out.lost.size(), 1U);
  EXPECT_NE(out.lost[0].find("powered up, detected by its answers: position counter"), std::string::npos)
      << out.lost[0];
}

TEST_F(TwoDriveTest, MovingBystanderForcesASequentialStart) {
  banks[2].set_moving(true);  // d is jogging: a broadcast table execute could disturb it
  run_for(150ms);
  core->execute(arm(11, 0, {{"c", 4000}}), now);  // trigger 0: start at once
  run_for(300ms);
  const auto replies = out.of(11);
  ASSERT_GE(replies.size(), 3U);
  EXPECT_EQ(replies[0].status, kArmed);
  EXPECT_EQ(replies[1].status, kStarted);
  EXPECT_EQ(replies[1].start_mechanism, "sequential");
  EXPECT_TRUE(was_sent("01 10 00 D0 00 02 04 0F A0 00 00 7D 8F") ||
              was_sent(hex(with_crc({0x01, 0x10, 0x00, 0xD0, 0x00, 0x02, 0x04, 0x0F, 0xA0, 0x00, 0x00}))));
  EXPECT_FALSE(was_sent("00 06 00 DD 00 00 18 21"));
  EXPECT_EQ(out.terminal(11), 1);
  EXPECT_EQ(replies.back().status, kDone);
}

TEST_F(TwoDriveTest, StopFailsTheRunningMoveAndEndsDoneWhenStill) {
  banks[1].completes_moves = false;  // the move runs until stopped
  core->execute(arm(12, 0, {{"c", 50000}}), now);
  run_for(250ms);
  EXPECT_EQ(out.terminal(12), 0);
  core->execute(command(13, std::int8_t{Command::STOP}, {"c"}), now);
  run_for(250ms);
  ASSERT_EQ(out.terminal(12), 1);
  EXPECT_EQ(out.of(12).back().status, kFailed);
  EXPECT_EQ(out.of(12).back().error_code, error_code(ReplyError::kStopped));
  EXPECT_TRUE(was_sent("01 06 00 C8 00 00 08 34"));  // ramped stop (§8.65①)
  ASSERT_EQ(out.terminal(13), 1);
  EXPECT_EQ(out.of(13).back().status, kDone);
}

TEST_F(TwoDriveTest, EstopStopsAtOnceAndReleasesTheMotorLikeEveryFamily) {
  banks[1].completes_moves = false;
  core->execute(arm(16, 0, {{"c", 50000}}), now);
  run_for(250ms);
  core->execute(command(17, std::int8_t{Command::ESTOP}, {"c"}), now);
  run_for(250ms);
  ASSERT_EQ(out.terminal(17), 1);
  EXPECT_EQ(out.of(17).back().status, kDone);
  // Emergency stop (0x00C8 = 0x0100), then release (0x00D4 = 1), §8.67.
  EXPECT_TRUE(was_sent(hex(with_crc({0x01, 0x06, 0x00, 0xC8, 0x01, 0x00}))));
  EXPECT_TRUE(was_sent(hex(with_crc({0x01, 0x06, 0x00, 0xD4, 0x00, 0x01}))));
  const auto last =
      std::find_if(out.statuses.rbegin(), out.statuses.rend(), [](const auto& s) { return s.first == "c"; });
  ASSERT_NE(last, out.statuses.rend());
  EXPECT_FALSE(last->second.enabled);
}

TEST_F(TwoDriveTest, DisarmEndsTheArmedMoveAndIsDone) {
  core->execute(arm(14, 99, {{"c", 1000}, {"d", 2000}}), now);
  run_for(80ms);
  ASSERT_EQ(out.of(14).back().status, kArmed);
  Command disarm = command(15, std::int8_t{Command::DISARM}, {});
  disarm.trigger_id = 99;
  core->execute(disarm, now);
  ASSERT_EQ(out.terminal(14), 1);
  EXPECT_EQ(out.of(14).back().status, kFailed);
  ASSERT_EQ(out.terminal(15), 1);
  EXPECT_EQ(out.of(15).back().status, kDone);
  core->fire(99, now);
  run_for(10ms);
  EXPECT_FALSE(was_sent("00 06 00 DD 00 00 18 21"));
}

TEST_F(TwoDriveTest, AlarmFailsTheMoveOfItsAxis) {
  banks[1].completes_moves = false;
  core->execute(arm(16, 0, {{"c", 50000}}), now);
  run_for(150ms);
  banks[1].regs[0x00A3] = 0x0001;  // over-current (§8.52)
  run_for(250ms);
  ASSERT_EQ(out.terminal(16), 1);
  EXPECT_EQ(out.of(16).back().status, kFailed);
  EXPECT_EQ(out.of(16).back().error_code, error_code(ReplyError::kAxisFaulted));
  EXPECT_NE(out.of(16).back().reason.find("Over-current"), std::string::npos) << out.of(16).back().reason;
  EXPECT_TRUE(out.has_event(std::int16_t{motionlcm::event_t::ALARM}));
}

// The line is half-duplex: after a broadcast start the drives' fresh samples come one by one.
// A drive whose last sample predates the start must not be judged "stopped short" on that old
// sample while the other drives' samples arrive (it used to be counted once per other drive).
class FourDriveTest : public AdamStackTest {
 protected:
  FourDriveTest()
      : AdamStackTest({drive("c1-drive", "c1", 1), drive("c2-drive", "c2", 2), drive("c3-drive", "c3", 3),
                       drive("c4-drive", "c4", 4)}) {
    for (std::uint8_t unit = 1; unit <= 4; ++unit) banks[unit].completes_moves = false;
    core->start(now);
    run_for(80ms);
  }
  // Answers the frames one at a time until the position/status read of `unit` is answered.
  void step_until_position_read_of(std::uint8_t unit) {
    const std::string read = hex(Bytes{unit, 0x03, 0x00, 0x04, 0x00, 0x04}).substr(0, 17);
    for (int step = 0; step < 2000; ++step) {
      if (answered < sent.size()) {
        const Bytes frame = sent[answered++];
        for (auto& [id, bank] : banks) {
          const auto result = adam::serve(frame, adam::SlaveConfig{id, {}, adam::ExceptionMode::kStandard}, bank);
          if (!result.reply.empty()) reply(result.reply);
        }
        if (hex(frame).substr(0, 17) == read) return;
      } else {
        advance(1ms);
      }
    }
    FAIL() << "no position read of unit " << int{unit};
  }
};

TEST_F(FourDriveTest, ADriveIsJudgedOnlyOnItsOwnSamplesTakenAfterTheStart) {
  ASSERT_TRUE(core->ready());
  core->execute(arm(20, 5, {{"c1", 4000}, {"c2", 4000}, {"c3", 4000}, {"c4", 4000}}), now);
  run_for(150ms);
  ASSERT_EQ(out.of(20).size(), 1U);
  ASSERT_EQ(out.of(20)[0].status, kArmed);
  step_until_position_read_of(4);  // c4 sampled idle at 0 just before the start
  core->fire(5, now);
  // c1..c3 are sampled moving before c4 is sampled again: no verdict on c4 meanwhile.
  step_until_position_read_of(3);
  EXPECT_EQ(out.terminal(20), 0) << out.of(20).back().reason;
  // Every drive arrives: the move ends DONE.
  for (std::uint8_t unit = 1; unit <= 4; ++unit) {
    banks[unit].set_moving(false);
    banks[unit].set_position(4000);
  }
  run_for(500ms);
  ASSERT_EQ(out.terminal(20), 1);
  EXPECT_EQ(out.of(20).back().status, kDone) << out.of(20).back().reason;
}

}  // namespace
}  // namespace motion::adam_driver
