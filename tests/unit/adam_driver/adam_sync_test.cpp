// AdamStack with two and four drives on the line (adam_stack_fixture.hpp): synchronized starts
// by one broadcast frame, bystanders, stops, e-stops, alarms, and samples judged per drive.
#include "adam_stack_fixture.hpp"
#include "motion/adam/table.hpp"

namespace motion::adam_driver::test {
namespace {

class TwoDriveTest : public AdamStackTest {
 protected:
  // `egress`: the line's egress latency (bus key egress_latency_us).
  explicit TwoDriveTest(Duration egress = {})
      : AdamStackTest({drive("c-drive", "c", 1), drive("d-drive", "d", 2)}, egress) {
    banks[1];
    banks[2];
    core->start(now);
    run_for(50ms);
  }
  // Command 10 arms c and d for trigger 77 (their table entries written and acknowledged).
  void arm_both(std::int64_t c, std::int64_t d) {
    ASSERT_TRUE(core->ready());
    core->execute(arm(10, 77, {{"c", c}, {"d", d}}), now);
    run_for(80ms);  // 12 acknowledged writes, each followed by t3.5 of silence
    ASSERT_EQ(out.of(10).size(), 1U);
    ASSERT_EQ(out.of(10)[0].status, kArmed);
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
  // The drives act at the end of the 8-byte frame, 8 x 10 bits at 115200 baud after its write.
  const auto us = [](TimePoint t) {
    return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
  };
  EXPECT_EQ(out.of(10)[1].trigger_utime, us(now) + 694);
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

// A line whose adapter takes 400 us from the write to the first character on the wire (bus key
// egress_latency_us): the drives act, and the start is dated, that much later than without it.
class LatentLineTest : public TwoDriveTest {
 protected:
  LatentLineTest() : TwoDriveTest(400us) {}
};

TEST_F(LatentLineTest, TheStartIsDatedAfterTheEgressLatencyAndItsWireTime) {
  ASSERT_NO_FATAL_FAILURE(arm_both(1000, -800));
  const std::size_t before = sent.size();
  core->fire(77, now);
  ASSERT_EQ(sent.size(), before + 1);
  ASSERT_EQ(out.of(10).size(), 2U);
  const auto written = std::chrono::duration_cast<std::chrono::microseconds>(now.time_since_epoch()).count();
  EXPECT_EQ(out.of(10)[1].trigger_utime, written + 400 + 694);
}

TEST_F(TwoDriveTest, AReservedLineSendsTheBroadcastAtOnceWhereAPollRoundWouldHoldIt) {
  ASSERT_NO_FATAL_FAILURE(arm_both(100000, -8000));
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

// What holds the line when a start comes is said (the gateway logs it): the poll read awaiting
// its reply, the drive it addresses, and how long ago its request ended; then the silence the
// line keeps after the reply (t3.5); nothing once the round is over.
TEST_F(TwoDriveTest, TheExchangeUnderWayIsNamedWithItsAge) {
  ASSERT_NO_FATAL_FAILURE(arm_both(100000, -8000));
  run_for(20ms);
  ASSERT_EQ(core->exchange_under_way(now), "");
  const std::size_t mark = sent.size();
  for (int i = 0; i < 200 && sent.size() == mark; ++i) advance(1ms);
  ASSERT_GT(sent.size(), mark) << "no poll went out";
  const std::string busy = core->exchange_under_way(now + 5ms);
  EXPECT_NE(busy.find("(slave "), std::string::npos) << busy;
  EXPECT_NE(busy.find("reading register"), std::string::npos) << busy;
  EXPECT_NE(busy.find("its request ended"), std::string::npos) << busy;
  serve_pending();
  const std::string silence = core->exchange_under_way(now);
  EXPECT_NE(silence.find("the silent interval after the last frame"), std::string::npos) << silence;
  run_for(60ms);  // the poll round over
  EXPECT_EQ(core->exchange_under_way(now), "") << "answered, the line is free";
}

// The line's start wait (LINE_TIMING) is its longest poll read as a reservation counts it: the
// request (8 bytes), the drive's assumed reply latency (1 ms), the position-and-status reply (4
// registers: 13 bytes), and t3.5 after each frame, 1.75 ms above 19200 baud (Modbus over serial
// line §2.5.1.1); 10 bits per character at 115200 baud, 8N1.
TEST_F(TwoDriveTest, TheStartWaitIsTheLongestPollReadOfTheLine) {
  const double expected_us = (8 + 13) * 10 * 1e6 / 115200 + 1000 + 2 * 1750;
  const double wait_us = std::chrono::duration<double, std::micro>(core->start_wait()).count();
  EXPECT_NEAR(wait_us, expected_us, 0.5);
}

// A start reserved the start wait before its broadcast finds the line free wherever a poll read
// was when the reservation came: as the read was written, during the drive's answer, in the
// silence after it. Each reply comes whole, at the baud rate, the assumed 1 ms after its request
// crossed the line. Reserved as it goes out, the broadcast is left behind the read.
TEST_F(TwoDriveTest, AStartReservedItsStartWaitAheadFindsThePollReadDone) {
  ASSERT_NO_FATAL_FAILURE(arm_both(100000, -8000));
  const Duration character = std::chrono::nanoseconds(1'000'000'000LL * 10 / 115200);
  const Duration wait = core->start_wait();
  // Time runs in steps of at most 50 us, every frame answered at its wire time.
  std::vector<TimePoint> written;  // when each frame of `sent` was written
  const auto note_writes = [&] {
    while (written.size() < sent.size()) written.push_back(now);
  };
  std::multimap<TimePoint, Bytes> due;  // replies, at the end of their frames
  const auto answer = [&] {
    for (; answered < sent.size(); ++answered) {
      const Bytes frame = sent[answered];
      for (auto& [unit, bank] : banks) {
        const auto result = adam::serve(frame, adam::SlaveConfig{unit, {}, adam::ExceptionMode::kStandard}, bank);
        if (result.reply.empty()) continue;
        const auto bytes = static_cast<std::int64_t>(frame.size() + result.reply.size());
        due.emplace(written[answered] + character * bytes + 1ms, result.reply);
      }
    }
  };
  const auto step_to = [&](TimePoint until) {
    while (now < until) {
      const TimePoint next = std::min({now + 50us, until, due.empty() ? until : due.begin()->first});
      now = next;
      while (!due.empty() && due.begin()->first <= now) {
        core->on_bytes(due.begin()->second, now);
        due.erase(due.begin());
      }
      core->process(now);
      note_writes();
      answer();
    }
  };
  note_writes();
  answer();
  int checked = 0;
  int late_unreserved = 0;
  for (const Duration phase : {0us, 300us, 700us, 1200us, 1700us, 2300us, 2900us, 3500us, 4200us}) {
    for (const bool reserved : {true, false}) {
      // The next poll read to be written, then `phase` into its exchange.
      const std::size_t mark = sent.size();
      for (int i = 0; i < 200000 && sent.size() == mark; ++i) step_to(now + 50us);
      ASSERT_GT(sent.size(), mark) << "no poll read";
      ASSERT_EQ(sent[mark][1], 0x03) << "a poll read (function 3)";
      step_to(now + phase);
      const TimePoint at = now + (reserved ? wait : Duration{});
      if (reserved) core->reserve_line(at, now);
      step_to(at);
      const std::size_t before = sent.size();
      core->fire(77, now);
      const bool on_time = sent.size() == before + 1 && hex(sent[before]) == "00 06 00 DD 00 00 18 21";
      if (reserved) {
        EXPECT_TRUE(on_time) << "reserved " << phase.count() / 1000 << " us into a poll read";
        ++checked;
      } else {
        late_unreserved += on_time ? 0 : 1;
      }
      step_to(now + 400ms);  // the move (started on time or late) runs to its end
      // Arm again for the next start.
      const std::int64_t id = 10 + 2 * checked + (reserved ? 0 : 1);
      core->execute(arm(id, 77, {{"c", id * 10}, {"d", -id * 10}}), now);
      step_to(now + 150ms);
      ASSERT_FALSE(out.of(id).empty());
      ASSERT_EQ(out.of(id).back().status, kArmed);
    }
  }
  EXPECT_EQ(checked, 9);
  EXPECT_GT(late_unreserved, 0) << "an unreserved start never met a poll read: the test would not see a short wait";
}

// A drive of the line that does not answer (unit 2: no fake drive) is not polled while a move of
// the line awaits its trigger: a read to it holds the line until its timeout, far beyond the
// start wait the line announces. After the start it is polled again (one try per tenth round).
class SilentDriveTest : public AdamStackTest {
 protected:
  SilentDriveTest() : AdamStackTest({drive("c-drive", "c", 1), drive("d-drive", "d", 2)}) {
    banks[1];
    core->start(now);
    run_for(3s);  // d's reads time out: offline
  }
  [[nodiscard]] std::size_t frames_to_d(std::size_t from) const {
    return static_cast<std::size_t>(std::count_if(sent.begin() + static_cast<std::ptrdiff_t>(from), sent.end(),
                                                  [](const Bytes& b) { return !b.empty() && b[0] == 2; }));
  }
};

TEST_F(SilentDriveTest, ASilentDriveIsNotPolledWhileAMoveAwaitsItsTrigger) {
  const std::size_t before_arm = sent.size();
  run_for(3s);
  ASSERT_GT(frames_to_d(before_arm), 0U) << "an offline drive is tried now and then";
  core->execute(arm(10, 77, {{"c", 1000}}), now);
  run_for(1s);
  ASSERT_FALSE(out.of(10).empty());
  ASSERT_EQ(out.of(10).back().status, kArmed) << out.of(10).back().reason;
  const std::size_t armed_at = sent.size();
  run_for(3s);
  EXPECT_EQ(frames_to_d(armed_at), 0U) << "d was polled while the move awaited its trigger";
  core->fire(77, now);
  const std::size_t fired_at = sent.size();
  run_for(3s);
  EXPECT_GT(frames_to_d(fired_at), 0U) << "d is tried again after the start";
}

// The line's start wait bounds every exchange the gateway begins while a move of the line awaits
// its trigger, not only its polls: a second move armed meanwhile (d, for another trigger) loads its
// table entry, but its Save, a 0.1 s flash erase (§8.69), waits for the first move's start. The
// other drive's polls go on; after the start the Save goes out and the second move is ARMED.
TEST_F(TwoDriveTest, NoExchangeLongerThanTheStartWaitBeginsWhileAMoveAwaitsItsTrigger) {
  ASSERT_TRUE(core->ready());
  core->execute(arm(10, 77, {{"c", 1000}}), now);
  run_for(400ms);  // with d's neutral table entry and its Save
  ASSERT_FALSE(out.of(10).empty());
  ASSERT_EQ(out.of(10).back().status, kArmed) << out.of(10).back().reason;
  const std::size_t armed_at = sent.size();
  core->execute(arm(11, 78, {{"d", -500}}), now);
  run_for(1s);
  const auto is_save_to = [](const Bytes& b, std::uint8_t unit) {
    return hex(b) == hex(with_crc({unit, 0x06, 0x00, 0xDC, 0x00, 0x01}));  // 0x00DC = 1 (§8.69)
  };
  const Duration wait = core->start_wait();
  std::size_t to_c = 0;
  std::size_t to_d = 0;
  for (std::size_t i = armed_at; i < sent.size(); ++i) {
    EXPECT_FALSE(is_save_to(sent[i], 2)) << "d's Save went out while c's move awaited its trigger";
    const auto parsed = adam::rtu::decode_request(sent[i]);
    ASSERT_TRUE(std::holds_alternative<adam::rtu::Request>(parsed)) << hex(sent[i]);
    EXPECT_LE(adam::transaction_time({}, std::get<adam::rtu::Request>(parsed)), wait) << hex(sent[i]);
    to_c += sent[i][0] == 1 ? 1U : 0U;
    to_d += sent[i][0] == 2 ? 1U : 0U;
  }
  EXPECT_GT(to_c, 5U) << "c is polled meanwhile";
  EXPECT_GT(to_d, 0U) << "d's table entry is loaded meanwhile";
  EXPECT_TRUE(out.of(11).empty()) << "the second move reported before its Save";
  const std::size_t fired_at = sent.size();
  core->fire(77, now);
  run_for(500ms);
  EXPECT_TRUE(std::any_of(sent.begin() + static_cast<std::ptrdiff_t>(fired_at), sent.end(), [&](const Bytes& b) {
    return is_save_to(b, 2);
  })) << "d's Save goes out after the start";
  ASSERT_FALSE(out.of(11).empty());
  EXPECT_EQ(out.of(11).back().status, kArmed) << out.of(11).back().reason;
  ASSERT_EQ(out.terminal(10), 1);
  EXPECT_EQ(out.of(10).back().status, kDone) << out.of(10).back().reason;
  EXPECT_EQ(banks[1].position(), 1000);
  EXPECT_EQ(banks[2].position(), 0) << "d waits for its own trigger";
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
}  // namespace motion::adam_driver::test
