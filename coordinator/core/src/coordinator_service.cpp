#include "motion/coordinator/coordinator_service.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <span>
#include <type_traits>

#include "motion/lcm/channels.hpp"
#include "motion/lcm/request_kinds.hpp"

namespace motion::coordinator {

security::Loaded<CoordinatorService::Security> CoordinatorService::load_security(const config::Config& config) {
  const auto& settings = config.security;
  Security out;
  if (!settings.key.empty()) {
    auto key = security::load_private_key(settings.key);
    if (auto* error = std::get_if<std::string>(&key)) return "security.key: " + *error;
    const auto& pair = std::get<security::KeyPair>(key);
    if (!settings.coordinator_public_key.empty()) {
      // What the gateways will verify with must be this key's public half.
      auto published = security::load_public_key(settings.coordinator_public_key);
      if (auto* error = std::get_if<std::string>(&published)) return "security.coordinator_public_key: " + *error;
      if (std::get<security::PublicKey>(published) != pair.public_key()) {
        return "security.key (" + settings.key + ") and security.coordinator_public_key (" +
               settings.coordinator_public_key + ") are not one key pair: gateways would refuse every command";
      }
    }
    out.command_signer.emplace(pair, config.lcm.channel_prefix);
    out.message_signer.emplace(pair, config.lcm.channel_prefix);
  }
  if (!settings.authorized_keys.empty()) {
    auto keys = security::AuthorizedKeys::load(settings.authorized_keys);
    if (auto* error = std::get_if<std::string>(&keys)) return "security.authorized_keys: " + *error;
    auto& authorized = std::get<security::AuthorizedKeys>(keys);
    out.gateway_keys = authorized.with_role(security::Role::kGateway);
    out.verifier.emplace(std::move(authorized), config.lcm.channel_prefix,
                         std::chrono::milliseconds(settings.window_ms), wall_time_us());
  }
  if (settings.mode == config::SecuritySettings::Mode::kEnforce && out.gateway_keys.empty()) {
    return "security.authorized_keys (" + settings.authorized_keys +
           ") has no key with role gateway: under security.mode enforce every axis state and gateway reply would "
           "be refused (add the public half of security.gateway_key, e.g. motionctl keygen --name gateway --role "
           "gateway)";
  }
  return out;
}

CoordinatorService::CoordinatorService(EventLoop& loop, lcm::Node& node, const config::Config& config,
                                       MovePlanner planner, Security security)
    : loop_(loop),
      node_(node),
      core_(config, std::move(planner), *this),
      enforce_(config.security.mode == config::SecuritySettings::Mode::kEnforce),
      window_ms_(config.security.window_ms),
      verifier_(std::move(security.verifier)),
      command_signer_(std::move(security.command_signer)),
      message_signer_(std::move(security.message_signer)) {
  using motionlcm::request_t;
  // What must reach the gateways on time is never held by a quiet interval (start_quiet_).
  for (const std::string& commands : {lcm::channels::gateway_command(""), lcm::channels::gateway_command2(""),
                                      lcm::channels::signed_gateway_command("")}) {
    node_.publish_at_once(commands);
  }
  // A prefix: SYNC_TRIGGER covers SYNC_TRIGGER2 too, SSYNC_TRIGGER its signed channels.
  node_.publish_at_once(lcm::channels::kSyncTrigger);
  node_.publish_at_once(security::signed_channel(lcm::channels::kSyncTrigger));
  node_.subscribe<request_t>(
      lcm::channels::kRequest,
      [this](const request_t& m, const std::string&) {
        if (enforce_) {
          core_.on_refused_request(std::nullopt, unsigned_refusal(lcm::request_label(m)), loop_.now());
        } else {
          core_.on_request(m, loop_.now());
        }
        pump();
      },
      [this](const void* data, int size, const std::string& why) {
        if (enforce_) {
          core_.on_refused_request(std::nullopt, unsigned_refusal("malformed request (" + why + ")"), loop_.now());
        } else {
          const auto n = static_cast<std::size_t>(size > 0 ? size : 0);
          core_.on_malformed_request(std::span<const std::uint8_t>(static_cast<const std::uint8_t*>(data), n), why,
                                     loop_.now());
        }
        pump();
      });
  node_.subscribe<motionlcm::signed_request_t>(
      lcm::channels::kSignedRequest,
      [this](const motionlcm::signed_request_t& m, const std::string&) {
        on_signed_request(m);
        pump();
      },
      [this](const void*, int, const std::string& why) {
        core_.on_refused_request(std::nullopt, "malformed signed request refused: " + why, loop_.now());
        pump();
      });
  // Under enforce gateways still send plain AXIS_STATE, DRIVE_MODEL, ARM_TIMING and TRIGGER_HEARD for
  // observers: not looked at.
  subscribe_gateway_channel(lcm::channels::kAxisState, &Coordinator::on_axis_state, security.gateway_keys, false);
  subscribe_gateway_channel(lcm::channels::kGatewayReply, &Coordinator::on_gateway_reply, security.gateway_keys, true);
  if (enforce_) {
    // Gateways' events only signed with a gateway key (GW_EVENT on SGW_EVENT); plain EVENTs, sent
    // too for observers, are not looked at.
    subscribe_gateway_channel(lcm::channels::kGatewayEvent, &Coordinator::on_event, security.gateway_keys, false);
  } else {
    node_.subscribe<motionlcm::event_t>(lcm::channels::kEvent, [this](const motionlcm::event_t& m, const std::string&) {
      core_.on_event(m, loop_.now());
      pump();
    });
  }
  node_.subscribe<motionlcm::health_t>(lcm::channels::kHealth,
                                       [this](const motionlcm::health_t& m, const std::string&) {
                                         on_plain_health(m);
                                         pump();
                                       });
  // Under enforce a gateway's liveness comes from its signed heartbeats only (SHEALTH).
  if (enforce_)
    subscribe_gateway_channel(lcm::channels::kHealth, &Coordinator::on_health, security.gateway_keys, false);
  subscribe_gateway_channel(lcm::channels::kDriveModel, &Coordinator::on_drive_model, security.gateway_keys, false);
  subscribe_gateway_channel(lcm::channels::kArmTiming, &Coordinator::on_arm_timing, security.gateway_keys, false);
  subscribe_gateway_channel(lcm::channels::kLineTiming, &Coordinator::on_line_timing, security.gateway_keys, false);
  subscribe_gateway_channel(lcm::channels::kTriggerHeard, &Coordinator::on_trigger_heard, security.gateway_keys, false);
  subscribe_gateway_channel(lcm::channels::kOrphanedMoves, &Coordinator::on_orphaned_moves, security.gateway_keys,
                            true);
  // A malformed request cannot be answered (its ids are unreadable): say so loudly on EVENT.
  node_.on_malformed([this](const std::string& what) {
    spdlog::warn("{}", what);
    core_.on_malformed_message(what, loop_.now());
    pump();
  });
  pump();
}

namespace {

// What a refusal says a gateway message claimed to be, and the stream its counter is kept in (its
// bus: gateways of several buses may share one key, each signing with its own clock).
std::string label(const motionlcm::axis_state_t& m) { return "axis " + m.axis + " of bus " + m.bus; }
std::string label(const motionlcm::gateway_reply_t& m) {
  return "reply to command " + std::to_string(m.command_id) + " of bus " + m.bus;
}
std::string label(const motionlcm::drive_model_t& m) { return "model of axis " + m.axis + " of bus " + m.bus; }
std::string label(const motionlcm::arm_timing_t& m) { return "arming time of axis " + m.axis + " of bus " + m.bus; }
std::string label(const motionlcm::line_timing_t& m) { return "line timing of bus " + m.bus; }
std::string label(const motionlcm::trigger_heard_t& m) {
  return "hearing of trigger " + std::to_string(m.trigger_id) + " on bus " + m.bus;
}
std::string label(const motionlcm::active_moves_t& m) { return std::to_string(m.num_axes) + " rows"; }
std::string label(const motionlcm::event_t& m) { return "event of " + m.source; }
std::string label(const motionlcm::health_t& m) {
  return "heartbeat of " + m.process + ", pid " + std::to_string(m.pid) + " on " + m.host;
}
std::string stream(const motionlcm::axis_state_t& m) { return m.bus; }
std::string stream(const motionlcm::event_t& m) { return m.bus; }
std::string stream(const motionlcm::gateway_reply_t& m) { return m.bus; }
std::string stream(const motionlcm::drive_model_t& m) { return m.bus; }
std::string stream(const motionlcm::arm_timing_t& m) { return m.bus; }
std::string stream(const motionlcm::trigger_heard_t& m) { return m.bus; }
std::string stream(const motionlcm::line_timing_t& m) { return m.bus; }
// A gateway's heartbeat names its bus in its process name, "gateway:<bus>".
std::string stream(const motionlcm::health_t& m) {
  return m.process.rfind("gateway:", 0) == 0 ? m.process.substr(8) : m.process;
}
std::string stream(const motionlcm::active_moves_t& m) { return m.buses.empty() ? std::string() : m.buses.front(); }

// The buses a gateway message speaks for, checked against the buses its key is bound to: the bus
// it names, and the one this configuration gives the axis (or the command) it concerns, so that a
// message naming its key's bus but another bus's axis is no way around the binding.
void add(std::vector<std::string>& buses, const std::optional<std::string>& bus) {
  if (bus && std::find(buses.begin(), buses.end(), *bus) == buses.end()) buses.push_back(*bus);
}
template <typename Msg>
std::vector<std::string> axis_buses(const Coordinator& core, const Msg& m) {
  std::vector<std::string> out{m.bus};
  if (!m.axis.empty()) add(out, core.bus_of_axis(m.axis));
  return out;
}
std::vector<std::string> buses(const Coordinator& core, const motionlcm::axis_state_t& m) {
  return axis_buses(core, m);
}
std::vector<std::string> buses(const Coordinator& core, const motionlcm::drive_model_t& m) {
  return axis_buses(core, m);
}
std::vector<std::string> buses(const Coordinator& core, const motionlcm::arm_timing_t& m) {
  return axis_buses(core, m);
}
std::vector<std::string> buses(const Coordinator&, const motionlcm::trigger_heard_t& m) { return {m.bus}; }
std::vector<std::string> buses(const Coordinator&, const motionlcm::line_timing_t& m) { return {m.bus}; }
std::vector<std::string> buses(const Coordinator& core, const motionlcm::event_t& m) { return axis_buses(core, m); }
std::vector<std::string> buses(const Coordinator& core, const motionlcm::gateway_reply_t& m) {
  std::vector<std::string> out{m.bus};
  add(out, core.bus_of_command(m.command_id));
  return out;
}
std::vector<std::string> buses(const Coordinator& core, const motionlcm::active_moves_t& m) {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < m.buses.size(); ++i) {
    add(out, m.buses[i]);
    if (i < m.axes.size()) add(out, core.bus_of_axis(m.axes[i]));
  }
  return out;
}
std::vector<std::string> buses(const Coordinator&, const motionlcm::health_t& m) { return {stream(m)}; }

bool claims_gateway(const motionlcm::health_t& m) { return m.role == "gateway" || m.process.rfind("gateway:", 0) == 0; }
// What a signed heartbeat claims before it is verified (one that does not decode is a gateway's to
// refuse as malformed).
bool claims_gateway(const motionlcm::signed_message_t& envelope) {
  motionlcm::health_t claimed;
  return !lcm::wire::decode_bounded(envelope.message.data(), envelope.message.size(), claimed).empty() ||
         claims_gateway(claimed);
}

}  // namespace

