#include "motion/app/service.hpp"

#include <spdlog/spdlog.h>

namespace motion::app {

Service::Service(const config::Config& config, const CommonOptions& options, std::string process, std::string role)
    : config_(config), process_(std::move(process)) {
  loop_.stop_on_signals();
  node_ = std::make_unique<lcm::Node>(loop_, lcm_options(options, config));
  health_ = std::make_unique<lcm::HealthPublisher>(loop_, *node_, process_, std::move(role));
}

int Service::run() {
  spdlog::info("{} running (LCM {}, prefix {})", process_, node_->url().empty() ? "<default>" : node_->url(), node_->prefix());
  const auto errors = loop_.run();
  health_->set_state(motionlcm::health_t::STOPPING, loop_.stop_signal() != 0 ? "signal" : "stopped");
  spdlog::info("{} stopped{}", process_, errors != 0 ? fmt::format(" ({} callback errors)", errors) : "");
  return kExitOk;
}

}  // namespace motion::app
