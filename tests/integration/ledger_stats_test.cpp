// LEDGER_STATS end to end: a real gateway on a simulated bus publishes its command ledger's counters
// with every heartbeat, and they count what a move did (a move of two axes: two parts accepted,
// armed, started and done, none left); motionctl status --ledger shows the same figures. Once on a
// CAN bus (UC57, the CAN bus driver summing its stacks) and once on a serial line (UIM242).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <motionlcm/ledger_stats_t.hpp>

#include "sim_lab.hpp"

namespace motion::testing {
namespace {

struct LedgerCase {
  const char* name;
  const char* config;
  const char* bus;
  const char* axis1;
  const char* axis2;
  double target1, target2;
};

class LedgerStats : public ::testing::TestWithParam<LedgerCase> {};

TEST_P(LedgerStats, AMoveOfTwoAxesIsTwoPartsThroughEveryStageAndMotionctlShowsThem) {
  const auto& p = GetParam();
  SimLab lab(source_path(std::string("tests/integration/configs/") + p.config));
  std::vector<motionlcm::ledger_stats_t> heard;
  lab.group().node().subscribe<motionlcm::ledger_stats_t>(lcm::channels::kLedgerStats,
                                                          [&](const motionlcm::ledger_stats_t& m, const std::string&) {
                                                            if (m.bus == p.bus) heard.push_back(m);
                                                          });
  ASSERT_TRUE(lab.start({p.axis1, p.axis2}));
  ASSERT_TRUE(lab.enable({p.axis1, p.axis2}));
  // The next LEDGER_STATS of the bus published from now on.
  const auto next = [&] {
    const std::size_t before = heard.size();
    EXPECT_TRUE(lab.client().wait_until([&] { return heard.size() > before; }, seconds(5))) << "no LEDGER_STATS";
    return heard.empty() ? motionlcm::ledger_stats_t{} : heard.back();
  };
  const auto before = next();
  EXPECT_EQ(before.process, std::string("gateway:") + p.bus);
  EXPECT_GE(before.done, 2) << "the ENABLE of both axes";

  const auto moved =
      lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{p.axis1, p.target1}, {p.axis2, p.target2}}));
  ASSERT_EQ(moved.status, st(reply_t::DONE)) << moved.reason;
  const auto after = next();
  EXPECT_EQ(after.accepted - before.accepted, 2);
  EXPECT_EQ(after.armed - before.armed, 2);
  EXPECT_EQ(after.started - before.started, 2);
  EXPECT_EQ(after.done - before.done, 2);
  EXPECT_EQ(after.failed - before.failed, 0);
  EXPECT_EQ(after.stopped - before.stopped, 0);
  EXPECT_EQ(
      after.now_loading + after.now_armed + after.now_started + after.now_done + after.now_failed + after.now_stopped,
      0);
  EXPECT_EQ(after.refused_transitions + after.refused_terminals + after.refused_adds, 0);
  std::printf(
      "[ ledger %s ] after the move: accepted %lld, armed %lld, started %lld, done %lld, failed %lld, "
      "stopped %lld, repeats answered %lld, released %lld\n",
      p.bus, static_cast<long long>(after.accepted), static_cast<long long>(after.armed),
      static_cast<long long>(after.started), static_cast<long long>(after.done), static_cast<long long>(after.failed),
      static_cast<long long>(after.stopped), static_cast<long long>(after.repeats_answered),
      static_cast<long long>(after.released));

  // motionctl status --ledger, as text and JSON: the figures as published (nothing ran since).
  std::string text;
  ASSERT_EQ(lab.group().run_to_completion(
                {"status-ledger", "motionctl", {"--config", lab.config_path(), "status", "--ledger"}, {}}, &text,
                seconds(20)),
            0)
      << text;
  char total[200];
  std::snprintf(total, sizeof total,
                "  parts total   accepted %lld, armed %lld, started %lld, done %lld, failed %lld, stopped %lld",
                static_cast<long long>(after.accepted), static_cast<long long>(after.armed),
                static_cast<long long>(after.started), static_cast<long long>(after.done),
                static_cast<long long>(after.failed), static_cast<long long>(after.stopped));
  EXPECT_NE(text.find(total), std::string::npos) << total << "\n" << text;
  EXPECT_NE(text.find("  parts now     loading 0, armed 0, started 0, done 0, failed 0, stopped 0"), std::string::npos)
      << text;
  std::string json_text;
  ASSERT_EQ(
      lab.group().run_to_completion(
          {"status-ledger-json", "motionctl", {"--config", lab.config_path(), "--json", "status", "--ledger"}, {}},
          &json_text, seconds(20)),
      0)
      << json_text;
  const auto first = json_text.find('{');
  const auto last = json_text.rfind('}');
  ASSERT_TRUE(first != std::string::npos && last != std::string::npos) << json_text;
  const auto doc = nlohmann::json::parse(json_text.substr(first, last - first + 1), nullptr, false);
  ASSERT_TRUE(doc.is_object() && doc.contains(p.bus) && doc[p.bus].is_object()) << json_text;
  const auto& bus = doc[p.bus];
  EXPECT_EQ(bus["process"], std::string("gateway:") + p.bus);
  EXPECT_EQ(bus["total"]["done"], after.done) << json_text;
  EXPECT_EQ(bus["total"]["accepted"], after.accepted) << json_text;
  EXPECT_EQ(bus["now"]["started"], 0) << json_text;
  EXPECT_EQ(bus["repeats_answered"], after.repeats_answered) << json_text;
}

INSTANTIATE_TEST_SUITE_P(Buses, LedgerStats,
                         ::testing::Values(LedgerCase{"Uc57Can", "uc57-three.yaml", "can0", "a", "b", 45.0, -30.0},
                                           LedgerCase{"Uim242Serial", "uim242-two.yaml", "rs232", "u1", "u2", 2.0,
                                                      -1.5}),
                         [](const ::testing::TestParamInfo<LedgerCase>& c) { return std::string(c.param.name); });

}  // namespace
}  // namespace motion::testing
