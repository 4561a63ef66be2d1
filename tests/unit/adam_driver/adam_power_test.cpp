// An ADAM drive that loses power, served by the simulated drive (sim::AdamDriveSim, which powers up
// with its registers at their defaults and its position at 0):
//   - powered up at rest where its position read 0 already, which its answers alone cannot show:
//     its power-on marker (position reminder X19, written and not saved) is gone, so its position
//     is reported lost once, saying how it was found;
//   - after a Save (which stores the marker too) a different marker is written;
//   - a drive that goes silent and answers again, or rests at 0 for long, is no power-up.
#include <algorithm>
#include <cstdio>

#include "adam_stack_fixture.hpp"
#include "motion/sim/adam_drive_sim.hpp"

namespace motion::adam_driver::test {
namespace {

constexpr std::int16_t kOffline = std::int16_t{motionlcm::event_t::OFFLINE};

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

class AdamPowerTest : public AdamStackTest {
 protected:
  AdamPowerTest() {
    other_banks[1] = &sim;
    before_serving = [this] { sim.set_now(now); };
    core->start(now);
    run_for(500ms);  // set up, polled, its marker written
  }
  // Frames of `prefix` (hex) sent from `from` on.
  [[nodiscard]] std::size_t count_sent(const std::string& prefix, std::size_t from = 0) const {
    return static_cast<std::size_t>(std::count_if(sent.begin() + static_cast<std::ptrdiff_t>(from), sent.end(),
                                                  [&](const Bytes& b) { return hex(b).rfind(prefix, 0) == 0; }));
  }
  static constexpr const char* kMarkerRead = "01 03 00 C6 00 02";
  static constexpr const char* kMarkerWrite = "01 10 00 C6 00 02 04";
  sim::AdamDriveSim sim;
};

TEST_F(AdamPowerTest, APowerCycleAtRestAtZeroIsReportedOnceByItsMarker) {
  ASSERT_TRUE(core->ready());
  ASSERT_EQ(count_sent(kMarkerWrite), 1U);
  ASSERT_TRUE(out.lost.empty());
  sim.power_cycle(now);
  run_for(3s);
  ASSERT_EQ(out.lost.size(), 1U);
  EXPECT_TRUE(contains(out.lost[0],
                       "c-drive (slave 1) powered up, detected by its power-on marker: position "
                       "reminder X19 reads 0x3fffffff, not the unsaved 0x3ffffffe"))
      << out.lost[0];
  // Set up again, its marker written again: no second report.
  run_for(10s);
  EXPECT_TRUE(core->ready());
  EXPECT_EQ(count_sent(kMarkerWrite), 2U);
  EXPECT_EQ(out.lost.size(), 1U);
}

TEST_F(AdamPowerTest, AfterASaveTheNextMarkerIsWritten) {
  Command c = command(9, std::int8_t{Command::PARAM_WRITE}, {"c"});
  c.param.space = std::int8_t{motionlcm::param_t::MODBUS_REGISTER};
  c.param.index = 0x00DC;  // Save (§8.69): the marker in flash now
  c.param.value = 1;
  c.param.width = 1;
  const auto before = sent.size();
  core->execute(c, now);
  run_for(500ms);
  ASSERT_EQ(out.terminal(9), 1);
  EXPECT_EQ(out.of(9).back().status, kDone) << out.of(9).back().reason;
  // 0x3FFFFFFD, low word first.
  EXPECT_EQ(count_sent(hex(with_crc({0x01, 0x10, 0x00, 0xC6, 0x00, 0x02, 0x04, 0xFF, 0xFD, 0x3F, 0xFF})), before), 1U);
  sim.power_cycle(now);
  run_for(3s);
  EXPECT_EQ(out.lost.size(), 1U);
}

TEST_F(AdamPowerTest, SilenceAndALongRestAtZeroAreNoPowerUp) {
  silent.insert(1);
  run_for(3s);
  EXPECT_TRUE(out.has_event(kOffline));
  silent.clear();
  const auto back = sent.size();
  run_for(20s);
  EXPECT_TRUE(core->ready());
  EXPECT_TRUE(out.lost.empty()) << out.lost.front();
  // At 0 at rest: read again at most once a second (polled every 100 ms), and read.
  const auto reads = count_sent(kMarkerRead, back);
  EXPECT_GE(reads, 10U);
  EXPECT_LE(reads, 21U);
  std::printf("20 s at rest at position 0, polled at 10 Hz: %zu marker reads\n", reads);
}

}  // namespace
}  // namespace motion::adam_driver::test
