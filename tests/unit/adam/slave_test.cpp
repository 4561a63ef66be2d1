// Slave-side serving: replies, exceptions, broadcast and restart silence, addressing, silent mode.
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "hex.hpp"
#include "motion/adam/commands.hpp"
#include "motion/adam/slave.hpp"

namespace motion::adam {
namespace {

using test::hex;
using test::to_hex;

// A plain register image with a log of writes.
class FakeBank final : public RegisterBank {
 public:
  FakeBank() : words_(0x10000, 0) {}
  std::optional<rtu::ExceptionCode> read(std::uint16_t start, std::span<std::uint16_t> out) override {
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = words_[start + i];
    return std::nullopt;
  }
  std::optional<rtu::ExceptionCode> write(std::uint16_t start, std::span<const std::uint16_t> values) override {
    if (busy) return rtu::ExceptionCode::kServerDeviceBusy;
    for (std::size_t i = 0; i < values.size(); ++i) words_[start + i] = values[i];
    ++writes;
    return std::nullopt;
  }
  std::uint16_t& at(std::uint16_t address) { return words_[address]; }
  int writes = 0;
  bool busy = false;

 private:
  std::vector<std::uint16_t> words_;
};

std::vector<std::uint8_t> frame_of(const rtu::Request& r) { return rtu::encode_request(r).value(); }

TEST(AdamSlave, ReadsAndWritesReplyWithExactFrames) {
  FakeBank bank;
  bank.at(0x0004) = 0x86A0;
  bank.at(0x0005) = 0x0001;
  const SlaveConfig config;
  struct Case {
    const char* what;
    const char* request;
    const char* reply;
  };
  const Case cases[] = {
      {"read position", "01 03 00 04 00 02 85 CA", "01 03 04 86 A0 00 01 12 99"},
      {"working speed 600", "01 06 00 9A 02 58 A9 7F", "01 06 00 9A 02 58 A9 7F"},
      {"absolute move", "01 10 00 D0 00 02 04 86 A0 00 01 16 59", "01 10 00 D0 00 02 40 31"},
      {"manual table bulk load ack", "01 10 01 F4 00 02 04 63 BF 00 00 DF 28", "01 10 01 F4 00 02 01 C6"},
  };
  for (const auto& c : cases) {
    const ServeResult r = serve(hex(c.request), config, bank);
    EXPECT_EQ(r.outcome, ServeOutcome::kReplied) << c.what;
    EXPECT_EQ(to_hex(r.reply), c.reply) << c.what;
    ASSERT_TRUE(r.request.has_value()) << c.what;
  }
  EXPECT_EQ(bank.at(0x009A), 600);
  EXPECT_EQ(decode32_signed(bank.at(0x00D0), bank.at(0x00D1)), 100000);
}

TEST(AdamSlave, ExceptionsForIllegalFunctionAddressAndValue) {
  FakeBank bank;
  const SlaveConfig config;
  struct Case {
    const char* what;
    std::vector<std::uint8_t> request;
    const char* reply;
  };
  const auto fc01 = [] {
    auto f = hex("01 01 00 00 00 08");
    rtu::append_crc(f);
    return f;
  }();
  const Case cases[] = {
      {"illegal function (FC 01)", fc01, "01 81 01 81 90"},
      {"read hole 0x0014", frame_of({1, rtu::ReadRegisters{0x0014, 1}}), "01 83 02 C0 F1"},
      {"write read-only alarm", frame_of(write16(1, Reg::kAlarm, 0)), "01 86 02 C3 A1"},
      {"baud code 99", frame_of(write16(1, Reg::kBaudRate, 99)), "01 86 03 02 61"},
      {"fc10 to read-only position", frame_of(write32(1, Reg::kPosition, 5)), "01 90 02 CD C1"},
  };
  for (const auto& c : cases) {
    const ServeResult r = serve(c.request, config, bank);
    EXPECT_EQ(r.outcome, ServeOutcome::kException) << c.what;
    EXPECT_EQ(to_hex(r.reply), c.reply) << c.what;
  }
  EXPECT_EQ(bank.writes, 0);  // refused requests never reach the bank
}

TEST(AdamSlave, BankErrorsBecomeExceptions) {
  FakeBank bank;
  bank.busy = true;
  const ServeResult r = serve(frame_of(command(1, VelocityCommand::kRunForward)), {}, bank);
  EXPECT_EQ(r.outcome, ServeOutcome::kException);
  EXPECT_EQ(r.exception, rtu::ExceptionCode::kServerDeviceBusy);
  EXPECT_EQ(to_hex(r.reply), to_hex(rtu::encode_exception(1, 0x06, rtu::ExceptionCode::kServerDeviceBusy)));
}

TEST(AdamSlave, BroadcastsAndRestartAreExecutedWithoutReply) {
  FakeBank bank;
  const SlaveConfig config;
  const char* silent[] = {
      "00 06 00 C8 00 01 C8 25",                 // broadcast run forward
      "00 10 00 E8 00 02 04 79 60 FF FE 21 8F",  // broadcast pre-empting absolute move
      "00 06 00 DD 00 00 18 21",                 // broadcast execute table
      "01 06 00 D4 01 00 C8 62",                 // restart, addressed (§8.67)
  };
  for (const char* frame : silent) {
    const ServeResult r = serve(hex(frame), config, bank);
    EXPECT_EQ(r.outcome, ServeOutcome::kExecutedSilently) << frame;
    EXPECT_TRUE(r.reply.empty()) << frame;
  }
  EXPECT_EQ(bank.writes, 4);
  EXPECT_EQ(bank.at(0x00C8), 1);
  // A refused broadcast is not answered either.
  const ServeResult refused = serve(frame_of(write16(0, Reg::kBaudRate, 99)), config, bank);
  EXPECT_EQ(refused.outcome, ServeOutcome::kRejectedSilently);
  EXPECT_TRUE(refused.reply.empty());
  // A broadcast read is discarded.
  auto read_all = hex("00 03 00 04 00 02");
  rtu::append_crc(read_all);
  EXPECT_EQ(serve(read_all, config, bank).frame_error, rtu::FrameErrc::kBroadcastRead);
}

TEST(AdamSlave, OtherUnitsBadFramesAndSilentMode) {
  FakeBank bank;
  SlaveConfig config;
  config.unit = 2;
  EXPECT_EQ(serve(hex("01 03 00 04 00 02 85 CA"), config, bank).outcome, ServeOutcome::kNotAddressed);
  EXPECT_EQ(serve(hex("02 03 00 04 00 02 85 F9"), config, bank).outcome, ServeOutcome::kReplied);
  const ServeResult bad = serve(hex("02 03 00 04 00 02 85 FA"), config, bank);
  EXPECT_EQ(bad.outcome, ServeOutcome::kDiscarded);
  EXPECT_EQ(bad.frame_error, rtu::FrameErrc::kBadCrc);
  EXPECT_TRUE(bad.reply.empty());

  config.exceptions = ExceptionMode::kSilent;
  const ServeResult quiet = serve(frame_of({2, rtu::ReadRegisters{0x0014, 1}}), config, bank);
  EXPECT_EQ(quiet.outcome, ServeOutcome::kException);
  EXPECT_EQ(quiet.exception, rtu::ExceptionCode::kIllegalDataAddress);
  EXPECT_TRUE(quiet.reply.empty());
}

TEST(AdamSlave, PartialWritesOfThirtyTwoBitRegistersFollowThePolicy) {
  FakeBank bank;
  SlaveConfig config;
  const auto half = frame_of(write16(1, Reg::kAbsoluteMove, 5));
  EXPECT_EQ(serve(half, config, bank).exception, rtu::ExceptionCode::kIllegalDataAddress);
  config.rules.allow_partial_32bit_write = true;
  EXPECT_EQ(serve(half, config, bank).outcome, ServeOutcome::kReplied);
}

}  // namespace
}  // namespace motion::adam
