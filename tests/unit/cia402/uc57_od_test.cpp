// UC57 object dictionary: contents against the manual's tables (§5, §5.1, §5.2), lookups, access
// and range checks (derived abort vectors D-20..D-25, CiA 301 §7.2.4.3.17), the manual's SDO
// frames, and the value codec.
#include <gtest/gtest.h>
#include <initializer_list>

#include <algorithm>
#include <array>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "motion/cia402/uc57_od.hpp"

namespace motion::cia402::uc57 {
namespace {

const OdEntry& at(std::uint16_t index, std::uint8_t subindex) {
  const OdEntry* entry = find_entry(index, subindex);
  EXPECT_NE(entry, nullptr) << std::hex << index << ":" << int{subindex};
  static const OdEntry kMissing{};
  return entry != nullptr ? *entry : kMissing;
}

std::vector<std::uint8_t> le(std::uint32_t value, std::size_t size) {
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i < size; ++i) out.push_back(static_cast<std::uint8_t>(value >> (8 * i)));
  return out;
}

std::optional<AccessError> write_error(std::uint16_t index, std::uint8_t subindex, std::uint32_t value,
                                       std::size_t size, const WritePolicy& policy = {}) {
  return check_write(index, subindex, le(value, size), policy).error;
}

TEST(Uc57Od, ListsExactlyTheManualsObjects) {
  const std::set<std::uint16_t> expected = {
      0x1000, 0x1001, 0x1003, 0x1009, 0x100A, 0x1014, 0x1017, 0x1018, 0x1200, 0x1400, 0x1401, 0x1402, 0x1403,
      0x1600, 0x1601, 0x1602, 0x1603, 0x1800, 0x1801, 0x1802, 0x1803, 0x1A00, 0x1A01, 0x1A02, 0x1A03, 0x2000,
      0x2001, 0x2003, 0x2004, 0x2005, 0x2006, 0x2007, 0x2008, 0x2009, 0x200A, 0x200B, 0x200C, 0x200E, 0x200F,
      0x2010, 0x2011, 0x2012, 0x2030, 0x2040, 0x2041, 0x2FF7, 0x603F, 0x6040, 0x6041, 0x605D, 0x6060, 0x6061,
      0x6064, 0x606C, 0x607A, 0x607C, 0x6081, 0x6083, 0x6084, 0x6098, 0x6099, 0x609A, 0x60FD, 0x60FF};
  std::set<std::uint16_t> present;
  for (const OdEntry& entry : object_dictionary()) present.insert(entry.index);
  EXPECT_EQ(present, expected);
  EXPECT_EQ(object_dictionary().size(), 151U);
  for (const std::uint16_t index : expected) EXPECT_TRUE(has_object(index)) << std::hex << index;
}

TEST(Uc57Od, SortedAndUnique) {
  const auto od = object_dictionary();
  for (std::size_t i = 1; i < od.size(); ++i) {
    const bool ordered =
        od[i - 1].index < od[i].index || (od[i - 1].index == od[i].index && od[i - 1].subindex < od[i].subindex);
    EXPECT_TRUE(ordered) << std::hex << od[i].index << ":" << int{od[i].subindex};
  }
}

TEST(Uc57Od, SubindexLayouts) {
  const auto subindexes = [](std::uint16_t index) {
    std::vector<int> out;
    for (const OdEntry& entry : object_entries(index)) out.push_back(entry.subindex);
    return out;
  };
  EXPECT_EQ(subindexes(0x1003), (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8}));
  EXPECT_EQ(subindexes(0x1018), (std::vector<int>{0, 1, 2, 3, 4}));
  for (const std::uint16_t pdo :
       std::initializer_list<std::uint16_t>{0x1400, 0x1401, 0x1402, 0x1403, 0x1800, 0x1801, 0x1802, 0x1803}) {
    EXPECT_EQ(subindexes(pdo), (std::vector<int>{0, 1, 2, 3, 5})) << std::hex << pdo;  // no sub04
  }
  for (const std::uint16_t map :
       std::initializer_list<std::uint16_t>{0x1600, 0x1601, 0x1602, 0x1603, 0x1A00, 0x1A01, 0x1A02, 0x1A03}) {
    EXPECT_EQ(subindexes(map), (std::vector<int>{0, 1, 2, 3, 4})) << std::hex << map;
  }
  EXPECT_EQ(subindexes(0x2030), (std::vector<int>{0x00, 0x01, 0x02, 0x03, 0x04, 0x0C, 0x0D, 0x0E}));
  EXPECT_EQ(subindexes(0x6099), (std::vector<int>{0, 1, 2}));
  EXPECT_TRUE(object_entries(0x605A).empty());
}

