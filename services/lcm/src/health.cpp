#include "motion/lcm/health.hpp"

#include <unistd.h>

#include "motion/core/version.hpp"
#include "motion/lcm/channels.hpp"

namespace motion::lcm {
namespace {
std::string host_name() {
  char buf[256] = {};
  if (::gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}
}  // namespace

HealthPublisher::HealthPublisher(EventLoop& loop, Node& node, std::string process, std::string role,
                                 std::chrono::milliseconds period)
    : loop_(loop), node_(node), started_(loop.now()) {
  msg_.process = std::move(process);
  msg_.role = std::move(role);
  msg_.host = host_name();
  msg_.pid = static_cast<std::int32_t>(::getpid());
  msg_.version = std::string(kVersion);
  msg_.state = motionlcm::health_t::STARTING;
  msg_.period_ms = static_cast<std::int32_t>(period.count());
  timer_ = loop_.call_every(period, [this] { publish_now(); });
}

HealthPublisher::~HealthPublisher() { loop_.cancel(timer_); }

void HealthPublisher::set_state(std::int8_t state, std::string detail) {
  const bool changed = state != msg_.state || detail != detail_;
  msg_.state = state;
  detail_ = std::move(detail);
  if (changed) publish_now();
}

std::string HealthPublisher::detail_with_counters(const std::string& detail, std::uint64_t malformed,
                                                  std::uint64_t handler_errors) {
  std::string out = detail;
  const auto append = [&out](std::uint64_t n, const char* what) {
    if (n == 0) return;
    out += (out.empty() ? "" : "; ") + std::to_string(n) + what;
  };
  append(malformed, " malformed LCM messages dropped");
  append(handler_errors, " LCM handler errors");
  return out;
}

void HealthPublisher::publish_now() {
  msg_.utime = wall_time_us();
  msg_.uptime_s = std::chrono::duration<double>(loop_.now() - started_).count();
  msg_.buses = bus_stats_ ? bus_stats_() : std::vector<motionlcm::bus_stats_t>{};
  msg_.num_buses = static_cast<std::int32_t>(msg_.buses.size());
  msg_.detail = detail_with_counters(detail_, node_.malformed_count(), node_.handler_errors());
  if (signed_copy_) signed_copy_(msg_);
  node_.publish(channels::kHealth, msg_);
  if (companion_) companion_(msg_);
}

}  // namespace motion::lcm
