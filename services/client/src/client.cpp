#include "motion/client/client.hpp"

#include <spdlog/spdlog.h>

#include "motion/lcm/channels.hpp"
#include "motion/lcm/message_names.hpp"
#include "motion/lcm/reply_error.hpp"
#include "motion/lcm/request_kinds.hpp"
#include "motion/lcm/wire_bounds.hpp"

namespace motion::client {

bool is_terminal(std::int8_t status) { return lcm::reply_is_terminal(status); }

const char* status_name(std::int8_t status) { return lcm::reply_status_name(status); }

Client::Client(EventLoop& loop, lcm::Node& node, std::string client_id)
    : loop_(loop), node_(node), id_(std::move(client_id)), next_request_id_(wall_time_us()) {
  // Request ids start at the wall clock so a restarted client never reuses a live id.
  node_.subscribe<motionlcm::reply_t>(lcm::channels::kReply, [this](const motionlcm::reply_t& r, const std::string&) {
    // While verifying, a plain REPLY is not a reply: the coordinator's own come signed on SREPLY
    // too (its plain copies are for clients that do not verify), so it is not counted either.
    if (!reply_verifier_) on_reply(r);
  });
  node_.subscribe<motionlcm::axis_state_t>(lcm::channels::kAxisState,
                                           [this](const motionlcm::axis_state_t& s, const std::string&) {
                                             // While verifying states only the signed copies count.
                                             if (!state_verifier_) take_state(s);
                                           });
  node_.subscribe<motionlcm::event_t>(lcm::channels::kEvent, [this](const motionlcm::event_t& e, const std::string&) {
    if (e.kind == motionlcm::event_t::SECURITY && !event_verifier_) on_security_event(e);
    if (event_handler_) event_handler_(e);
  });
}

void Client::verify_with(const security::PublicKey& coordinator, std::chrono::milliseconds window) {
  const bool subscribed = reply_verifier_.has_value();
  const std::int64_t now = wall_time_us();
  reply_verifier_.emplace(coordinator, node_.prefix(), std::string(lcm::channels::kReply), window, now);
  event_verifier_.emplace(coordinator, node_.prefix(), std::string(lcm::channels::kEvent), window, now);
  if (subscribed) return;
  node_.subscribe<motionlcm::signed_message_t>(
      security::signed_channel(lcm::channels::kReply),
      [this](const motionlcm::signed_message_t& m, const std::string&) {
        auto verified = reply_verifier_->verify<motionlcm::reply_t>(m, wall_time_us());
        if (verified.message) return on_reply(*verified.message);
        // What it claims to be, to tell whether it concerns this client.
        motionlcm::reply_t claimed;
        if (lcm::wire::decode_bounded(m.message.data(), m.message.size(), claimed).empty()) {
          forged_reply(claimed, verified.reason);
        }
      });
  node_.subscribe<motionlcm::signed_message_t>(
      security::signed_channel(lcm::channels::kEvent),
      [this](const motionlcm::signed_message_t& m, const std::string&) {
        auto verified = event_verifier_->verify<motionlcm::event_t>(m, wall_time_us());
        if (verified.message && verified.message->kind == motionlcm::event_t::SECURITY) {
          on_security_event(*verified.message);
        }
      });
}

void Client::verify_states_with(std::vector<security::Principal> gateways, std::chrono::milliseconds window) {
  const bool subscribed = state_verifier_.has_value();
  state_verifier_.emplace(std::move(gateways), "a gateway key", node_.prefix(), std::string(lcm::channels::kAxisState),
                          window, wall_time_us());
  axes_.clear();  // what was taken unverified
  if (subscribed) return;
  node_.subscribe<motionlcm::signed_message_t>(
      security::signed_channel(lcm::channels::kAxisState),
      [this](const motionlcm::signed_message_t& m, const std::string&) {
        auto verified = state_verifier_->verify<motionlcm::axis_state_t>(
            m, wall_time_us(), [](const motionlcm::axis_state_t& s) { return s.bus; });
        if (verified.message) return take_state(*verified.message);
        if (verified.authentic) {
          if (++stale_states_ <= 10) spdlog::info("an authentic axis state is ignored: {}", verified.reason);
          return;
        }
        if (++forged_states_ <= 10) spdlog::warn("SECURITY: an axis state is ignored: {}", verified.reason);
      });
}

void Client::take_state(const motionlcm::axis_state_t& s) {
  axes_[s.axis] = s;
  if (state_handler_) state_handler_(s);
}

void Client::on_reply(const motionlcm::reply_t& r) {
  if (r.client_id != id_) return;
  auto it = pending_.find(r.request_id);
  if (it == pending_.end()) return;
  it->second.heard = true;
  it->second.last_heard = loop_.now();
  auto handler = it->second.handler;  // copy: the handler may send further requests
  if (is_terminal(r.status)) pending_.erase(it);
  if (handler) handler(r);
}

void Client::forged_reply(const motionlcm::reply_t& r, const std::string& why) {
  if (r.client_id != id_ || !pending_.contains(r.request_id)) return;
  ++forged_replies_;
  if (forged_replies_ <= 10) {
    spdlog::warn("SECURITY: a {} reply to request {} is not the coordinator's and is ignored: {}",
                 status_name(r.status), r.request_id, why);
  }
}

void Client::sign_with(const security::KeyPair& key) {
  signer_.emplace(key, node_.prefix());
  id_ = signer_->own_client_id(id_);
}

std::string_view Client::request_channel() const {
  return signer_ ? lcm::channels::kSignedRequest : lcm::channels::kRequest;
}

void Client::on_security_event(const motionlcm::event_t& event) {
  std::vector<std::pair<ReplyHandler, motionlcm::reply_t>> refused;
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (event.text.find(it->second.label) == std::string::npos) {
      ++it;
      continue;
    }
    motionlcm::reply_t r{};
    r.utime = event.utime;
    r.client_id = id_;
    r.request_id = it->first;
    r.status = motionlcm::reply_t::REJECTED;
    r.error_code = error_code(ReplyError::kUnauthorized);
    r.reason = "refused by the coordinator's security (SECURITY event, no reply): " + event.text;
    refused.emplace_back(std::move(it->second.handler), std::move(r));
    it = pending_.erase(it);
  }
  for (const auto& [handler, reply] : refused) {
    if (handler) handler(reply);
  }
}