TEST(Uc57Od, EveryDefaultIsWithinItsRangeAndType) {
  for (const OdEntry& entry : object_dictionary()) {
    SCOPED_TRACE(std::string(entry.name));
    EXPECT_LE(entry.min, entry.max);
    EXPECT_GE(entry.min, type_min(entry.type));
    EXPECT_LE(entry.max, type_max(entry.type));
    EXPECT_FALSE(entry.name.empty());
    for (const std::uint8_t node : {std::uint8_t{1}, std::uint8_t{127}}) {
      const std::int64_t value = default_value(entry, node);
      EXPECT_EQ(check_value(entry, value), std::nullopt) << "node " << int{node} << " default " << value;
      std::array<std::uint8_t, 4> raw{};
      EXPECT_TRUE(encode_value(entry.type, value, raw));
    }
  }
}

TEST(Uc57Od, SampleEntriesMatchTheManual) {
  const OdEntry& device_type = at(0x1000, 0);
  EXPECT_EQ(device_type.type, DataType::kUnsigned32);
  EXPECT_EQ(device_type.access, Access::kReadOnly);
  EXPECT_FALSE(device_type.pdo_mappable);
  EXPECT_EQ(device_type.default_value, 0x00040192);  // D-05

  EXPECT_EQ(at(0x1018, 1).default_value, 0x00000322);  // D-06
  EXPECT_EQ(at(0x1017, 0).access, Access::kReadWriteStore);
  EXPECT_EQ(at(0x1017, 0).unit, Unit::kMilliseconds);

  const OdEntry& microstep = at(0x2006, 0);
  EXPECT_EQ(microstep.default_value, 13);  // D-09
  EXPECT_EQ(microstep.type, DataType::kUnsigned16);
  EXPECT_EQ(microstep.access, Access::kReadWriteStore);
  EXPECT_TRUE(microstep.pdo_mappable);
  EXPECT_EQ(microstep.max, 15);

  const OdEntry& controlword = at(0x6040, 0);
  EXPECT_EQ(controlword.type, DataType::kUnsigned16);
  EXPECT_EQ(controlword.access, Access::kReadWrite);
  EXPECT_TRUE(controlword.pdo_mappable);

  const OdEntry& halt = at(0x605D, 0);
  EXPECT_EQ(halt.type, DataType::kInteger16);
  EXPECT_FALSE(halt.pdo_mappable);

  EXPECT_EQ(at(0x6060, 0).type, DataType::kInteger8);
  EXPECT_EQ(at(0x6061, 0).access, Access::kReadOnly);
  EXPECT_EQ(at(0x6098, 0).type, DataType::kUnsigned8);
  EXPECT_EQ(at(0x607A, 0).default_value, 5000);
  EXPECT_EQ(at(0x607A, 0).min, -1000000);
  EXPECT_EQ(at(0x6099, 1).default_value, 120);
  EXPECT_EQ(at(0x6099, 2).default_value, 60);
  EXPECT_EQ(at(0x2030, 0).type, DataType::kUnsigned16);  // sub00 as U16, as printed
  EXPECT_EQ(at(0x2030, 0).default_value, 16);
  EXPECT_EQ(at(0x2005, 0).unit, Unit::kDeciAmpereRms);
  EXPECT_EQ(at(0x2040, 0).default_value, 220);
}

