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
// reply, because its ids cannot be trusted. With a command signer, gateway commands go out
// signed on GW_SCOMMAND_<bus> instead of GW_COMMAND_<bus>, and its triggers, ACTIVE_MOVES, replies
// and events also go out signed (signed_message_t on SSYNC_TRIGGER, SSYNC_TRIGGER2, SACTIVE_MOVES,
// SREPLY, SEVENT); with mode enforce the plain triggers and ACTIVE_MOVES are not sent at all
// (gateways would refuse them), plain REPLY and EVENT still are (for observers and clients that
// do not verify). With mode enforce the coordinator takes what gateways publish (AXIS_STATE,
// GW_REPLY, DRIVE_MODEL, ORPHANED_MOVES, EVENT, HEALTH) only from their signed copies (signed_message_t on
// SAXIS_STATE, SGW_REPLY, SDRIVE_MODEL, SORPHANED_MOVES, SHEALTH, and GW_EVENT on SGW_EVENT) that verify
// against a key of role gateway in authorized_keys (counter per signer and bus; a key bound to
// buses speaks only for messages whose bus, and the configured bus of the axis or the command they
// name, are among them); a signed one that
// does not verify, or a plain GW_REPLY or ORPHANED_MOVES, is ignored and counted, with a SECURITY
// event (5 a second, then a count); plain AXIS_STATE, DRIVE_MODEL and EVENT (gateways send them
// for observers) are not looked at, nor is the plain HEALTH of a live gateway (the copy of its
// signed one: same host and pid); any other plain HEALTH claiming a gateway is refused like a plain
// GW_REPLY, so a forged heartbeat keeps no dead gateway's bus alive.
//
// Around each start it schedules (SYNC_TRIGGER2) the coordinator keeps quiet like the gateways
// (lcm/start_quiet.hpp): its replies, ACTIVE_MOVES, events and heartbeat published from just
// before the first bus's send time until just after the act time go out at its end. Gateway
// commands and triggers (GW_COMMAND*, GW_SCOMMAND_*, SYNC_TRIGGER*, SSYNC_TRIGGER*) are never
// held: a stop or the next move's trigger goes out at once.
//
// Thread contract: loop thread only. Never blocks.
#pragma once

#include <deque>
#include <string>
#include <vector>

#include "motion/config/config.hpp"
#include "motion/coordinator/coordinator.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/lcm/malformed_limiter.hpp"
#include "motion/lcm/node.hpp"
#include "motion/lcm/start_quiet.hpp"
#include "motion/security/gateway_commands.hpp"
#include "motion/security/request_verifier.hpp"
#include "motion/security/signed_messages.hpp"

namespace motion::coordinator {

class CoordinatorService final : private CoordinatorOutput {
 public:
  // What config.security gives the coordinator: the verifier of signed requests (none without
  // authorized_keys) and the signer of its gateway commands (none without key).
  struct Security {
    std::optional<security::RequestVerifier> verifier;
    std::optional<security::GatewayCommandSigner> command_signer;
    std::optional<security::MessageSigner> message_signer;  // with command_signer: the same key
    std::vector<security::Principal> gateway_keys;          // role gateway in authorized_keys
  };

  // `loop`, `node` and `config` must outlive the service. `security`: see load_security().
  CoordinatorService(EventLoop& loop, lcm::Node& node, const config::Config& config, MovePlanner planner,
                     Security security = {});

  // The Security of `config.security`: a verifier over authorized_keys (its channel prefix,
  // window_ms, and now as the start) and a signer with key, each when configured; or what is
  // wrong with a file (each error names the configuration key and file:line), including a key
  // and coordinator_public_key that are not one pair, and mode enforce without a gateway key.
  [[nodiscard]] static security::Loaded<Security> load_security(const config::Config& config);
  ~CoordinatorService() override;
  CoordinatorService(const CoordinatorService&) = delete;
  CoordinatorService& operator=(const CoordinatorService&) = delete;