std::int64_t Client::send(motionlcm::request_t request, ReplyHandler on_reply) {
  request.client_id = id_;
  request.request_id = next_request_id_++;
  request.num_axes = static_cast<std::int32_t>(request.axes.size());
  request.values.resize(request.axes.size(), 0.0);
  const std::int64_t id = request.request_id;
  std::string label = lcm::request_label(request);
  Pending& p = pending_[id] = Pending{std::move(on_reply), std::move(label), std::move(request)};
  publish(p);
  return id;
}

void Client::publish(Pending& p) {
  p.request.utime = wall_time_us();
  p.last_heard = loop_.now();
  if (signer_) {
    node_.publish(lcm::channels::kSignedRequest, signer_->sign(p.request, p.request.utime));
  } else {
    node_.publish(lcm::channels::kRequest, p.request);
  }
}

bool Client::follow(std::int64_t id, const std::function<bool()>& done, std::chrono::milliseconds timeout) {
  return wait_until(
      [&] {
        if (done()) return true;
        if (const auto it = pending_.find(id); it != pending_.end()) {
          Pending& p = it->second;
          if (loop_.now() - p.last_heard >= (p.heard ? kQuietResend : kResendAfter)) {
            ++resent_;
            publish(p);
          }
        }
        return false;
      },
      timeout);
}

motionlcm::reply_t Client::call(motionlcm::request_t request, std::chrono::milliseconds timeout,
                                ReplyHandler on_progress) {
  motionlcm::reply_t result{};
  bool done = false;
  bool answered = false;
  const std::int64_t id = send(std::move(request), [&](const motionlcm::reply_t& r) {
    answered = true;
    if (is_terminal(r.status)) {
      result = r;
      done = true;
    } else if (on_progress) {
      on_progress(r);
    }
  });
  // The coordinator answers every request at once (ACCEPTED or REJECTED): silence means nobody
  // is listening, and the caller learns it within kAcceptTimeout rather than the whole timeout.
  const auto first_wait = std::min(timeout, kAcceptTimeout);
  const bool heard = follow(
      id, [&] { return answered; }, first_wait);
  if (!heard || !follow(
                    id, [&] { return done; }, timeout - first_wait)) {
    pending_.erase(id);
    result.client_id = id_;
    result.request_id = id;
    result.status = motionlcm::reply_t::FAILED;
    result.error_code = error_code(ReplyError::kTimeout);
    const std::string where = (node_.url().empty() ? std::string("the default LCM URL") : node_.url()) + ", channel " +
                              node_.channel(request_channel());
    result.reason = heard ? "no terminal reply from the coordinator within " + std::to_string(timeout.count()) +
                                " ms (" + where + ")"
                          : "no reply from the coordinator within " + std::to_string(first_wait.count()) +
                                " ms: is motion-coordinator running on " + where + "?";
  }
  return result;
}

bool Client::wait_until(const std::function<bool()>& done, std::chrono::milliseconds timeout) {
  const auto deadline = loop_.now() + timeout;
  while (!done()) {
    if (loop_.now() >= deadline || loop_.stopping()) return false;
    loop_.run_once(std::chrono::milliseconds(20));
  }
  return true;
}

motionlcm::request_t Client::make(std::int8_t kind, const std::map<std::string, double>& axis_values) {
  motionlcm::request_t r{};
  r.kind = kind;
  for (const auto& [axis, value] : axis_values) {
    r.axes.push_back(axis);
    r.values.push_back(value);
  }
  r.num_axes = static_cast<std::int32_t>(r.axes.size());
  return r;
}

motionlcm::request_t Client::make(std::int8_t kind, const std::vector<std::string>& axes) {
  motionlcm::request_t r{};
  r.kind = kind;
  r.axes = axes;
  r.values.assign(axes.size(), 0.0);
  r.num_axes = static_cast<std::int32_t>(r.axes.size());
  return r;
}

}  // namespace motion::client
