// The skeleton of a long-running motion-* process: config loaded, one EventLoop, one LCM node,
// a heartbeat, SIGINT/SIGTERM for a clean stop (a last STOPPING heartbeat is published).
// Under systemd (Type=notify, motion/app/systemd.hpp) run() sends READY=1 at the loop's first
// turn, STATUS= lines mirroring the heartbeat's state and detail, WATCHDOG=1 from the loop when the
// unit sets WatchdogSec=, and STOPPING=1 when the loop ends.
#pragma once

#include <memory>
#include <string>

#include "motion/app/app.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/lcm/health.hpp"
#include "motion/lcm/node.hpp"

namespace motion::app {

class Service {
 public:
  // Opens LCM and starts the heartbeat. Check ok() (LCM URL refused).
  Service(const config::Config& config, const CommonOptions& options, std::string process, std::string role);

  [[nodiscard]] bool ok() const { return node_->ok(); }
  EventLoop& loop() { return loop_; }
  lcm::Node& node() { return *node_; }
  lcm::HealthPublisher& health() { return *health_; }
  const config::Config& config() const { return config_; }
  const std::string& process() const { return process_; }

  // Runs the loop until a signal or stop(); publishes STOPPING last. Returns an exit code.
  int run();

 private:
  [[nodiscard]] std::string status_line() const;  // the heartbeat's "ok: <detail>", "degraded: ..."
  void notify_systemd();

  const config::Config& config_;
  std::string process_;
  EventLoop loop_;
  std::unique_ptr<lcm::Node> node_;
  std::unique_ptr<lcm::HealthPublisher> health_;
  std::string status_sent_;  // the last STATUS= sent to systemd
};

}  // namespace motion::app
