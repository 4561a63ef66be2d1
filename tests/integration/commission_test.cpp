// motionctl commission on the simulated UIM242 line (configs/uim242-two.yaml): every set-up value
// the gateway applied reads back as configured (exit 0); a value changed behind the gateway's back
// is named as a contradiction with what to do (exit 1). Nothing moves without --small-move.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <motionlcm/param_t.hpp>

#include "sim_lab.hpp"

namespace motion::testing {
namespace {

TEST(Commission, ReadsBackTheSetUpAndNamesAContradiction) {
  SimLab lab(source_path("tests/integration/configs/uim242-two.yaml"));
  ASSERT_TRUE(lab.start({"u1", "u2"}));
  const std::vector<std::string> args{"--config", lab.config_path(), "commission", "rs232"};
  std::string printed;
  ASSERT_EQ(lab.group().run_to_completion({"commission", "motionctl", args, {}}, &printed, std::chrono::seconds(30)), 0)
      << printed;
  EXPECT_NE(printed.find("u1-drive (uim242, node 5)\n  ICFG: 0\n  MCS micro-steps: 16 (as configured)"),
            std::string::npos)
      << printed;
  EXPECT_NE(printed.find("u2-drive (uim242, node 6)"), std::string::npos) << printed;

  request_t write = Client::make(request_t::PARAM_WRITE, std::vector<std::string>{"u1"});
  write.param.space = motionlcm::param_t::UIM242_INSTRUCTION;
  write.param.mnemonic = "MCS";
  write.param.value = 8;
  const auto written = lab.call(write);
  ASSERT_EQ(written.status, st(reply_t::DONE)) << written.reason;
  printed.clear();
  EXPECT_EQ(lab.group().run_to_completion({"commission-2", "motionctl", args, {}}, &printed, std::chrono::seconds(30)),
            1)
      << printed;
  EXPECT_NE(printed.find("MCS micro-steps: 8 CONTRADICTS the configuration (16)"), std::string::npos) << printed;
  EXPECT_TRUE(lab.starts_of("u1-drive").empty()) << "commission moved an axis";
  EXPECT_TRUE(lab.starts_of("u2-drive").empty()) << "commission moved an axis";
}

// --small-move 1 (configs/uim242-two.yaml): each axis moves 1 % of its 200 mm travel (+2 mm = 320
// counts at 160 counts/mm, toward the side with more room) out and back; the counts each drive
// reports change by exactly that and come back (exit 0). Checked against a configuration that says
// 320 counts/mm for u1 (as a wrong micro-stepping would make it), the same move is a contradiction
// naming what to check (exit 1). The first run also reports how each drive's move start was probed.
TEST(Commission, SmallMoveOutAndBackChecksTheCountsEachDriveReports) {
  SimLab lab(source_path("tests/integration/configs/uim242-two.yaml"));
  ASSERT_TRUE(lab.start({"u1", "u2"}));
  ASSERT_TRUE(lab.enable({"u1", "u2"}));
  std::vector<std::string> args{"--config", lab.config_path(), "commission", "rs232", "--small-move", "1"};
  std::string printed;
  ASSERT_EQ(lab.group().run_to_completion({"commission", "motionctl", args, {}}, &printed, std::chrono::seconds(60)), 0)
      << printed;
  std::printf("%s", printed.c_str());
  for (const auto* drive : {"u1-drive", "u2-drive"}) {
    const auto at = printed.find(std::string(drive) + " (uim242");
    ASSERT_NE(at, std::string::npos) << printed;
    EXPECT_EQ(printed.find("small move: +2 mm = 320 counts out and back: the drive counted +320, back at +0 (as "
                           "expected)",
                           at),
              printed.find("small move:", at))
        << drive << "\n"
        << printed;
    EXPECT_EQ(lab.starts_of(drive).size(), 2u) << drive << ": out and back";
    // The first armed move since the gateway started probed the move start (the simulated drives
    // hold a displacement loaded at speed 0, the default variant).
    EXPECT_NE(printed.find("move start: probed: a displacement loaded at speed 0 holds still", at), std::string::npos)
        << drive << "\n"
        << printed;
  }
  EXPECT_TRUE(lab.settled_at("u1", 0.0, 1e-9));
  EXPECT_TRUE(lab.settled_at("u2", 0.0, 1e-9));

  std::ifstream in(lab.config_path());
  std::stringstream text;
  text << in.rdbuf();
  std::string wrong = text.str();
  const auto first = wrong.find("steps_per_unit: 160");
  ASSERT_NE(first, std::string::npos);
  wrong.replace(first, 19, "steps_per_unit: 320");
  const auto wrong_path = std::filesystem::path(::testing::TempDir()) / "commission-wrong-steps.yaml";
  std::ofstream(wrong_path) << wrong;
  args[1] = wrong_path.string();
  printed.clear();
  EXPECT_EQ(lab.group().run_to_completion({"commission-2", "motionctl", args, {}}, &printed, std::chrono::seconds(60)),
            1)
      << printed;
  std::printf("%s", printed.c_str());
  EXPECT_NE(printed.find("small move: +2 mm = 640 counts out and back: the drive counted +320, back at +0 CONTRADICTS "
                         "the configuration (640 and 0 at steps_per_unit 320): check steps_per_unit and the drive's "
                         "micro-stepping (2 times the counts it made)"),
            std::string::npos)
      << printed;
  // The gateway probed both drives during the first run: nothing new to report, and it says why.
  EXPECT_NE(printed.find("move start: not probed in this run: the gateway probes a drive once"), std::string::npos)
      << printed;
  std::filesystem::remove(wrong_path);
}

// UC57 rpdo_sync (configs/uc57-rpdo-variants.yaml): commission names the variant each simulated
// drive follows; b-drive's configured answer (honoured) contradicts what its gateway found (exit 1).
TEST(Commission, NamesTheUc57RpdoSyncVariantOfEachDrive) {
  SimLab lab(source_path("tests/integration/configs/uc57-rpdo-variants.yaml"));
  ASSERT_TRUE(lab.start({"a", "b", "c"}));
  const std::vector<std::string> args{"--config", lab.config_path(), "commission", "can0"};
  std::string printed;
  EXPECT_EQ(lab.group().run_to_completion({"commission", "motionctl", args, {}}, &printed, std::chrono::seconds(30)), 1)
      << printed;
  const auto a = printed.find("a-drive (uc57, node 1)\n");
  ASSERT_NE(a, std::string::npos) << printed;
  EXPECT_EQ(printed.find("1400h:02 RPDO1 transmission type: 1; rpdo_sync: honoured\n"), printed.find("1400h:02", a))
      << printed;
  EXPECT_NE(printed.find("1400h:02 RPDO1 transmission type: 1; rpdo_sync: on_reception CONTRADICTS the configuration "
                         "(rpdo_sync: honoured)"),
            std::string::npos)
      << printed;
  EXPECT_NE(printed.find("1400h:02 RPDO1 transmission type: 255; rpdo_sync: refused (moves start node by node"),
            std::string::npos)
      << printed;
  for (const auto* drive : {"a-drive", "b-drive", "c-drive"})
    EXPECT_TRUE(lab.starts_of(drive).empty()) << "commission moved " << drive;

  // A synchronized move of all three: a by its SYNC, b and c by their own RPDO1 (one start each,
  // planned by the coordinator from their drive models), every one at its target.
  const auto enabled = lab.call(Client::make(request_t::ENABLE, std::vector<std::string>{"a", "b", "c"}));
  ASSERT_EQ(enabled.status, st(reply_t::DONE)) << enabled.reason;
  const auto moved = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"a", 1.0}, {"b", -1.0}, {"c", 0.5}}));
  ASSERT_EQ(moved.status, st(reply_t::DONE)) << moved.reason;
  for (const auto* axis : {"a", "b", "c"})
    EXPECT_TRUE(lab.settled_at(axis,
                               std::string(axis) == "b"   ? -1.0
                               : std::string(axis) == "c" ? 0.5
                                                          : 1.0,
                               1e-9))
        << axis;
  for (const auto* drive : {"a-drive", "b-drive", "c-drive"}) EXPECT_EQ(lab.starts_of(drive).size(), 1u) << drive;
}

}  // namespace
}  // namespace motion::testing
