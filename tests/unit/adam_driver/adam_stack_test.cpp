// AdamStack (the ADAM Modbus RTU master, passive): every frame it sends is checked byte for byte,
// replies are scripted bytes or come from motion::adam::serve() over a fake register bank, and
// time only moves when the test says so (adam_stack_fixture.hpp).
#include "adam_stack_fixture.hpp"

namespace motion::adam_driver::test {
namespace {

TEST_F(AdamStackTest, StartUpReadsPowerOnStateAndSubdivisionThenPollsPositionStatusAndAlarm) {
  banks[1];
  core->start(now);
  run_for(20ms);
  ASSERT_GE(sent.size(), 5U);
  EXPECT_EQ(hex(sent[0]), "01 03 00 12 00 01 24 0F");                            // 0x0012 (§8.15)
  EXPECT_EQ(hex(sent[1]), "01 03 00 24 00 02 84 00");                            // 0x0024 subdivision (§8.29)
  EXPECT_EQ(hex(sent[2]), hex(with_crc({0x01, 0x03, 0x00, 0xC6, 0x00, 0x02})));  // X19, the power-on marker
  EXPECT_EQ(hex(sent[3]), "01 03 00 04 00 04 05 C8");                            // position + status (§8.3, §8.4)
  EXPECT_EQ(hex(sent[4]), hex(with_crc({0x01, 0x03, 0x00, 0xA2, 0x00, 0x02})));  // outputs + alarm
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

}  // namespace
}  // namespace motion::adam_driver::test
