// The UIM242 crawl start in the drive model (docs/protocols.md UIM242 #3): two UIM242s behind a
// simulated UIM2501 whose controllers run a displacement loaded at speed 0 at once
// (`simulation.variants: spd0_position_move: runs_at_last_speed`, and the same answer in the
// set-up, so the gateway knows it from the start). Their drive models list the crawl
// (START_UIM242_CRAWL with its line time), the coordinator's schedule (SYNC_TRIGGER2
// predicted_spread_us) includes it, and the spread of the simulated drives' own starts
// (SIM_REPORT) lies within it.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <string>

#include <motionlcm/drive_model_request_t.hpp>
#include <motionlcm/drive_model_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>

#include "motion/testing/temp_dir.hpp"
#include "sim_lab.hpp"

namespace motion::testing {
namespace {

using motionlcm::drive_model_t;
using motionlcm::sim_report_t;

std::string write_config(const TempDir& dir) {
  std::ifstream base(source_path("tests/integration/configs/uim242-two.yaml"));
  std::string yaml((std::istreambuf_iterator<char>(base)), std::istreambuf_iterator<char>());
  for (const std::string drive : {"u1-drive", "u2-drive"}) {
    const std::string from = drive + ", family: uim242, bus: rs232, node_id: ";
    const auto at = yaml.find("setup: {micro_steps: 16", yaml.find(from));
    yaml.insert(at + 8, "spd0_position_move: runs_at_last_speed, ");
  }
  yaml +=
      "  variants:\n    u1-drive: {spd0_position_move: runs_at_last_speed}\n"
      "    u2-drive: {spd0_position_move: runs_at_last_speed}\n";
  const std::string path = (dir.path() / "uim242-crawl.yaml").string();
  std::ofstream(path) << yaml;
  return path;
}

class Uim242Crawl : public ::testing::Test {
 protected:
  Uim242Crawl() : lab(write_config(dir)) {
    lab.group().node().subscribe<drive_model_t>(
        lcm::channels::kDriveModel, [this](const drive_model_t& m, const std::string&) { models[m.axis] = m; });
    lab.group().node().subscribe<motionlcm::sync_trigger2_t>(
        lcm::channels::kSyncTrigger2,
        [this](const motionlcm::sync_trigger2_t& t, const std::string&) { triggers.push_back(t); });
  }
  void TearDown() override {
    if (HasFailure()) lab.group().print_logs();
  }
  [[nodiscard]] std::optional<double> crawl_us(const std::string& axis) const {
    const auto it = models.find(axis);
    if (it == models.end()) return std::nullopt;
    for (std::size_t i = 0; i < it->second.start_kinds.size(); ++i) {
      if (it->second.start_kinds[i] == std::int8_t{drive_model_t::START_UIM242_CRAWL})
        return it->second.start_wire_us[i];
    }
    return std::nullopt;
  }

  TempDir dir{"uim242-crawl"};
  SimLab lab;
  std::map<std::string, drive_model_t> models;
  std::vector<motionlcm::sync_trigger2_t> triggers;
};

TEST_F(Uim242Crawl, TheDriveModelCarriesTheCrawlAndThePredictedSpreadIncludesIt) {
  ASSERT_TRUE(lab.start({"u1", "u2"}));
  ASSERT_TRUE(lab.enable({"u1", "u2"}));
  motionlcm::drive_model_request_t ask{};
  ask.utime = wall_time_us();
  ask.requester = "uim242-crawl-test";
  lab.group().node().publish(lcm::channels::kDriveModelRequest, ask);
  ASSERT_TRUE(lab.client().wait_until([&] { return crawl_us("u1") && crawl_us("u2"); }, seconds(10)))
      << "no START_UIM242_CRAWL in the drive models";
  EXPECT_GT(*crawl_us("u1"), 0.0);

  lab.clear_reports();
  const auto moved = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"u1", 10.0}, {"u2", 5.0}}));
  ASSERT_EQ(moved.status, st(reply_t::DONE)) << moved.reason;
  ASSERT_TRUE(lab.settled_at("u1", 10.0, 1e-9));
  ASSERT_TRUE(lab.settled_at("u2", 5.0, 1e-9));
  const auto u1 = lab.starts_of("u1-drive");
  const auto u2 = lab.starts_of("u2-drive");
  ASSERT_FALSE(u1.empty());
  ASSERT_FALSE(u2.empty());
  const double actual_us = std::abs(static_cast<double>(u1.front().frame_utime - u2.front().frame_utime));
  ASSERT_FALSE(triggers.empty());
  const double predicted_us = triggers.back().predicted_spread_us;
  const auto* started = lab.last_gateway_started();
  ASSERT_NE(started, nullptr);
  // (Two speeds: each axis gets its own SPD after the crawls.)
  EXPECT_EQ(started->start_mechanism.rfind("crawl_", 0), 0u) << started->start_mechanism;
  // The schedule's spread is the two crawls' line time (a bound: the first axis starts during its
  // own crawl); the simulated starts lie within it.
  EXPECT_DOUBLE_EQ(predicted_us, *crawl_us("u1") + *crawl_us("u2"));
  EXPECT_GT(actual_us, 0.0) << "the crawls start the axes one after the other";
  EXPECT_LE(actual_us, predicted_us);
  std::printf(
      "crawl start: simulated starts %.0f us apart; coordinator predicted %.0f us (crawls %.0f + %.0f us); "
      "gateway STARTED skew %.0f us\n",
      actual_us, predicted_us, *crawl_us("u1"), *crawl_us("u2"), started->predicted_skew_us);
}

}  // namespace
}  // namespace motion::testing
