#include "motion/app/service.hpp"

#include <spdlog/spdlog.h>

#include "motion/app/systemd.hpp"
#include "motion/lcm/message_names.hpp"

namespace motion::app {

Service::Service(const config::Config& config, const CommonOptions& options, std::string process, std::string role)
    : config_(config), process_(std::move(process)) {
  loop_.stop_on_signals();
  node_ = std::make_unique<lcm::Node>(loop_, lcm_options(options, config));
  health_ = std::make_unique<lcm::HealthPublisher>(loop_, *node_, process_, std::move(role));
}

int Service::run() {
  spdlog::info("{} running (LCM {}, prefix {})", process_, node_->url().empty() ? "<default>" : node_->url(),
               node_->prefix());
  notify_systemd();
  const auto errors = loop_.run();
  systemd::notify_stopping();
  health_->set_state(motionlcm::health_t::STOPPING, loop_.stop_signal() != 0 ? "signal" : "stopped");
  spdlog::info("{} stopped{}", process_, errors != 0 ? fmt::format(" ({} callback errors)", errors) : "");
  return kExitOk;
}

std::string Service::status_line() const {
  const std::string state = lcm::health_state_name(health_->state());
  return health_->detail().empty() ? state : state + ": " + health_->detail();
}

void Service::notify_systemd() {
  systemd::start_watchdog(loop_);
  if (!systemd::notify_socket_set()) return;
  // READY=1 at the loop's first turn: LCM is open, every subscription of the process was made
  // before run(), and the gateway has tried its bus once (its STATUS says open or what it waits for).
  loop_.call_after(Duration::zero(), [this] {
    status_sent_ = status_line();
    systemd::notify_ready(status_sent_);
  });
  // STATUS= follows the heartbeat's state and detail.
  loop_.call_every(std::chrono::milliseconds(500), [this] {
    if (auto status = status_line(); status != status_sent_) {
      status_sent_ = std::move(status);
      systemd::notify_status(status_sent_);
    }
  });
}

}  // namespace motion::app
