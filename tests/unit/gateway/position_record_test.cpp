// PositionRecords (the gateway's record of its axes across its restarts): the file's text both
// ways, what a bad file is, the atomic private write, and what counts as evidence of a power cycle.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "motion/gateway/position_record.hpp"

namespace motion::gateway {
namespace {

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(PositionRecords, TextRoundTripsEveryField) {
  const std::map<std::string, AxisRecord> records{
      {"x", {7680, 7680, false, true, ""}},
      {"y", {-100, 5000, true, false, ""}},
      {"z", {0, 0, false, false, "z-drive sent a boot-up message\t(power cycle)"}},
  };
  std::map<std::string, AxisRecord> back;
  ASSERT_EQ(PositionRecords::parse(PositionRecords::format(records), back), "");
  ASSERT_EQ(back.size(), 3U);
  EXPECT_EQ(back.at("x"), records.at("x"));
  EXPECT_EQ(back.at("y"), records.at("y"));
  EXPECT_EQ(back.at("z").lost, "z-drive sent a boot-up message (power cycle)");  // one line, no tab
}

TEST(PositionRecords, ABadFileIsNamedAndKnowsNothing) {
  std::map<std::string, AxisRecord> back;
  EXPECT_TRUE(contains(PositionRecords::parse("", back), "empty"));
  EXPECT_TRUE(contains(PositionRecords::parse("x\t1\t1\trest\thomed\t\n", back), "line 1"));
  const std::string header = PositionRecords::format({});
  const std::string why = PositionRecords::parse(header + "x\t1\t1\trest\thomed\t\ny\tten\t1\trest\thomed\t\n", back);
  EXPECT_TRUE(contains(why, "line 4")) << why;
  EXPECT_TRUE(back.empty());
}

TEST(PositionRecords, SavedPrivatelyAndLoadedBack) {
  const auto dir = std::filesystem::temp_directory_path() / ("position-record-test-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "bus.positions").string();
  PositionRecords none(path);
  EXPECT_EQ(none.load(), "");  // no file: the first start
  EXPECT_EQ(none.find("x"), nullptr);

  PositionRecords records(path);
  EXPECT_TRUE(records.update("x", {1234, 1234, false, true, ""}));
  EXPECT_FALSE(records.update("x", {1234, 1234, false, true, ""}));  // unchanged: nothing to write
  ASSERT_EQ(records.save(), "");
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600U);
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
  PositionRecords again(path);
  ASSERT_EQ(again.load(), "");
  ASSERT_NE(again.find("x"), nullptr);
  EXPECT_EQ(again.find("x")->position_counts, 1234);

  std::ofstream(path) << "garbage\n";
  PositionRecords bad(path);
  EXPECT_TRUE(contains(bad.load(), path));
  EXPECT_EQ(bad.find("x"), nullptr);
  std::filesystem::remove_all(dir);
}

DriveStatus at(std::int64_t counts, bool homed = false) {
  DriveStatus s;
  s.online = true;
  s.position_read = true;
  s.position_counts = counts;
  s.homed = homed;
  return s;
}

TEST(PowerCycleEvidence, AtRestAPositionBeyondTheToleranceIsOne) {
  const AxisRecord rest{7680, 7680, false, true, ""};
  EXPECT_FALSE(power_cycle_evidence(rest, at(7680 + 64), false, 64, "x-drive"));
  EXPECT_FALSE(power_cycle_evidence(rest, at(7680 - 64), false, 64, "x-drive"));
  const auto why = power_cycle_evidence(rest, at(0), false, 64, "x-drive");
  ASSERT_TRUE(why);
  EXPECT_TRUE(contains(*why,
                       "x-drive powered up or was reset while no gateway ran, detected by the position record: it "
                       "answers at 0 counts, 7680 counts were recorded at rest"))
      << *why;
}

TEST(PowerCycleEvidence, MovingAnywhereBetweenStartAndTargetIsNot) {
  const AxisRecord moving{1000, -5000, true, false, ""};
  EXPECT_FALSE(power_cycle_evidence(moving, at(-2000), false, 64, "x-drive"));
  EXPECT_FALSE(power_cycle_evidence(moving, at(0), false, 64, "x-drive"));  // not caught: 0 is on the way
  EXPECT_FALSE(power_cycle_evidence(moving, at(-5050), false, 64, "x-drive"));
  const auto why = power_cycle_evidence(AxisRecord{1000, 5000, true, false, ""}, at(0), false, 64, "x-drive");
  ASSERT_TRUE(why);
  EXPECT_TRUE(contains(*why, "outside the move from 1000 to 5000 counts")) << *why;
}

TEST(PowerCycleEvidence, ADriveThatKeepsHomedAndClearedItIsOneEvenAtTheSamePosition) {
  const AxisRecord homed{0, 0, false, true, ""};
  const auto why = power_cycle_evidence(homed, at(0, false), true, 64, "a-drive");
  ASSERT_TRUE(why);
  EXPECT_TRUE(contains(*why,
                       "a-drive powered up or was reset while no gateway ran, detected by the position record: it no "
                       "longer reports homed"))
      << *why;
  EXPECT_FALSE(power_cycle_evidence(homed, at(0, true), true, 64, "a-drive"));
  // Where homed is the driver's own bookkeeping (false after any restart), it says nothing.
  EXPECT_FALSE(power_cycle_evidence(homed, at(0, false), false, 64, "z-drive"));
}

}  // namespace
}  // namespace motion::gateway