template <typename Msg>
void CoordinatorService::subscribe_gateway_channel(std::string_view channel,
                                                   void (Coordinator::*handler)(const Msg&, TimePoint),
                                                   const std::vector<security::Principal>& gateway_keys,
                                                   bool refuse_plain) {
  if (enforce_ && !refuse_plain) {
    // Sent plain too, for observers: not looked at (only the signed copy counts).
  } else {
    node_.subscribe<Msg>(channel, [this, channel, handler](const Msg& m, const std::string&) {
      if (enforce_) {
        refuse_gateway_message("unsigned " + std::string(channel) + " (" + label(m) +
                               ") refused: security is enforced, it must be signed with a gateway key (" +
                               node_.channel(security::signed_channel(channel)) + ")");
      } else {
        (core_.*handler)(m, loop_.now());
      }
      pump();
    });
  }
  if (!enforce_) return;  // mode off: the plain copies count (gateways send both)
  auto& verifier =
      gateway_verifiers_.emplace_back(gateway_keys, "a key of role gateway in authorized_keys", node_.prefix(),
                                      std::string(channel), std::chrono::milliseconds(window_ms_), wall_time_us());
  node_.subscribe<motionlcm::signed_message_t>(
      security::signed_channel(channel),
      [this, &verifier, handler](const motionlcm::signed_message_t& envelope, const std::string&) {
        if constexpr (std::is_same_v<Msg, motionlcm::health_t>) {
          // SHEALTH also carries the heartbeats other processes sign (this coordinator's own, with
          // its key): only those claiming a gateway are a gateway's to verify.
          if (!claims_gateway(envelope)) return;
        }
        auto verified = verifier.verify<Msg>(
            envelope, wall_time_us(), [](const Msg& m) { return stream(m); },
            [this](const Msg& m) { return buses(core_, m); });
        if (verified.message) {
          (core_.*handler)(*verified.message, loop_.now());
        } else {
          refuse_gateway_message(verified.reason);
        }
        pump();
      },
      [this, channel](const void*, int, const std::string& why) {
        refuse_gateway_message("malformed signed " + std::string(channel) + " refused: " + why);
        pump();
      });
}

