// Two UIM342 drives behind a simulated UIROBOT UIM2513 serial gateway (a `uimessage:` bus; motion-sim
// --simulate-uimessage links its pty at the bus's device path), under both readings of the
// UIMessage CRC coverage (docs/protocols.md, UIMessage row 1): the simulated gateway checks the
// CRC over `simulation.variants.<bus>.crc_bytes` (13: SM..d8, the manual's text; 12: ID..d8) and
// drops every frame whose CRC is wrong. With `uimessage_crc: detect` (the default) the gateway
// process starts with 13 and must find 12 by itself (its first frames are dropped), say so in an
// INFO CONFIG_MISMATCH event and in its bus statistics; with the coverage configured it is
// trusted. Either way a synchronized move (group BG) lands both shafts exactly on their targets,
// judged by the simulated drives' own reports (SIM_REPORT).
#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <tuple>

#include "motion/testing/temp_dir.hpp"
#include "sim_lab.hpp"

namespace motion::testing {
namespace {

using motionlcm::sim_report_t;

std::int8_t report_kind(std::int8_t k) { return k; }

// The lab's configuration with the gateway's pty at `device`.
std::string lab_yaml(const std::string& device, const std::string& crc_bytes, const std::string& uimessage_crc) {
  return "lcm: {url: \"udpm://239.255.76.67:7667?ttl=0\", channel_prefix: \"MOTION_\"}\n"
         "buses:\n"
         "  - {name: gw, transport: \"uimessage:" +
         device + "\", baud: 115200, uimessage_crc: " + uimessage_crc +
         ", request_timeout_ms: 50, retries: 2, poll_hz: 20}\n"
         "drives:\n"
         "  - {name: x-drive, family: uim342, bus: gw, node_id: 5, group_id: 20,\n"
         "     setup: {micro_steps: 16, current_a: 2.0, acceleration_unit: rate}}\n"
         "  - {name: y-drive, family: uim342, bus: gw, node_id: 6, group_id: 20,\n"
         "     setup: {micro_steps: 16, current_a: 2.0, acceleration_unit: rate}}\n"
         "axes:\n"
         "  - {name: x, drive: x-drive, unit: mm, steps_per_unit: 640,\n"
         "     limits: {min: -50, max: 300, velocity: 50, acceleration: 400}}\n"
         "  - {name: y, drive: y-drive, unit: mm, steps_per_unit: 640,\n"
         "     limits: {min: -50, max: 300, velocity: 50, acceleration: 400}}\n"
         "coordinator: {default_timeout_ms: 60000, progress_period_ms: 200, trigger_lead_ms: 30, "
         "gateway_timeout_ms: 1500}\n"
         "simulation:\n"
         "  reply_latency_us: 200\n"
         "  variants:\n"
         "    gw: {crc_bytes: " +
         crc_bytes + "}\n";
}

std::string write_config(const TempDir& dir, const std::string& crc_bytes, const std::string& uimessage_crc) {
  const std::string path = (dir.path() / "uimessage-lab.yaml").string();
  std::ofstream(path) << lab_yaml((dir.path() / "uim2513.tty").string(), crc_bytes, uimessage_crc);
  return path;
}

// (the simulated gateway's crc_bytes, the configuration's uimessage_crc)
class UiMessageLab : public ::testing::TestWithParam<std::tuple<std::string, std::string>> {
 protected:
  UiMessageLab() : lab(write_config(dir, std::get<0>(GetParam()), std::get<1>(GetParam()))) {
    lab.add_sim_args({"--simulate-uimessage"});
  }
  void TearDown() override {
    if (HasFailure()) lab.group().print_logs();
  }
  std::vector<sim_report_t> reports_of(const std::string& drive, std::int8_t kind) const {
    std::vector<sim_report_t> out;
    for (const auto& r : lab.reports()) {
      if (r.drive == drive && r.kind == kind) out.push_back(r);
    }
    return out;
  }

