// Heartbeat publisher (health_t on <prefix>HEALTH every period) for every process. The detail
// it publishes is the one set_state() gave, followed by the node's counters of malformed LCM
// messages and handler errors when they are not zero ("...; 12 malformed LCM messages dropped").
// A process with a signing key (gateways, the coordinator: README "Security") also publishes a
// signed copy of every heartbeat through set_signed_copy(), just before the plain one.
// Thread contract: loop thread only.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <motionlcm/health_t.hpp>

#include "motion/core/event_loop.hpp"
#include "motion/lcm/node.hpp"

namespace motion::lcm {

class HealthPublisher {
 public:
  using BusStatsProvider = std::function<std::vector<motionlcm::bus_stats_t>()>;

  HealthPublisher(EventLoop& loop, Node& node, std::string process, std::string role,
                  std::chrono::milliseconds period = std::chrono::milliseconds(500));
  ~HealthPublisher();
  HealthPublisher(const HealthPublisher&) = delete;
  HealthPublisher& operator=(const HealthPublisher&) = delete;

  void set_state(std::int8_t state, std::string detail = {});
  void set_bus_stats(BusStatsProvider provider) { bus_stats_ = std::move(provider); }
  // Called with every heartbeat just before the plain one goes out (empty: none): it publishes
  // the signed copy (signed_message_t on SHEALTH). Whoever sets it clears it before it goes.
  using SignedCopy = std::function<void(const motionlcm::health_t&)>;
  void set_signed_copy(SignedCopy publish) { signed_copy_ = std::move(publish); }
  // Called with every heartbeat just after the plain one went out (empty: none): what a process
  // publishes beside its heartbeat at the same rate (a gateway's LEDGER_STATS). Whoever sets it
  // clears it before it goes.
  using Companion = std::function<void(const motionlcm::health_t&)>;
  void set_companion(Companion publish) { companion_ = std::move(publish); }
  // Publishes at once (state changes, and the last STOPPING heartbeat on shutdown).
  void publish_now();
  // What set_state() last gave (the process's own status: systemd's STATUS= line mirrors it).
  [[nodiscard]] std::int8_t state() const { return msg_.state; }
  [[nodiscard]] const std::string& detail() const { return detail_; }

  [[nodiscard]] static std::string detail_with_counters(const std::string& detail, std::uint64_t malformed,
                                                        std::uint64_t handler_errors);

 private:
  EventLoop& loop_;
  Node& node_;
  motionlcm::health_t msg_{};
  std::string detail_;
  TimePoint started_;
  EventLoop::TimerId timer_;
  BusStatsProvider bus_stats_;
  SignedCopy signed_copy_;
  Companion companion_;
};

}  // namespace motion::lcm
