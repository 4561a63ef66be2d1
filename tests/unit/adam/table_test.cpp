// Table data (§8.54) and the broadcast synchronized start built on it.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "hex.hpp"
#include "motion/adam/table.hpp"

namespace motion::adam {
namespace {

using test::to_hex;

// The 24 entries of the §8.54 example table (registers 500…547).
const std::vector<std::int32_t> kManualTable = {
    25535, -13575, 12352, -11231, 24563, -18963, 12345, -600,  5635, -3565, 25635, -25635,
    1345,  -6000,  56315, -35615, 2565,  -2535,  2345,  -5600, 8635, -1365, 15635, -5635,
};
constexpr std::uint16_t kManualStartOffset = 200;  // 0x00AC example: 500 − 300

std::vector<std::string> frames_hex(const std::vector<rtu::Request>& requests) {
  std::vector<std::string> out;
  out.reserve(requests.size());
  for (const auto& r : requests) out.push_back(to_hex(rtu::encode_request(r).value()));
  return out;
}

TEST(AdamTable, EntryAddresses) {
  EXPECT_EQ(table_entry_address(kManualStartOffset, 0), 500U);
  EXPECT_EQ(table_entry_address(kManualStartOffset, 21), 542U);  // −1365 per the §8.54 table
}

TEST(AdamTable, BulkLoadIsTheManualsFrame) {
  const auto frames = table_data_writes(1, kManualStartOffset, kManualTable);
  ASSERT_TRUE(frames.ok());
  ASSERT_EQ(frames.value().size(), 1U);
  const auto bytes = rtu::encode_request(frames.value()[0]).value();
  EXPECT_EQ(bytes.size(), 105U);
  EXPECT_EQ(to_hex(bytes),
            "01 10 01 F4 00 30 60 63 BF 00 00 CA F9 FF FF 30 40 00 00 D4 21 FF FF 5F F3 00 00 B5 ED FF FF 30 39 "
            "00 00 FD A8 FF FF 16 03 00 00 F2 13 FF FF 64 23 00 00 9B DD FF FF 05 41 00 00 E8 90 FF FF DB FB 00 "
            "00 74 E1 FF FF 0A 05 00 00 F6 19 FF FF 09 29 00 00 EA 20 FF FF 21 BB 00 00 FA AB FF FF 3D 13 00 00 "
            "E9 FD FF FF 14 91");
}

TEST(AdamTable, EntryByEntryLoadIsTheManualsFrames) {
  const auto frames = table_data_writes(1, kManualStartOffset, kManualTable, 2);
  ASSERT_TRUE(frames.ok());
  ASSERT_EQ(frames.value().size(), 24U);
  const auto hexes = frames_hex(frames.value());
  EXPECT_EQ(hexes[0], "01 10 01 F4 00 02 04 63 BF 00 00 DF 28");  // 25535 at 500
  EXPECT_EQ(hexes[1], "01 10 01 F6 00 02 04 CA F9 FF FF 9F 08");  // −13575 at 502
}

TEST(AdamTable, ChunkingRespectsTheFrameLimit) {
  const std::vector<std::int32_t> many(100, 7);
  const auto frames = table_data_writes(3, 0, many);
  ASSERT_TRUE(frames.ok());
  ASSERT_EQ(frames.value().size(), 3U);  // 47 + 47 + 6 entries of 2 registers
  std::uint32_t next = kProgrammingAreaFirst;
  for (const auto& r : frames.value()) {
    const auto& w = std::get<rtu::WriteRegisters>(r.pdu);
    EXPECT_EQ(w.start, next);
    EXPECT_LE(w.values.size(), kMaxDriveWriteRegisters);
    EXPECT_LE(rtu::encode_request(r).value().size(), kMaxDriveFrameBytes);
    next += static_cast<std::uint32_t>(w.values.size());
  }
  EXPECT_EQ(next, kProgrammingAreaFirst + 200U);
  EXPECT_EQ(table_data_writes(1, 0, {}).error(), AdamErrc::kEmptyTable);
  EXPECT_EQ(table_data_writes(1, 0, many, 96).error(), AdamErrc::kTooManyRegisters);
  EXPECT_EQ(table_data_writes(1, 0, std::vector<std::int32_t>(2049, 0)).error(), AdamErrc::kTooManyRegisters);
}

TEST(AdamTable, SynchronizedStartPreloadAndTrigger) {
  SyncMovePreload preload;
  preload.profile = {0, 0, 200, 200, 60000};  // start/stop 0 rpm, 200 ms ramps, 600 rpm
  preload.target_pulses = -100000;
  const auto frames = sync_move_preload(2, preload);
  ASSERT_TRUE(frames.ok());
  const std::vector<std::string> expected = {
      "02 10 00 96 00 04 08 00 00 00 00 00 C8 00 C8 BE 9A",  // 0x0096…0x0099
      "02 10 00 D8 00 02 04 EA 60 00 00 C4 17",              // 0x00D8 = 60000 (600.00 rpm)
      "02 10 01 F4 00 02 04 79 60 FF FE 26 FE",              // entry 0 at 500 = −100000
      "02 06 00 AA 00 01 68 19",                             // table size 1
      "02 06 00 AB 00 00 F8 19",                             // pointer 0
      "02 06 00 AC 00 C8 48 4E",                             // start offset 200
  };
  EXPECT_EQ(frames_hex(frames.value()), expected);
  const auto trigger = table_execute_broadcast();
  ASSERT_TRUE(trigger.ok());
  EXPECT_EQ(to_hex(rtu::encode_request(trigger.value()).value()), "00 06 00 DD 00 00 18 21");
  EXPECT_FALSE(expects_reply(trigger.value()));

  EXPECT_EQ(sync_move_preload(0, preload).error(), AdamErrc::kInvalidUnitAddress);
  EXPECT_EQ(sync_move_preload(65, preload).error(), AdamErrc::kInvalidUnitAddress);
  preload.profile.start_speed_rpm = 301;
  EXPECT_EQ(sync_move_preload(2, preload).error(), AdamErrc::kValueOutOfRange);
  EXPECT_EQ(table_execute_broadcast({TableEntryKind::kAbsolute, PointerArithmetic::kAdd, 4096}).error(),
            AdamErrc::kValueOutOfRange);
}

}  // namespace
}  // namespace motion::adam
