// The simulated lab of config/sim-lab.yaml, started for one integration test: motion-sim, one
// gateway per bus and the coordinator on the test's own LCM URL and simulation directory, with a
// C++ client, the ground truth of the simulated drives (SIM_REPORT) and fault injection
// (SIM_CONTROL). Every process is killed in the ProcessGroup's destructor.
// Thread contract: the test's thread only.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <string>
#include <vector>

#include <motionlcm/sim_control_t.hpp>
#include <motionlcm/sim_report_t.hpp>

#include "motion/client/client.hpp"
#include "motion/config/config.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/testing/process_group.hpp"

namespace motion::testing {

class SimLab {
 public:
  explicit SimLab(std::string config_path = source_path("config/sim-lab.yaml"))
      : config_path_(std::move(config_path)), client_(group_.loop(), group_.node(), "it-client") {
    auto loaded = config::load_file(config_path_);
    if (!loaded.ok()) throw std::runtime_error(loaded.error_text());
    config_ = *loaded.config;
    group_.node().subscribe<motionlcm::sim_report_t>(
        lcm::channels::kSimReport, [this](const motionlcm::sim_report_t& r, const std::string&) { reports_.push_back(r); });
  }

  // Starts every process and waits for their heartbeats (DEGRADED accepted: a family without a
  // driver yet) and for `axes` to be online.
  [[nodiscard]] ::testing::AssertionResult start(const std::vector<std::string>& axes) {
    group_.start({"sim", "motion-sim", {"--config", config_path_}, {}});
    for (const auto& bus : config_.buses) {
      group_.start({"gateway:" + bus.name, "motion-gateway", {"--config", config_path_, "--bus", bus.name}, {}});
    }
    group_.start({"coordinator", "motion-coordinator", {"--config", config_path_}, {}});
    // The coordinator accepts requests for a bus once it has heard that bus's gateway.
    std::vector<std::string> processes{"sim", "coordinator"};
    for (const auto& bus : config_.buses) processes.push_back("gateway:" + bus.name);
    for (const auto& name : processes) {
      if (!group_.wait_for_heartbeat(name, std::chrono::seconds(20), true)) return ::testing::AssertionFailure() << "no heartbeat from " << name;
    }
    // The coordinator says OK once it has heard every gateway.
    if (!group_.wait_for_heartbeat("coordinator", std::chrono::seconds(20))) {
      return ::testing::AssertionFailure() << "the coordinator never heard every gateway";
    }
    const bool online = client_.wait_until(
        [&] {
          for (const auto& axis : axes) {
            const auto it = client_.axes().find(axis);
            if (it == client_.axes().end() || !it->second.online) return false;
          }
          return true;
        },
        std::chrono::seconds(20));
    if (!online) {
      auto failure = ::testing::AssertionFailure() << "axes not online within 20 s:";
      for (const auto& axis : axes) failure << " " << axis << (client_.axes().contains(axis) ? "(state seen)" : "(no state)");
      return failure;
    }
    return ::testing::AssertionSuccess();
  }

  // Sends a request and waits for its terminal reply; `seen` collects every reply.
  motionlcm::reply_t call(motionlcm::request_t request, std::vector<motionlcm::reply_t>* seen = nullptr,
                          std::chrono::milliseconds timeout = std::chrono::seconds(30)) {
    return client_.call(std::move(request), timeout, [seen](const motionlcm::reply_t& r) {
      if (seen != nullptr) seen->push_back(r);
    });
  }

  void control(const std::string& drive, std::int8_t action, std::int32_t value = 0, std::int32_t level = 0) {
    motionlcm::sim_control_t c{};
    c.utime = wall_time_us();
    c.drive = drive;
    c.action = action;
    c.value = value;
    c.level = level;
    group_.node().publish(lcm::channels::kSimControl, c);
  }

  // MOTION_STARTED reports of `drive` seen so far.
  [[nodiscard]] std::vector<motionlcm::sim_report_t> starts_of(const std::string& drive) const {
    std::vector<motionlcm::sim_report_t> out;
    for (const auto& r : reports_) {
      if (r.drive == drive && r.kind == motionlcm::sim_report_t::MOTION_STARTED) out.push_back(r);
    }
    return out;
  }
  void clear_reports() { reports_.clear(); }

  client::Client& client() { return client_; }
  ProcessGroup& group() { return group_; }
  [[nodiscard]] const config::Config& config() const { return config_; }

 private:
  std::string config_path_;
  ProcessGroup group_;
  config::Config config_;
  client::Client client_;
  std::vector<motionlcm::sim_report_t> reports_;
};

}  // namespace motion::testing