void CoordinatorService::on_plain_health(const motionlcm::health_t& health) {
  if (!enforce_ || !claims_gateway(health)) return core_.on_health(health, loop_.now());
  // The plain copy a live gateway sends beside its signed heartbeat, for observers, is not looked
  // at; any other plain heartbeat claiming a gateway (one that stopped signing, or a forger keeping
  // a dead gateway's bus "alive") is refused and reported.
  if (core_.is_live_gateways_heartbeat(health, loop_.now())) return;
  refuse_gateway_message("unsigned HEALTH (" + label(health) +
                         ") refused: security is enforced, a gateway is alive only by its heartbeats signed with a "
                         "gateway key (" +
                         node_.channel(security::signed_channel(lcm::channels::kHealth)) + ")");
}

void CoordinatorService::sign_heartbeat(const motionlcm::health_t& health) {
  if (message_signer_) {
    node_.publish(security::signed_channel(lcm::channels::kHealth),
                  message_signer_->sign(lcm::channels::kHealth, health, wall_time_us()));
  }
}

void CoordinatorService::refuse_gateway_message(const std::string& reason) {
  // A flood of forged states must not become a flood of events: 5 a second, then a count.
  const TimePoint now = loop_.now();
  const std::uint64_t suppressed = gateway_refusals_.take_summary(now);
  if (!gateway_refusals_.admit(now)) return;
  core_.on_refused_message(suppressed == 0 ? reason
                                           : reason + " (and " + std::to_string(suppressed) +
                                                 " more refusals not reported, at most 5 a second)",
                           now);
}