TEST(Uc57Od, NodeIdDependentDefaults) {
  EXPECT_EQ(default_value(at(0x1200, 1), 1), 0x601);
  EXPECT_EQ(default_value(at(0x1200, 2), 1), 0x581);
  EXPECT_EQ(default_value(at(0x1400, 1), 1), 0x201);
  EXPECT_EQ(default_value(at(0x1401, 1), 1), 0x301);
  EXPECT_EQ(default_value(at(0x1402, 1), 1), 0x401);
  EXPECT_EQ(default_value(at(0x1403, 1), 1), 0x501);
  EXPECT_EQ(default_value(at(0x1800, 1), 1), 0x181);
  EXPECT_EQ(default_value(at(0x1801, 1), 5), 0x285);
  EXPECT_EQ(default_value(at(0x1802, 1), 0x12), 0x392);
  EXPECT_EQ(default_value(at(0x1803, 1), 1), 0x481);
  EXPECT_EQ(default_value(at(0x1014, 0), 1), 0x81);  // C-11
  EXPECT_EQ(default_value(at(0x2000, 0), 7), 7);
  EXPECT_EQ(default_value(at(0x1400, 2), 7), 0xFF);  // not node-dependent
}

TEST(Uc57Od, DefaultPdoMappings) {
  EXPECT_EQ(mapping_entry(0x6081, 0, 32), 0x60810020U);  // the manual's address form
  const std::vector<std::tuple<std::uint16_t, std::uint8_t, std::int64_t>> cases = {
      {0x1600, 0, 3},          {0x1600, 1, 0x60400010}, {0x1600, 2, 0x60FF0020}, {0x1600, 3, 0x60600008},
      {0x1600, 4, 0},          {0x1601, 0, 2},          {0x1601, 1, 0x607A0020}, {0x1601, 2, 0x60810020},
      {0x1602, 0, 0},          {0x1603, 0, 0},          {0x1A00, 0, 3},          {0x1A00, 1, 0x60410010},
      {0x1A00, 2, 0x60FD0020}, {0x1A00, 3, 0x60610008}, {0x1A01, 0, 2},  // C-09: printed 0
      {0x1A01, 1, 0x60640020}, {0x1A01, 2, 0x606C0020}, {0x1A02, 0, 0},          {0x1A03, 0, 0},
  };
  for (const auto& [index, sub, value] : cases) {
    EXPECT_EQ(at(index, sub).default_value, value) << std::hex << index << ":" << int{sub};
  }
}

TEST(Uc57Od, ConflictChoices) {
  EXPECT_EQ(at(0x6081, 0).min, 5);  // C-03
  EXPECT_EQ(at(0x6081, 0).max, 1000);
  EXPECT_EQ(at(0x6081, 0).default_value, 60);
  for (const std::uint16_t ramp : std::initializer_list<std::uint16_t>{0x6083, 0x6084, 0x609A}) {  // C-02
    EXPECT_EQ(at(ramp, 0).min, 1);
    EXPECT_EQ(at(ramp, 0).max, 2000);
    EXPECT_EQ(at(ramp, 0).default_value, 50);
    EXPECT_EQ(at(ramp, 0).unit, Unit::kRampSetting);
  }
  EXPECT_EQ(at(0x60FF, 0).default_value, 120);  // C-04
  EXPECT_EQ(at(0x60FF, 0).min, -1000);
  EXPECT_EQ(at(0x607C, 0).max, 1000000);               // C-05
  EXPECT_EQ(at(0x6099, 0).access, Access::kReadOnly);  // C-06
  EXPECT_EQ(at(0x6098, 0).max, 255);                   // C-07
  EXPECT_EQ(at(0x1009, 0).default_value, 0x0100);      // C-13
  EXPECT_EQ(at(0x2008, 0).max, 127);                   // C-15
  EXPECT_EQ(at(0x2011, 0).max, 1);                     // C-12
  EXPECT_EQ(at(0x1003, 0).default_value, 8);           // C-18
  EXPECT_EQ(at(0x2005, 0).max, 25);                    // C-19
}

// ---- Access and range checks: derived abort vectors (D-20..D-25) and more ----
TEST(Uc57OdAccess, DerivedAbortVectors) {
  EXPECT_EQ(write_error(0x6041, 0, 0x0000, 2), AccessError::kReadOnly);        // D-20
  EXPECT_EQ(check_read(0x605A, 0).error, AccessError::kNoObject);              // D-21
  EXPECT_EQ(check_read(0x6099, 3).error, AccessError::kNoSubindex);            // D-22
  EXPECT_EQ(write_error(0x6099, 0, 120, 4), AccessError::kReadOnly);           // D-23 (= manual H-04)
  EXPECT_EQ(write_error(0x6081, 0, 0, 4), AccessError::kValueTooLow);          // D-24
  EXPECT_EQ(write_error(0x6040, 0, 0x000F, 4), AccessError::kLengthMismatch);  // D-25
}

