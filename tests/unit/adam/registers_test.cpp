// Register map as data: completeness, defaults within range, lookups, spot checks against the
// manual's §7/§8 rows, the drive's 32-bit word order, and the slave access rules.
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <set>
#include <string>

#include "hex.hpp"
#include "motion/adam/commands.hpp"
#include "motion/adam/registers.hpp"

namespace motion::adam {
namespace {

using test::to_hex;

TEST(AdamRegisterMap, EveryDefaultIsWithinItsRangeAndFitsItsWidth) {
  for (const RegisterInfo& r : register_map()) {
    EXPECT_LE(r.min, r.max) << r.name;
    const bool is_signed = r.type == RegType::kI16 || r.type == RegType::kI32;
    const std::int64_t lo = is_signed ? -(std::int64_t{1} << (bit_width(r.type) - 1)) : 0;
    const std::int64_t hi =
        is_signed ? (std::int64_t{1} << (bit_width(r.type) - 1)) - 1 : (std::int64_t{1} << bit_width(r.type)) - 1;
    EXPECT_GE(r.min, lo) << r.name;
    EXPECT_LE(r.max, hi) << r.name;
    if (r.default_value) {
      EXPECT_GE(*r.default_value, r.min) << r.name;
      EXPECT_LE(*r.default_value, r.max) << r.name;
      EXPECT_TRUE(encode_value(r, *r.default_value).ok()) << r.name;
    }
    EXPECT_FALSE(r.meaning.empty()) << r.name;
    EXPECT_EQ(r.meaning.substr(0, 2), "§") << r.name;  // every row cites its manual section
  }
}

TEST(AdamRegisterMap, NamesUniqueAndLookupsRoundTrip) {
  std::set<std::string_view> names;
  for (const RegisterInfo& r : register_map()) {
    EXPECT_TRUE(names.insert(r.name).second) << "duplicate " << r.name;
    EXPECT_EQ(find_register(r.first()), &r) << r.name;
    EXPECT_EQ(find_register(r.name), &r) << r.name;
    EXPECT_EQ(&info(r.reg), &r) << r.name;
    for (std::uint16_t i = 0; i < r.count(); ++i)
      EXPECT_EQ(register_containing(static_cast<std::uint16_t>(r.first() + i)), &r);
  }
  // Manual §7 prints 108 typed rows, but three of them (0x00DE, the OCR-merged 0x00DF "INT32
  // INT32 …" and 0x00E9) stand for only two 32-bit commands, 0x00DE and 0x00E8 (§8.65⑤/⑦;
  // the §7 rows are OCR-merged): 107 entries. Plus 0x0012 (§8.15, missing from §7) = 108.
  EXPECT_EQ(register_map().size(), 108U);
  EXPECT_EQ(find_register("no_such_register"), nullptr);
  EXPECT_EQ(find_register(std::uint16_t{0x0005}), nullptr);  // high word of position: not a start
  EXPECT_EQ(register_containing(0x0005)->reg, Reg::kPosition);
}

TEST(AdamRegisterMap, UndocumentedHolesHaveNoEntry) {
  // The addresses neither the §7 table nor §8 documents.
  const std::pair<std::uint16_t, std::uint16_t> holes[] = {
      {0x0014, 0x0014}, {0x0018, 0x0018}, {0x0023, 0x0023}, {0x0028, 0x0028}, {0x002A, 0x002B}, {0x0034, 0x0043},
      {0x0049, 0x0065}, {0x0067, 0x006A}, {0x006D, 0x006D}, {0x0072, 0x0095}, {0x00B9, 0x00B9}, {0x00BC, 0x00BD},
      {0x00D5, 0x00D5}, {0x00DA, 0x00DA}, {0x00E0, 0x00E7}, {0x00EA, 0x012B},
  };
  std::size_t hole_count = 0;
  for (const auto& [first, last] : holes) {
    for (std::uint32_t a = first; a <= last; ++a, ++hole_count)
      EXPECT_EQ(register_containing(static_cast<std::uint16_t>(a)), nullptr) << std::hex << a;
  }
  // Everything from 0x0000 to 0x00E9 is either a hole or covered by exactly one entry.
  std::size_t covered = 0;
  for (const RegisterInfo& r : register_map()) covered += r.count();
  EXPECT_EQ(covered + hole_count, 0x012CU);
}

struct Spot {
  std::uint16_t address;
  std::string_view name;
  RegType type;
  Access access;
  std::optional<std::int64_t> default_value;
  std::int64_t min, max;
};

TEST(AdamRegisterMap, SpotChecksAgainstTheManual) {
  const Spot spots[] = {
      {0x0004, "position", RegType::kI32, Access::kReadOnly, std::nullopt, INT32_MIN, INT32_MAX},
      {0x0006, "status", RegType::kU32, Access::kReadOnly, std::nullopt, 0, 0x1FFFFF},
      {0x0008, "serial_timeout", RegType::kU16, Access::kReadWrite, 0, 0, 65535},
      {0x0009, "baud_rate", RegType::kU16, Access::kReadWrite, 12, 1, 15},
      {0x000A, "smoothing", RegType::kU16, Access::kReadWrite, 250, 1, 2500},
      {0x000C, "static_error_alarm", RegType::kU16, Access::kReadWrite, 100, 0, 65535},
      {0x0011, "position_deviation", RegType::kI16, Access::kReadOnly, std::nullopt, -32768, 32767},
      {0x0019, "speed_rpm", RegType::kI16, Access::kReadOnly, std::nullopt, -32768, 32767},
      {0x0024, "subdivision", RegType::kU32, Access::kReadWrite, 4000, 200, 1000000},
      {0x006E, "negative_limit", RegType::kI32, Access::kReadWrite, INT32_MIN, INT32_MIN, INT32_MAX},
      {0x0070, "positive_limit", RegType::kI32, Access::kReadWrite, INT32_MAX, INT32_MIN, INT32_MAX},
      {0x0096, "start_speed", RegType::kU16, Access::kReadWrite, 50, 0, 300},
      {0x0097, "stop_speed", RegType::kU16, Access::kReadWrite, 50, 0, 1000},
      {0x0098, "acceleration_time", RegType::kU16, Access::kReadWrite, 120, 0, 65535},
      {0x009A, "working_speed", RegType::kU16, Access::kReadWrite, 300, 0, 1000},
      {0x009F, "working_mode", RegType::kU16, Access::kReadWrite, 3, 1, 3},
      {0x00A5, "alarm_output", RegType::kU16, Access::kReadWrite, 257, 0, 65535},
      {0x00A6, "running_output", RegType::kU16, Access::kReadWrite, 514, 0, 65535},
      {0x00BE, "rotor_offset", RegType::kI16, Access::kReadWrite, 0, -80, 80},
      {0x00C0, "speed_loop_p", RegType::kU16, Access::kReadWrite, 3200, 0, 65535},
      {0x00C1, "speed_loop_i", RegType::kU16, Access::kReadWrite, 25, 0, 65535},
      {0x00C2, "reminder_x17", RegType::kI32, Access::kReadWrite, 1073741823, INT32_MIN, INT32_MAX},
      {0x00C8, "velocity_command", RegType::kU16, Access::kWriteOnly, std::nullopt, 0, 257},
      {0x00CC, "timed_run", RegType::kI32, Access::kWriteOnly, std::nullopt, INT32_MIN, INT32_MAX},
      {0x00D0, "absolute_move", RegType::kI32, Access::kWriteOnly, std::nullopt, INT32_MIN, INT32_MAX},
      {0x00D2, "preset_position", RegType::kI32, Access::kReadWrite, 0, INT32_MIN, INT32_MAX},
      {0x00D4, "enable_command", RegType::kU16, Access::kWriteOnly, std::nullopt, 0, 256},
      {0x00D6, "speed_centi_rpm", RegType::kI32, Access::kReadOnly, 0, INT32_MIN, INT32_MAX},
      {0x00D8, "target_speed", RegType::kI32, Access::kReadWrite, 30000, -999999, 999999},
      {0x00DD, "table_execute", RegType::kU16, Access::kWriteOnly, std::nullopt, 0, 65535},
      {0x00DE, "relative_move_preempt", RegType::kI32, Access::kWriteOnly, std::nullopt, INT32_MIN, INT32_MAX},
      {0x00E8, "absolute_move_preempt", RegType::kI32, Access::kWriteOnly, std::nullopt, INT32_MIN, INT32_MAX},
  };
  for (const Spot& s : spots) {
    const RegisterInfo* r = find_register(s.address);
    ASSERT_NE(r, nullptr) << s.name;
    EXPECT_EQ(r->name, s.name);
    EXPECT_EQ(r->type, s.type) << s.name;
    EXPECT_EQ(r->access, s.access) << s.name;
    EXPECT_EQ(r->default_value, s.default_value) << s.name;
    EXPECT_EQ(r->min, s.min) << s.name;
    EXPECT_EQ(r->max, s.max) << s.name;
  }
}

// ---- Word order ----------------------------------------------------------------------------------

TEST(AdamWordOrder, LowWordAtLowerAddress) {
  EXPECT_EQ(encode32(std::uint32_t{0xAABBCCDD}), (std::array<std::uint16_t, 2>{0xCCDD, 0xAABB}));
  EXPECT_EQ(decode32(0xCCDD, 0xAABB), 0xAABBCCDDU);
  // On the wire (FC 0x10 data): CC DD AA BB — NOT libmodbus's AA BB CC DD.
  const auto frame = rtu::encode_request(write32(1, Reg::kSubdivision, std::uint32_t{0xAABBCCDD}));
  ASSERT_TRUE(frame.ok());
  EXPECT_EQ(to_hex(frame.value()).substr(0, 32), "01 10 00 24 00 02 04 CC DD AA BB");
}

TEST(AdamWordOrder, RoundTrips) {
  const std::int32_t signed_values[] = {0,     1,     -1,     4000,      -10000,    100000,     -100000,
                                        65535, 65536, -65536, INT32_MIN, INT32_MAX, 0x150000C8, -6400};
  for (const std::int32_t v : signed_values) {
    const auto w = encode32(v);
    EXPECT_EQ(decode32_signed(w[0], w[1]), v) << v;
    EXPECT_EQ(decode32(w[0], w[1]), static_cast<std::uint32_t>(v)) << v;
  }
  // The manual's examples (§8.29, §8.45, §8.46).
  EXPECT_EQ(decode32(0x0FA0, 0x0000), 4000U);
  EXPECT_EQ(decode32_signed(0x0000, 0x8000), INT32_MIN);
  EXPECT_EQ(decode32_signed(0xFFFF, 0x7FFF), INT32_MAX);
  EXPECT_EQ(decode32_signed(0xD8F0, 0xFFFF), -10000);
  for (std::uint32_t v = 1; v != 0; v <<= 1) {
    const auto w = encode32(v);
    EXPECT_EQ(decode32(w[0], w[1]), v);
  }
}

TEST(AdamWordOrder, EntryValuesEncodeAndDecodeByType) {
  const auto target = encode_value(info(Reg::kTargetSpeed), -30000);
  ASSERT_TRUE(target.ok());
  EXPECT_EQ(target.value(), (std::array<std::uint16_t, 2>{0x8AD0, 0xFFFF}));
  EXPECT_EQ(decode_value(info(Reg::kTargetSpeed), target.value()), -30000);
  EXPECT_EQ(decode_value(info(Reg::kRotorOffset), std::array<std::uint16_t, 1>{0xFFFB}), -5);
  EXPECT_EQ(decode_value(info(Reg::kSubdivision), std::array<std::uint16_t, 2>{0x2710, 0}), 10000);
  EXPECT_EQ(encode_value(info(Reg::kTargetSpeed), 1000000).error(), AdamErrc::kValueOutOfRange);
  EXPECT_EQ(encode_value(info(Reg::kRotorOffset), 81).error(), AdamErrc::kValueOutOfRange);
  EXPECT_EQ(encode_value(info(Reg::kSubdivision), 199).error(), AdamErrc::kValueOutOfRange);
}

// ---- Access rules (simulated slave) --------------------------------------------------------------

TEST(AdamAccessRules, ReadsAndWritesAgainstTheMap) {
  using E = rtu::ExceptionCode;
  struct Case {
    const char* what;
    rtu::RequestPdu pdu;
    std::optional<E> expected;
    AccessRules rules;
  };
  AccessRules holes_as_zero;
  holes_as_zero.holes_read_as_zero = true;
  AccessRules partial_ok;
  partial_ok.allow_partial_32bit_write = true;
  AccessRules no_ranges;
  no_ranges.check_value_ranges = false;
  const Case cases[] = {
      {"read position+status", rtu::ReadRegisters{0x0004, 4}, std::nullopt, {}},
      {"read high word alone", rtu::ReadRegisters{0x0005, 1}, std::nullopt, {}},
      {"read hole 0x0014", rtu::ReadRegisters{0x0014, 1}, E::kIllegalDataAddress, {}},
      {"read across hole", rtu::ReadRegisters{0x0012, 3}, E::kIllegalDataAddress, {}},
      {"read hole as zero", rtu::ReadRegisters{0x0012, 3}, std::nullopt, holes_as_zero},
      {"read WO command", rtu::ReadRegisters{0x00C8, 1}, std::nullopt, {}},
      {"read programming area", rtu::ReadRegisters{500, 48}, std::nullopt, {}},
      {"write RO position", rtu::WriteRegisters{0x0004, {0, 0}}, E::kIllegalDataAddress, {}},
      {"write RO alarm", rtu::WriteRegister{0x00A3, 0}, E::kIllegalDataAddress, {}},
      {"write hole", rtu::WriteRegister{0x0014, 0}, E::kIllegalDataAddress, {}},
      {"fc06 to half of 32-bit", rtu::WriteRegister{0x00D0, 5}, E::kIllegalDataAddress, {}},
      {"fc10 to high half", rtu::WriteRegisters{0x00D1, {0, 1}}, E::kIllegalDataAddress, {}},
      {"fc06 to half allowed", rtu::WriteRegister{0x00D0, 5}, std::nullopt, partial_ok},
      {"baud code 16", rtu::WriteRegister{0x0009, 16}, E::kIllegalDataValue, {}},
      {"baud code 0", rtu::WriteRegister{0x0009, 0}, E::kIllegalDataValue, {}},
      {"baud 16 unchecked", rtu::WriteRegister{0x0009, 16}, std::nullopt, no_ranges},
      {"working speed 1001", rtu::WriteRegister{0x009A, 1001}, E::kIllegalDataValue, {}},
      {"rotor offset -81", rtu::WriteRegister{0x00BE, encode16(-81)}, E::kIllegalDataValue, {}},
      {"rotor offset -80", rtu::WriteRegister{0x00BE, encode16(-80)}, std::nullopt, {}},
      {"subdivision 199", rtu::WriteRegisters{0x0024, {199, 0}}, E::kIllegalDataValue, {}},
      {"target speed 1000000", rtu::WriteRegisters{0x00D8, {0x4240, 0x000F}}, E::kIllegalDataValue, {}},
      {"target speed -999999", rtu::WriteRegisters{0x00D8, {0xBDC1, 0xFFF0}}, std::nullopt, {}},
      {"profile block", rtu::WriteRegisters{0x0096, {0, 0, 200, 200, 600}}, std::nullopt, {}},
      {"95 registers", rtu::WriteRegisters{500, std::vector<std::uint16_t>(95, 0)}, std::nullopt, {}},
      {"96 registers (> 200 bytes)",
       rtu::WriteRegisters{500, std::vector<std::uint16_t>(96, 0)},
       E::kIllegalDataValue,
       {}},
      {"value error in a block", rtu::WriteRegisters{0x0008, {0, 99, 250}}, E::kIllegalDataValue, {}},
      {"address error beats value error",
       rtu::WriteRegisters{0x0009, {99, 250, 200, 100, 100, 0, 1000, 20, 0}},
       E::kIllegalDataAddress,
       {}},
  };
  for (const auto& c : cases) EXPECT_EQ(check_request(c.pdu, c.rules), c.expected) << c.what;
}

TEST(AdamAccessRules, RepliesExpected) {
  EXPECT_TRUE(expects_reply(command(1, EnableCommand::kEnable)));
  EXPECT_FALSE(expects_reply(command(1, EnableCommand::kRestart)));
  EXPECT_FALSE(expects_reply(command(0, EnableCommand::kEnable)));
  EXPECT_FALSE(expects_reply(move(0, MoveCommand::kAbsolutePreempting, 5)));
  EXPECT_TRUE(expects_reply(read(64, Reg::kStatus)));
}

}  // namespace
}  // namespace motion::adam