void CoordinatorService::on_signed_request(const motionlcm::signed_request_t& envelope) {
  if (!verifier_) {
    // Mode off without authorized_keys: nobody to check the signature against; the request is
    // taken as a plain one would be.
    motionlcm::request_t request;
    const std::string why = lcm::wire::decode_bounded(envelope.payload.data(), envelope.payload.size(), request);
    if (why.empty()) {
      core_.on_request(request, loop_.now());
    } else {
      core_.on_malformed_request(envelope.payload, "signed request's payload: " + why, loop_.now());
    }
    return;
  }
  security::Verdict verdict = verifier_->verify(envelope, wall_time_us());
  if (verdict.accepted) {
    core_.on_request(*verdict.request, loop_.now());
  } else {
    core_.on_refused_request(verdict.answerable ? verdict.request : std::nullopt,
                             "signed request refused: " + verdict.reason, loop_.now());
  }
}

std::string CoordinatorService::unsigned_refusal(const std::string& what) const {
  return "unsigned request refused: security is enforced (" + what +
         "; sign it with a key of authorized_keys and send it on " + node_.channel(lcm::channels::kSignedRequest) + ")";
}

CoordinatorService::~CoordinatorService() {
  if (timer_ != 0) loop_.cancel(timer_);
}

void CoordinatorService::pump() {
  const TimePoint deadline = core_.process(loop_.now());
  if (timer_ != 0 && deadline == timer_deadline_) return;
  if (timer_ != 0) loop_.cancel(timer_);
  timer_ = 0;
  timer_deadline_ = deadline;
  if (deadline == kNever) return;
  timer_ = loop_.call_at(deadline, [this] {
    timer_ = 0;
    pump();
  });
}

template <typename Msg>
void CoordinatorService::publish_coordinator_message(std::string_view channel, const Msg& message,
                                                     bool plain_under_enforce) {
  if (!message_signer_ || !enforce_ || plain_under_enforce) node_.publish(channel, message);
  if (message_signer_)
    node_.publish(security::signed_channel(channel), message_signer_->sign(channel, message, wall_time_us()));
}

void CoordinatorService::reply(const motionlcm::reply_t& reply) {
  publish_coordinator_message(lcm::channels::kReply, reply, true);
}

// Every command goes out as gateway_command2_t (grid integers): on GW_COMMAND2_<bus>, or signed on
// GW_SCOMMAND_<bus>.
void CoordinatorService::gateway_command(const std::string& bus, const motionlcm::gateway_command2_t& command,
                                         const motionlcm::gateway_command_t& /*counts*/) {
  if (command_signer_) {
    node_.publish(lcm::channels::signed_gateway_command(bus), command_signer_->sign(command, wall_time_us()));
  } else {
    node_.publish(lcm::channels::gateway_command2(bus), command);
  }
}

void CoordinatorService::sync_trigger(const motionlcm::sync_trigger_t& trigger) {
  publish_coordinator_message(lcm::channels::kSyncTrigger, trigger, false);
}
void CoordinatorService::sync_trigger2(const motionlcm::sync_trigger2_t& trigger) {
  publish_coordinator_message(lcm::channels::kSyncTrigger2, trigger, false);
  start_quiet_.keep(trigger);
}

void CoordinatorService::active_moves(const motionlcm::active_moves_t& moves) {
  publish_coordinator_message(lcm::channels::kActiveMoves, moves, false);
}

void CoordinatorService::event(const motionlcm::event_t& event) {
  publish_coordinator_message(lcm::channels::kEvent, event, true);
}

void CoordinatorService::drive_model_request(const motionlcm::drive_model_request_t& request) {
  node_.publish(lcm::channels::kDriveModelRequest, request);
}

}  // namespace motion::coordinator