  TempDir dir{"uimessage-lab"};
  SimLab lab;
};

TEST_P(UiMessageLab, SynchronizedMoveLandsExactlyUnderEitherCrcCoverage) {
  const auto& [crc_bytes, configured] = GetParam();
  ASSERT_TRUE(lab.start({"x", "y"}));
  ASSERT_TRUE(lab.enable({"x", "y"}));

  // What the gateway process uses and how it knows.
  const bool detect = configured == "detect";
  const std::string coverage = crc_bytes == "12" ? "ID..d8 (12 bytes)" : "SM..d8 (13 bytes)";
  // (A heartbeat sent before the drives answered still says "not known yet": wait for a newer one.)
  const std::string expected = "CRC " + coverage + (detect ? ", detected" : ", configured");
  const auto transport_now = [&] { return lab.bus_stats("gw") ? lab.bus_stats("gw")->transport : std::string{}; };
  EXPECT_TRUE(lab.client().wait_until([&] { return transport_now().find(expected) != std::string::npos; }, seconds(10)))
      << transport_now();
  const std::string transport = transport_now();
  EXPECT_EQ(lab.has_event(ev(event_t::CONFIG_MISMATCH), "", "the gateway's CRC covers " + coverage), detect)
      << "detection is reported (only when detecting)";

  // 25 mm and 12.5 mm started together by one group BG: 16,000 and 8,000 counts.
  lab.clear_reports();
  const auto moved = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", 25.0}, {"y", 12.5}}));
  ASSERT_EQ(moved.status, st(reply_t::DONE)) << moved.reason;
  ASSERT_TRUE(lab.settled_at("x", 25.0, 1e-9));
  ASSERT_TRUE(lab.settled_at("y", 12.5, 1e-9));
  const auto x_starts = reports_of("x-drive", report_kind(sim_report_t::MOTION_STARTED));
  const auto y_starts = reports_of("y-drive", report_kind(sim_report_t::MOTION_STARTED));
  ASSERT_EQ(x_starts.size(), 1u);
  ASSERT_EQ(y_starts.size(), 1u);
  EXPECT_EQ(x_starts[0].frame_utime, y_starts[0].frame_utime) << "not started by one frame";
  ASSERT_TRUE(lab.client().wait_until(
      [&] {
        return !reports_of("x-drive", report_kind(sim_report_t::MOTION_FINISHED)).empty() &&
               !reports_of("y-drive", report_kind(sim_report_t::MOTION_FINISHED)).empty();
      },
      seconds(10)));
  EXPECT_EQ(reports_of("x-drive", report_kind(sim_report_t::MOTION_FINISHED)).back().position_counts, 16000);
  EXPECT_EQ(reports_of("y-drive", report_kind(sim_report_t::MOTION_FINISHED)).back().position_counts, 8000);
  const auto* started = lab.last_gateway_started();
  ASSERT_NE(started, nullptr);
  EXPECT_EQ(started->start_mechanism, "group-bg");
  // motionctl commission says it too.
  const std::vector<std::string> args{"--config", lab.config_path(), "commission", "gw"};
  std::string printed;
  EXPECT_EQ(lab.group().run_to_completion({"commission", "motionctl", args, {}}, &printed, seconds(30)), 0) << printed;
  EXPECT_NE(printed.find("bus gw: UIMessage CRC " + coverage + (detect ? ", detected" : ", configured")),
            std::string::npos)
      << printed;
  std::printf("crc_bytes %s, uimessage_crc %s: bus gw %s; %lld errors counted\n", crc_bytes.c_str(), configured.c_str(),
              transport.c_str(), static_cast<long long>(lab.bus_stats("gw")->errors));
}

INSTANTIATE_TEST_SUITE_P(CrcCoverages, UiMessageLab,
                         ::testing::Values(std::make_tuple("13", "detect"), std::make_tuple("12", "detect"),
                                           std::make_tuple("13", "13"), std::make_tuple("12", "12")),
                         [](const auto& param_info) {
                           return "Gateway" + std::get<0>(param_info.param) + "Config" + std::get<1>(param_info.param);
                         });

}  // namespace
}  // namespace motion::testing