  [[nodiscard]] std::size_t active_requests() const { return core_.active_requests(); }
  // The trigger lead a move of `buses` would get now (Coordinator::trigger_lead_us).
  [[nodiscard]] std::int64_t trigger_lead_us(const std::set<std::string>& buses) const {
    return core_.trigger_lead_us(buses);
  }
  // Buses whose gateway has not been heard within gateway_timeout_ms (see Coordinator).
  [[nodiscard]] std::vector<std::string> buses_without_gateway() const {
    return core_.buses_without_gateway(loop_.now());
  }
  [[nodiscard]] std::vector<std::string> axes_never_heard() const { return core_.axes_never_heard(); }
  // The coordinator's own heartbeat signed with security.key (signed_message_t on SHEALTH), when
  // it has one: the HealthPublisher's signed copy (coordinator/app/main.cpp).
  void sign_heartbeat(const motionlcm::health_t& health);
  // Gateway messages refused under enforce (plain, or signed but not verifying), reported or not.
  [[nodiscard]] std::uint64_t refused_gateway_messages() const { return gateway_refusals_.total(); }

 private:
  // Runs the core at the loop's now and re-arms the timer at the deadline it returns.
  void pump();
  void on_signed_request(const motionlcm::signed_request_t& envelope);
  // The reason a plain request is refused while security is enforced.
  [[nodiscard]] std::string unsigned_refusal(const std::string& what) const;
  // What gateways publish on `channel`: the plain message to `handler` in mode off; under enforce
  // only its signed copy that verifies against `gateway_keys`, and a plain one is refused when
  // `refuse_plain` (gateways send none) or not looked at (they send it too, for observers).
  template <typename Msg>
  void subscribe_gateway_channel(std::string_view channel, void (Coordinator::*handler)(const Msg&, TimePoint),
                                 const std::vector<security::Principal>& gateway_keys, bool refuse_plain);
  // HEALTH: to the core, except under enforce a heartbeat claiming to be a gateway's (those count
  // only signed, on SHEALTH): ignored, and refused unless it is the plain copy of a live gateway's.
  void on_plain_health(const motionlcm::health_t& health);
  // A gateway message refused under enforce: counted, and a SECURITY event (rate-limited).
  void refuse_gateway_message(const std::string& reason);

  void reply(const motionlcm::reply_t& reply) override;
  void gateway_command(const std::string& bus, const motionlcm::gateway_command2_t& command,
                       const motionlcm::gateway_command_t& counts) override;
  void sync_trigger(const motionlcm::sync_trigger_t& trigger) override;
  void sync_trigger2(const motionlcm::sync_trigger2_t& trigger) override;
  void active_moves(const motionlcm::active_moves_t& moves) override;
  void event(const motionlcm::event_t& event) override;
  void drive_model_request(const motionlcm::drive_model_request_t& request) override;

  EventLoop& loop_;
  lcm::Node& node_;
  Coordinator core_;
  bool enforce_ = false;
  int window_ms_ = 2000;  // config security.window_ms
  std::optional<security::RequestVerifier> verifier_;
  std::optional<security::GatewayCommandSigner> command_signer_;
  std::optional<security::MessageSigner> message_signer_;
  // Publishes `message` signed on S<channel> when there is a signer, and plain on <channel>
  // unless there is one, the mode is enforce and not `plain_under_enforce`.
  template <typename Msg>
  void publish_coordinator_message(std::string_view channel, const Msg& message, bool plain_under_enforce);
  std::deque<security::MessageVerifier> gateway_verifiers_;  // one per gateway channel (enforce)
  lcm::MalformedLimiter gateway_refusals_;                   // refused gateway messages (5 reported a second)
  EventLoop::TimerId timer_ = 0;
  TimePoint timer_deadline_ = kNever;
  lcm::StartQuiet start_quiet_{loop_, node_};  // around each start it schedules
};

}  // namespace motion::coordinator
