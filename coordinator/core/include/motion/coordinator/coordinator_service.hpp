// The coordinator on the wire: the passive core (coordinator.hpp) driven by a process's
// EventLoop and LCM node. It subscribes REQUEST, SREQUEST, AXIS_STATE, GW_REPLY, EVENT and HEALTH
// and hands each message to the core with the loop's `now`; what the core sends goes out on
// REPLY, GW_COMMAND_<bus>, SYNC_TRIGGER, ACTIVE_MOVES and EVENT, stamped with wall_time_us().
// After every message, and at the deadline process() returned, the core runs what is due: one
// loop timer, re-armed at the next deadline.
//
// Security (config `security`, README "Security"): signed requests (signed_request_t on
// SREQUEST) pass the RequestVerifier, when there is one, at wall_time_us(); what it accepts goes
// to the core as a request, what it refuses to Coordinator::on_refused_request. Without a
// verifier (mode off, no authorized_keys) a signed request is unwrapped unverified. With mode
// enforce, a plain request_t on REQUEST (well-formed or not) is refused: a SECURITY event, no
// reply, because its ids cannot be trusted.
//
// Thread contract: loop thread only. Never blocks.
#pragma once

#include <string>
#include <vector>

#include "motion/config/config.hpp"
#include "motion/coordinator/coordinator.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/lcm/node.hpp"
#include "motion/security/request_verifier.hpp"

namespace motion::coordinator {

class CoordinatorService final : private CoordinatorOutput {
 public:
  // `loop`, `node` and `config` must outlive the service. `verifier`: see load_verifier().
  CoordinatorService(EventLoop& loop, lcm::Node& node, const config::Config& config, MovePlanner planner,
                     std::optional<security::RequestVerifier> verifier = std::nullopt);

  // The verifier of `config.security`: none when no authorized_keys file is configured, else one
  // over that file (its channel prefix, window_ms, and now as the start), or what is wrong with
  // the file or the coordinator's own key (each error names the configuration key and file:line).
  [[nodiscard]] static security::Loaded<std::optional<security::RequestVerifier>> load_verifier(const config::Config& config);
  ~CoordinatorService() override;
  CoordinatorService(const CoordinatorService&) = delete;
  CoordinatorService& operator=(const CoordinatorService&) = delete;

  [[nodiscard]] std::size_t active_requests() const { return core_.active_requests(); }
  // Buses whose gateway has not been heard within gateway_timeout_ms (see Coordinator).
  [[nodiscard]] std::vector<std::string> buses_without_gateway() const { return core_.buses_without_gateway(loop_.now()); }

 private:
  // Runs the core at the loop's now and re-arms the timer at the deadline it returns.
  void pump();
  void on_signed_request(const motionlcm::signed_request_t& envelope);
  // The reason a plain request is refused while security is enforced.
  [[nodiscard]] std::string unsigned_refusal(const std::string& what) const;

  void reply(const motionlcm::reply_t& reply) override;
  void gateway_command(const std::string& bus, const motionlcm::gateway_command_t& command) override;
  void sync_trigger(const motionlcm::sync_trigger_t& trigger) override;
  void active_moves(const motionlcm::active_moves_t& moves) override;
  void event(const motionlcm::event_t& event) override;

  EventLoop& loop_;
  lcm::Node& node_;
  Coordinator core_;
  bool enforce_ = false;
  std::optional<security::RequestVerifier> verifier_;
  EventLoop::TimerId timer_ = 0;
  TimePoint timer_deadline_ = kNever;
};

}  // namespace motion::coordinator