TEST(Uc57OdAccess, ReadChecks) {
  const Lookup ok = check_read(0x6041, 0);
  EXPECT_EQ(ok.error, std::nullopt);
  ASSERT_NE(ok.entry, nullptr);
  EXPECT_EQ(ok.entry->index, 0x6041);
  EXPECT_EQ(check_read(0x1008, 0).error, AccessError::kNoObject);  // D-28: no 1008h on the UC57
  EXPECT_EQ(check_read(0x2030, 0x05).error, AccessError::kNoSubindex);
  EXPECT_TRUE(readable(Access::kReadWriteStore));
  EXPECT_FALSE(readable(Access::kWriteOnly));
  EXPECT_FALSE(writable(Access::kReadOnly));
  EXPECT_TRUE(writable(Access::kWriteOnly));
}

TEST(Uc57OdAccess, RangeChecks) {
  EXPECT_EQ(write_error(0x6081, 0, 1001, 4), AccessError::kValueTooHigh);
  EXPECT_EQ(write_error(0x6081, 0, 1000, 4), std::nullopt);
  EXPECT_EQ(write_error(0x6081, 0, 5, 4), std::nullopt);
  EXPECT_EQ(write_error(0x60FF, 0, static_cast<std::uint32_t>(-1000), 4), std::nullopt);
  EXPECT_EQ(write_error(0x60FF, 0, static_cast<std::uint32_t>(-1001), 4), AccessError::kValueTooLow);
  EXPECT_EQ(write_error(0x607A, 0, 1000001, 4), AccessError::kValueTooHigh);
  EXPECT_EQ(write_error(0x2005, 0, 0, 2), AccessError::kValueTooLow);
  EXPECT_EQ(write_error(0x2005, 0, 26, 2), AccessError::kValueTooHigh);
  EXPECT_EQ(write_error(0x2006, 0, 16, 2), AccessError::kValueTooHigh);
  EXPECT_EQ(write_error(0x2008, 0, 128, 2), AccessError::kValueTooHigh);
  // 6060h: only 0, 1, 3, 6 (C-01).
  EXPECT_EQ(write_error(0x6060, 0, 2, 1), AccessError::kInvalidValue);
  EXPECT_EQ(write_error(0x6060, 0, 6, 1), std::nullopt);
  EXPECT_EQ(write_error(0x6060, 0, 7, 1), AccessError::kValueTooHigh);
  EXPECT_EQ(write_error(0x6060, 0, 0xFF, 1), AccessError::kValueTooLow);  // I8 -1
}

TEST(Uc57OdAccess, PolicySwitches) {
  const WritePolicy lenient{.check_range = false};
  EXPECT_EQ(write_error(0x6081, 0, 0, 4, lenient), std::nullopt);
  EXPECT_EQ(write_error(0x6060, 0, 2, 1, lenient), std::nullopt);
  EXPECT_EQ(write_error(0x6041, 0, 0, 2, lenient), AccessError::kReadOnly);  // access is never relaxed

  const WritePolicy any_length{.check_length = false};
  EXPECT_EQ(write_error(0x6040, 0, 0x000F, 4, any_length), std::nullopt);
  EXPECT_EQ(write_error(0x6081, 0, 0x3C, 1, any_length), std::nullopt);  // zero-extended to 60

  // C-10: the manual's RO PDO configuration entries, writable on request (vectors D-31, D-32).
  EXPECT_EQ(write_error(0x1400, 1, 0x80000201, 4), AccessError::kReadOnly);
  EXPECT_EQ(write_error(0x1600, 0, 0, 1), AccessError::kReadOnly);
  const WritePolicy cia301{.pdo_configuration_writable = true};
  EXPECT_EQ(write_error(0x1400, 1, 0x80000201, 4, cia301), std::nullopt);
  EXPECT_EQ(write_error(0x1600, 0, 0, 1, cia301), std::nullopt);
  EXPECT_EQ(write_error(0x1A03, 0, 2, 1, cia301), std::nullopt);
  EXPECT_EQ(write_error(0x1A03, 0, 5, 1, cia301), AccessError::kValueTooHigh);  // at most 4 entries
  EXPECT_EQ(write_error(0x1803, 1, 0x481, 4, cia301), std::nullopt);
  EXPECT_EQ(write_error(0x1400, 0, 5, 1, cia301), AccessError::kReadOnly);  // only sub01 / sub00 unlock
  EXPECT_EQ(write_error(0x1000, 0, 0, 4, cia301), AccessError::kReadOnly);
}

