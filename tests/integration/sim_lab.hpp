// The simulated lab of config/sim-lab.yaml, started for one integration test: motion-sim, one
// gateway per bus and the coordinator on the test's own LCM URL and simulation directory, with a
// C++ client, the ground truth of the simulated drives (SIM_REPORT) and fault injection
// (SIM_CONTROL), and what the gateways said (EVENT, GW_REPLY). Every process is killed in the
// ProcessGroup's destructor.
// Thread contract: the test's thread only.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <algorithm>
#include <cmath>

#include <motionlcm/bus_stats_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>
#include <motionlcm/sim_control_t.hpp>
#include <motionlcm/sim_report_t.hpp>

#include "motion/client/client.hpp"
#include "motion/config/config.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/reply_error.hpp"
#include "motion/testing/process_group.hpp"

namespace motion::testing {

// The names every lab test uses.
using client::Client;
using motionlcm::event_t;
using motionlcm::reply_t;
using motionlcm::request_t;
using motionlcm::sim_control_t;
using std::chrono::milliseconds;
using std::chrono::seconds;

// LCM in-class constants are never ODR-used: tests copy them into values with these.
inline std::int8_t st(std::int8_t s) { return s; }
inline std::int16_t ev(std::int16_t k) { return k; }
inline std::int32_t code(ReplyError e) { return error_code(e); }
// Targets of a move request by axis name, in user units.
using Values = std::map<std::string, double>;

class SimLab {
 public:
  explicit SimLab(std::string config_path = source_path("config/sim-lab.yaml"))
      : config_path_(std::move(config_path)), client_(group_.loop(), group_.node(), "it-client") {
    auto loaded = config::load_file(config_path_);
    if (!loaded.ok()) throw std::runtime_error(loaded.error_text());
    config_ = *loaded.config;
    group_.node().subscribe<motionlcm::sim_report_t>(
        lcm::channels::kSimReport,
        [this](const motionlcm::sim_report_t& r, const std::string&) { reports_.push_back(r); });
    group_.node().subscribe<motionlcm::event_t>(
        lcm::channels::kEvent, [this](const motionlcm::event_t& e, const std::string&) { events_.push_back(e); });
    group_.node().subscribe<motionlcm::gateway_reply_t>(
        lcm::channels::kGatewayReply,
        [this](const motionlcm::gateway_reply_t& r, const std::string&) { gateway_replies_.push_back(r); });
  }

  [[nodiscard]] const std::string& config_path() const { return config_path_; }
  // Extra arguments of motion-sim (e.g. --simulate-uimessage), before start().
  void add_sim_args(std::vector<std::string> args) { sim_args_.insert(sim_args_.end(), args.begin(), args.end()); }
  // The gateway of `bus` (also to restart one a test killed).
  pid_t start_gateway(const std::string& bus) {
    return group_.start({"gateway:" + bus, "motion-gateway", {"--config", config_path_, "--bus", bus}, {}});
  }

  // Starts every process and waits for their heartbeats (DEGRADED accepted: a family without a
  // driver yet) and for `axes` to be online.
  [[nodiscard]] ::testing::AssertionResult start(const std::vector<std::string>& axes) {
    std::vector<std::string> sim_args{"--config", config_path_};
    sim_args.insert(sim_args.end(), sim_args_.begin(), sim_args_.end());
    group_.start({"sim", "motion-sim", sim_args, {}});
    for (const auto& bus : config_.buses) start_gateway(bus.name);
    group_.start({"coordinator", "motion-coordinator", {"--config", config_path_}, {}});
    // The coordinator accepts requests for a bus once it has heard that bus's gateway.
    std::vector<std::string> processes{"sim", "coordinator"};
    for (const auto& bus : config_.buses) processes.push_back("gateway:" + bus.name);
    for (const auto& name : processes) {
      if (!group_.wait_for_heartbeat(name, std::chrono::seconds(20), true))
        return ::testing::AssertionFailure() << "no heartbeat from " << name;
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
      for (const auto& axis : axes)
        failure << " " << axis << (client_.axes().contains(axis) ? "(state seen)" : "(no state)");
      return failure;
    }
    return ::testing::AssertionSuccess();
  }

  // Enables `axes` and waits until each of them reports it.
  [[nodiscard]] ::testing::AssertionResult enable(const std::vector<std::string>& axes) {
    const auto enabled = call(client::Client::make(motionlcm::request_t::ENABLE, axes));
    if (enabled.status != motionlcm::reply_t::DONE)
      return ::testing::AssertionFailure() << "ENABLE: " << enabled.reason;
    for (const auto& axis : axes) {
      if (!client_.wait_until([&] { return state(axis).enabled; }, std::chrono::seconds(10))) {
        return ::testing::AssertionFailure() << axis << " not enabled";
      }
    }
    return ::testing::AssertionSuccess();
  }

