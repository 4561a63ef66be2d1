// motionctl commission on the simulated UIM242 line (configs/uim242-two.yaml): every set-up value
// the gateway applied reads back as configured (exit 0); a value changed behind the gateway's back
// is named as a contradiction with what to do (exit 1). Nothing moves.
#include <gtest/gtest.h>

#include <motionlcm/param_t.hpp>

#include "sim_lab.hpp"

namespace motion::testing {
namespace {

TEST(Commission, ReadsBackTheSetUpAndNamesAContradiction) {
  SimLab lab(source_path("tests/integration/configs/uim242-two.yaml"));
  ASSERT_TRUE(lab.start({"u1", "u2"}));
  const std::vector<std::string> args{"--config", lab.config_path(), "commission", "rs232"};
  std::string printed;
  ASSERT_EQ(lab.group().run_to_completion({"commission", "motionctl", args, {}}, &printed, std::chrono::seconds(30)), 0) << printed;
  EXPECT_NE(printed.find("u1-drive (uim242, node 5)\n  ICFG: 0\n  MCS micro-steps: 16 (as configured)"), std::string::npos) << printed;
  EXPECT_NE(printed.find("u2-drive (uim242, node 6)"), std::string::npos) << printed;

  request_t write = Client::make(request_t::PARAM_WRITE, std::vector<std::string>{"u1"});
  write.param.space = motionlcm::param_t::UIM242_INSTRUCTION;
  write.param.mnemonic = "MCS";
  write.param.value = 8;
  const auto written = lab.call(write);
  ASSERT_EQ(written.status, st(reply_t::DONE)) << written.reason;
  printed.clear();
  EXPECT_EQ(lab.group().run_to_completion({"commission-2", "motionctl", args, {}}, &printed, std::chrono::seconds(30)), 1) << printed;
  EXPECT_NE(printed.find("MCS micro-steps: 8 CONTRADICTS the configuration (16)"), std::string::npos) << printed;
  EXPECT_TRUE(lab.starts_of("u1-drive").empty()) << "commission moved an axis";
  EXPECT_TRUE(lab.starts_of("u2-drive").empty()) << "commission moved an axis";
}

}  // namespace
}  // namespace motion::testing