// Every SDO download printed in the manual (§4.2.2-§4.2.6) and the derived ones (not printed in the
// manual), as frame bytes: the OD must accept them, except H-04 (C-06).
TEST(Uc57OdAccess, ManualAndDerivedDownloadFrames) {
  struct Frame {
    const char* id;
    std::array<std::uint8_t, 8> bytes;
    std::optional<AccessError> expected;
  };
  const std::vector<Frame> frames = {
      {"M-02", {0x2B, 0x40, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00}, std::nullopt},
      {"M-03", {0x2B, 0x40, 0x60, 0x00, 0x06, 0x00, 0x00, 0x00}, std::nullopt},
      {"M-04", {0x2B, 0x40, 0x60, 0x00, 0x07, 0x00, 0x00, 0x00}, std::nullopt},
      {"M-05", {0x2B, 0x40, 0x60, 0x00, 0x0F, 0x00, 0x00, 0x00}, std::nullopt},
      {"P-03", {0x23, 0x83, 0x60, 0x00, 0x64, 0x00, 0x00, 0x00}, std::nullopt},
      {"P-04", {0x23, 0x84, 0x60, 0x00, 0x64, 0x00, 0x00, 0x00}, std::nullopt},
      {"P-05", {0x23, 0x81, 0x60, 0x00, 0x3C, 0x00, 0x00, 0x00}, std::nullopt},
      {"P-06", {0x23, 0x7A, 0x60, 0x00, 0x88, 0x13, 0x00, 0x00}, std::nullopt},
      {"P-07", {0x2F, 0x60, 0x60, 0x00, 0x01, 0x00, 0x00, 0x00}, std::nullopt},
      {"P-11", {0x2B, 0x40, 0x60, 0x00, 0x4F, 0x00, 0x00, 0x00}, std::nullopt},
      {"P-12", {0x2B, 0x40, 0x60, 0x00, 0x5F, 0x00, 0x00, 0x00}, std::nullopt},
      {"V-05", {0x23, 0xFF, 0x60, 0x00, 0x3C, 0x00, 0x00, 0x00}, std::nullopt},
      {"V-06", {0x2F, 0x60, 0x60, 0x00, 0x03, 0x00, 0x00, 0x00}, std::nullopt},
      {"H-03", {0x2F, 0x98, 0x60, 0x00, 0x64, 0x00, 0x00, 0x00}, std::nullopt},  // C-07: any U8
      {"H-04", {0x23, 0x99, 0x60, 0x00, 0x78, 0x00, 0x00, 0x00}, AccessError::kReadOnly},
      {"H-05", {0x23, 0x99, 0x60, 0x01, 0x3C, 0x00, 0x00, 0x00}, std::nullopt},
      {"H-06", {0x23, 0x9A, 0x60, 0x00, 0x64, 0x00, 0x00, 0x00}, std::nullopt},
      {"H-07", {0x2F, 0x60, 0x60, 0x00, 0x06, 0x00, 0x00, 0x00}, std::nullopt},
      {"H-11", {0x2B, 0x40, 0x60, 0x00, 0x1F, 0x00, 0x00, 0x00}, std::nullopt},
      {"D-02", {0x23, 0x7A, 0x60, 0x00, 0x80, 0xF3, 0xFF, 0xFF}, std::nullopt},
      {"D-03", {0x23, 0x81, 0x60, 0x00, 0x78, 0x00, 0x00, 0x00}, std::nullopt},
      {"D-10", {0x23, 0xFF, 0x60, 0x00, 0xC4, 0xFF, 0xFF, 0xFF}, std::nullopt},
      {"D-19", {0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0x00, 0x00}, std::nullopt},
      {"D-36", {0x2F, 0x00, 0x14, 0x02, 0x01, 0x00, 0x00, 0x00}, std::nullopt},
      {"D-33", {0x23, 0x00, 0x16, 0x01, 0x10, 0x00, 0x40, 0x60}, std::nullopt},
      {"D-50/1", {0x2F, 0x98, 0x60, 0x00, 0x18, 0x00, 0x00, 0x00}, std::nullopt},
      {"D-50/3", {0x23, 0x99, 0x60, 0x02, 0x3C, 0x00, 0x00, 0x00}, std::nullopt},
      {"D-50/5", {0x23, 0x7C, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00}, std::nullopt},
      {"D-53", {0x2B, 0x40, 0x60, 0x00, 0x0F, 0x01, 0x00, 0x00}, std::nullopt},
      {"D-55", {0x2B, 0x12, 0x20, 0x00, 0x01, 0x00, 0x00, 0x00}, std::nullopt},
      {"D-56", {0x2B, 0x10, 0x20, 0x00, 0x02, 0x00, 0x00, 0x00}, std::nullopt},
      {"D-57", {0x2B, 0x06, 0x20, 0x00, 0x04, 0x00, 0x00, 0x00}, std::nullopt},
  };
  for (const Frame& frame : frames) {
    SCOPED_TRACE(frame.id);
    const auto& b = frame.bytes;
    const std::size_t size = 4 - ((b[0] >> 2) & 0x3);  // expedited, size indicated: n = unused bytes
    const auto index = static_cast<std::uint16_t>(b[1] | (b[2] << 8));
    const auto result = check_write(index, b[3], std::span<const std::uint8_t>(b.data() + 4, size));
    EXPECT_EQ(result.error, frame.expected);
  }
}

