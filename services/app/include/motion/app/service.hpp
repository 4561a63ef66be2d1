// The skeleton of a long-running motion-* process: config loaded, one EventLoop, one LCM node,
// a heartbeat, SIGINT/SIGTERM for a clean stop (a last STOPPING heartbeat is published).
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
  const config::Config& config_;
  std::string process_;
  EventLoop loop_;
  std::unique_ptr<lcm::Node> node_;
  std::unique_ptr<lcm::HealthPublisher> health_;
};

}  // namespace motion::app