  // The last AXIS_STATE of `axis` (seen by start()).
  const motionlcm::axis_state_t& state(const std::string& axis) { return client_.axes().at(axis); }
  double position(const std::string& axis) { return state(axis).position; }
  // Waits until `axis` is at rest within `tolerance` (user units) of `where`.
  bool settled_at(const std::string& axis, double where, double tolerance,
                  std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
    return client_.wait_until([&] { return !state(axis).moving && std::abs(position(axis) - where) <= tolerance; },
                              timeout);
  }
  // Pumps the loop for `period` (lets a few status polls come in; asserts nothing about time).
  void pause(std::chrono::milliseconds period) {
    client_.wait_until([] { return false; }, period);
  }

  // An EVENT of `kind` for `axis` ("" = any) whose text contains `text`, seen so far.
  [[nodiscard]] bool has_event(std::int16_t kind, const std::string& axis, const std::string& text) const {
    return std::any_of(events_.begin(), events_.end(), [&](const motionlcm::event_t& e) {
      return e.kind == kind && (axis.empty() || e.axis == axis) && e.text.find(text) != std::string::npos;
    });
  }
  // The last STARTED a gateway sent (start mechanism, trigger time, predicted skew); null if none.
  [[nodiscard]] const motionlcm::gateway_reply_t* last_gateway_started() const {
    const auto it = std::find_if(
        gateway_replies_.rbegin(), gateway_replies_.rend(),
        [](const motionlcm::gateway_reply_t& r) { return r.status == motionlcm::gateway_reply_t::STARTED; });
    return it == gateway_replies_.rend() ? nullptr : &*it;
  }

  // Sends a request and waits for its terminal reply; `seen` collects every reply.
  motionlcm::reply_t call(motionlcm::request_t request, std::vector<motionlcm::reply_t>* seen = nullptr,
                          std::chrono::milliseconds timeout = std::chrono::seconds(30)) {
    return client_.call(std::move(request), timeout, [seen](const motionlcm::reply_t& r) {
      if (seen != nullptr) seen->push_back(r);
    });
  }

  void control(const std::string& drive, std::int8_t action, std::int32_t value = 0, std::int32_t level = 0) {
    publish_control(drive, {}, action, value, level);
  }
  // A bus-level SIM_CONTROL (e.g. LINE_NOISE on a serial line).
  void control_bus(const std::string& bus, std::int8_t action, std::int32_t value = 0, std::int32_t level = 0) {
    publish_control({}, bus, action, value, level);
  }
  // The statistics of `bus` in its gateway's last heartbeat; null before one carried them.
  [[nodiscard]] std::optional<motionlcm::bus_stats_t> bus_stats(const std::string& bus) const {
    const auto health = group_.heartbeat("gateway:" + bus);
    if (!health) return std::nullopt;
    const auto it = std::find_if(health->buses.begin(), health->buses.end(),
                                 [&](const motionlcm::bus_stats_t& b) { return b.name == bus; });
    if (it == health->buses.end()) return std::nullopt;
    return *it;
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
  // Every SIM_REPORT heard (starts, finishes, power-ups).
  [[nodiscard]] const std::vector<motionlcm::sim_report_t>& reports() const { return reports_; }

  // Every GW_REPLY heard, in order.
  [[nodiscard]] const std::vector<motionlcm::gateway_reply_t>& gateway_replies() const { return gateway_replies_; }

  client::Client& client() { return client_; }
  ProcessGroup& group() { return group_; }
  [[nodiscard]] const config::Config& config() const { return config_; }

 private:
  void publish_control(const std::string& drive, const std::string& bus, std::int8_t action, std::int32_t value,
                       std::int32_t level) {
    motionlcm::sim_control_t c{};
    c.utime = wall_time_us();
    c.drive = drive;
    c.bus = bus;
    c.action = action;
    c.value = value;
    c.level = level;
    group_.node().publish(lcm::channels::kSimControl, c);
  }

  std::string config_path_;
  std::vector<std::string> sim_args_;
  ProcessGroup group_;
  config::Config config_;
  client::Client client_;
  std::vector<motionlcm::sim_report_t> reports_;
  std::vector<motionlcm::event_t> events_;
  std::vector<motionlcm::gateway_reply_t> gateway_replies_;
};

}  // namespace motion::testing
