#include "motion/coordinator/coordinator_service.hpp"

#include <spdlog/spdlog.h>

#include <span>

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
    out.verifier.emplace(std::move(std::get<security::AuthorizedKeys>(keys)), config.lcm.channel_prefix,
                         std::chrono::milliseconds(settings.window_ms), wall_time_us());
  }
  return out;
}

CoordinatorService::CoordinatorService(EventLoop& loop, lcm::Node& node, const config::Config& config,
                                       MovePlanner planner, Security security)
    : loop_(loop),
      node_(node),
      core_(config, std::move(planner), *this),
      enforce_(config.security.mode == config::SecuritySettings::Mode::kEnforce),
      verifier_(std::move(security.verifier)),
      command_signer_(std::move(security.command_signer)),
      message_signer_(std::move(security.message_signer)) {
  using motionlcm::request_t;
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
  node_.subscribe<motionlcm::axis_state_t>(lcm::channels::kAxisState,
                                           [this](const motionlcm::axis_state_t& m, const std::string&) {
                                             core_.on_axis_state(m, loop_.now());
                                             pump();
                                           });
  node_.subscribe<motionlcm::gateway_reply_t>(lcm::channels::kGatewayReply,
                                              [this](const motionlcm::gateway_reply_t& m, const std::string&) {
                                                core_.on_gateway_reply(m, loop_.now());
                                                pump();
                                              });
  node_.subscribe<motionlcm::event_t>(lcm::channels::kEvent, [this](const motionlcm::event_t& m, const std::string&) {
    core_.on_event(m, loop_.now());
    pump();
  });
  node_.subscribe<motionlcm::health_t>(lcm::channels::kHealth,
                                       [this](const motionlcm::health_t& m, const std::string&) {
                                         core_.on_health(m, loop_.now());
                                         pump();
                                       });
  node_.subscribe<motionlcm::drive_model_t>(lcm::channels::kDriveModel,
                                            [this](const motionlcm::drive_model_t& m, const std::string&) {
                                              core_.on_drive_model(m, loop_.now());
                                              pump();
                                            });
  node_.subscribe<motionlcm::arm_timing_t>(lcm::channels::kArmTiming,
                                           [this](const motionlcm::arm_timing_t& m, const std::string&) {
                                             core_.on_arm_timing(m, loop_.now());
                                             pump();
                                           });
  node_.subscribe<motionlcm::active_moves_t>(lcm::channels::kOrphanedMoves,
                                             [this](const motionlcm::active_moves_t& m, const std::string&) {
                                               core_.on_orphaned_moves(m, loop_.now());
                                               pump();
                                             });
  // A malformed request cannot be answered (its ids are unreadable): say so loudly on EVENT.
  node_.on_malformed([this](const std::string& what) {
    spdlog::warn("{}", what);
    core_.on_malformed_message(what, loop_.now());
    pump();
  });
  pump();
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

void CoordinatorService::gateway_command(const std::string& bus, const motionlcm::gateway_command_t& command) {
  if (command_signer_) {
    node_.publish(lcm::channels::signed_gateway_command(bus), command_signer_->sign(command, wall_time_us()));
  } else {
    node_.publish(lcm::channels::gateway_command(bus), command);
  }
}

void CoordinatorService::sync_trigger(const motionlcm::sync_trigger_t& trigger) {
  publish_coordinator_message(lcm::channels::kSyncTrigger, trigger, false);
}
void CoordinatorService::sync_trigger2(const motionlcm::sync_trigger2_t& trigger) {
  publish_coordinator_message(lcm::channels::kSyncTrigger2, trigger, false);
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