// ---- Value codec (little-endian, CiA 301) ----
TEST(Uc57OdCodec, DecodesUploadPayloads) {
  const std::array<std::uint8_t, 4> device_type = {0x92, 0x01, 0x04, 0x00};  // D-05
  EXPECT_EQ(decode_value(DataType::kUnsigned32, device_type), 0x00040192);
  const std::array<std::uint8_t, 4> position = {0x80, 0xF3, 0xFF, 0xFF};  // D-08
  EXPECT_EQ(decode_value(DataType::kInteger32, position), -3200);
  EXPECT_EQ(decode_value(DataType::kUnsigned32, position), 0xFFFFF380);
  const std::array<std::uint8_t, 1> mode = {0x01};  // D-07
  EXPECT_EQ(decode_value(DataType::kInteger8, mode), 1);
  const std::array<std::uint8_t, 2> status = {0x37, 0x02};  // D-04
  EXPECT_EQ(decode_value(DataType::kUnsigned16, status), 0x0237);
  EXPECT_EQ(decode_value(DataType::kUnsigned16, device_type), std::nullopt);  // wrong size
}

TEST(Uc57OdCodec, EncodesDownloadPayloads) {
  std::array<std::uint8_t, 4> out{};
  ASSERT_TRUE(encode_value(DataType::kInteger32, -3200, out));  // D-02
  EXPECT_EQ(out, (std::array<std::uint8_t, 4>{0x80, 0xF3, 0xFF, 0xFF}));
  ASSERT_TRUE(encode_value(DataType::kInteger32, -60, out));  // D-10
  EXPECT_EQ(out, (std::array<std::uint8_t, 4>{0xC4, 0xFF, 0xFF, 0xFF}));
  ASSERT_TRUE(encode_value(DataType::kUnsigned32, mapping_entry(0x6081, 0, 32), out));
  EXPECT_EQ(out, (std::array<std::uint8_t, 4>{0x20, 0x00, 0x81, 0x60}));
  std::array<std::uint8_t, 2> word{};
  ASSERT_TRUE(encode_value(DataType::kUnsigned16, 5000, word));  // 0x1388 -> 88 13
  EXPECT_EQ(word, (std::array<std::uint8_t, 2>{0x88, 0x13}));
  EXPECT_FALSE(encode_value(DataType::kUnsigned8, 256, out));
  EXPECT_FALSE(encode_value(DataType::kInteger8, -129, out));
  EXPECT_FALSE(encode_value(DataType::kUnsigned32, 0, word));  // too small a buffer
  EXPECT_EQ(size_bytes(DataType::kInteger16), 2);
  EXPECT_EQ(type_min(DataType::kInteger32), -2147483648LL);
  EXPECT_EQ(type_max(DataType::kUnsigned32), 4294967295LL);
}

}  // namespace
}  // namespace motion::cia402::uc57
