// The C++ client of the motion system: send requests to the coordinator and follow their replies,
// watch axis state and events.
//
// Signing (README "Security"): after sign_with(key) every request goes out signed
// (signed_request_t on SREQUEST) under the key's own client id. A request the coordinator's
// security refuses without a reply (unsigned while enforced, unknown key, bad signature, replay,
// stale timestamp: its ids cannot be trusted, so none is sent) is named in a SECURITY event on
// EVENT (lcm::request_label); the client ends such a request of its own at once with a local
// REJECTED reply (kUnauthorized) carrying the event's text, instead of waiting for the timeout.
// Like any reply, such an event is not authenticated unless the client verifies: another
// process on the network could then fail a request this way, never make one succeed.
//
// Verifying (README "Security"): after verify_with(coordinator's public key) replies and
// SECURITY events count only when signed by the coordinator (signed_message_t on SREPLY and
// SEVENT, security::MessageVerifier: key, signature, window, counter, nothing signed before the
// client started). A plain REPLY is not a reply then (ignored: the coordinator publishes a plain
// copy of each of its replies for clients that do not verify), and a signed one for a pending
// request that does not verify is a forgery: the request goes on waiting, the forgery is counted
// (forged_replies()) and logged (the first 10). on_event() handlers still get the plain EVENTs
// of every process.
//
// Axis states (README "Security"): after verify_states_with(the gateway keys of authorized_keys)
// axes() and on_axis_state() take only states signed by a gateway key (signed_message_t on
// SAXIS_STATE; counter per key and bus); plain AXIS_STATEs are ignored, signed ones whose key or
// signature does not verify are counted (forged_states()), and authentic ones refused for their
// freshness are counted apart (stale_states(): a state in flight when verification began, signed
// before it, is one of them).
//
// Lost datagrams (README "Safety and faults"): LCM delivers nothing for sure. While call() or
// follow() waits on a request, the request is sent again, unchanged but for its send time (and
// signature), whenever nothing has been heard of it for kResendAfter (before its first reply) or
// kQuietResend (after): the coordinator answers a request sent again with its latest reply to it,
// word for word (ACCEPTED/STARTED/PROGRESS while it runs, its terminal reply once it ended), and
// runs nothing twice. So a lost request, a lost ACCEPTED or a lost terminal reply costs a
// fraction of a second, not the whole timeout.
//
// Thread contract: owned by one thread with its EventLoop. `call()` pumps that loop until the
// terminal reply (or the timeout), so callbacks keep running while it waits.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>

#include "motion/core/event_loop.hpp"
#include "motion/lcm/node.hpp"
#include "motion/security/signed_messages.hpp"
#include "motion/security/signed_request.hpp"

namespace motion::client {

[[nodiscard]] bool is_terminal(std::int8_t status);
[[nodiscard]] const char* status_name(std::int8_t status);

class Client {
 public:
  using ReplyHandler = std::function<void(const motionlcm::reply_t&)>;

  Client(EventLoop& loop, lcm::Node& node, std::string client_id);

  // From now on requests are signed with `key` and sent on SREQUEST; id() becomes the key's own
  // client id (RequestSigner::own_client_id). Call it before the first send().
  void sign_with(const security::KeyPair& key);
  [[nodiscard]] bool signing() const { return signer_.has_value(); }

  // From now on only replies and SECURITY events signed with `coordinator` count (see above);
  // `window`: config security.window_ms. Call it before the first send().
  void verify_with(const security::PublicKey& coordinator, std::chrono::milliseconds window);
  [[nodiscard]] bool verifying() const { return reply_verifier_.has_value(); }
  // Signed replies for this client's pending requests that did not verify (see above).
  [[nodiscard]] std::uint64_t forged_replies() const { return forged_replies_; }
  // From now on only axis states signed with one of `gateways` count (see above), a key bound to
  // buses (Principal::buses) for states of those buses only.
  // (security::load_gateway_keys reads them from authorized_keys or gateway_public_keys.)
  void verify_states_with(std::vector<security::Principal> gateways, std::chrono::milliseconds window);
  [[nodiscard]] bool verifying_states() const { return state_verifier_.has_value(); }
  // Signed axis states whose key is no gateway's or whose signature does not verify.
  [[nodiscard]] std::uint64_t forged_states() const { return forged_states_; }
  // Authentic axis states refused all the same: signed before verification began or outside the
  // window, replayed, undecodable, or of a bus their key may not speak for.
  [[nodiscard]] std::uint64_t stale_states() const { return stale_states_; }

  // Fills utime/client_id/request_id/num_axes and publishes; replies go to `on_reply`.
  std::int64_t send(motionlcm::request_t request, ReplyHandler on_reply = {});
  // Sends and waits for the terminal reply. Returns a local FAILED reply (error code 13,
  // timeout) naming the LCM URL and channel when no reply at all comes within kAcceptTimeout (no
  // coordinator listening) or no terminal one within `timeout`.
  static constexpr std::chrono::milliseconds kAcceptTimeout{2000};
  // The default wait for a request's terminal reply (motionctl's --timeout default): long enough
  // for a move across an axis's whole travel or a homing run.
  static constexpr std::chrono::milliseconds kRequestTimeout{60000};
  motionlcm::reply_t call(motionlcm::request_t request, std::chrono::milliseconds timeout,
                          ReplyHandler on_progress = {});

  // Latest state of every axis heard so far.
  [[nodiscard]] const std::map<std::string, motionlcm::axis_state_t>& axes() const { return axes_; }
  void on_axis_state(std::function<void(const motionlcm::axis_state_t&)> handler) {
    state_handler_ = std::move(handler);
  }
  void on_event(std::function<void(const motionlcm::event_t&)> handler) { event_handler_ = std::move(handler); }
  // Pumps the loop until `done()` or the timeout; false on timeout.
  bool wait_until(const std::function<bool()>& done, std::chrono::milliseconds timeout);
  // wait_until(), sending request `id` (of send()) again while it is pending and nothing has been
  // heard of it for a while (see "Lost datagrams" above).
  static constexpr std::chrono::milliseconds kResendAfter{500};
  static constexpr std::chrono::milliseconds kQuietResend{1000};
  bool follow(std::int64_t id, const std::function<bool()>& done, std::chrono::milliseconds timeout);
  // Requests sent again by follow() so far.
  [[nodiscard]] std::uint64_t resent() const { return resent_; }

  [[nodiscard]] const std::string& id() const { return id_; }

  // Request builders.
  static motionlcm::request_t make(std::int8_t kind, const std::map<std::string, double>& axis_values);
  static motionlcm::request_t make(std::int8_t kind, const std::vector<std::string>& axes);

 private:
  EventLoop& loop_;
  lcm::Node& node_;
  std::string id_;
  std::int64_t next_request_id_;
  struct Pending {
    ReplyHandler handler;
    std::string label;  // lcm::request_label: how a SECURITY event names it
    motionlcm::request_t request;
    TimePoint last_heard{};  // sent (again), or a reply heard
    bool heard = false;      // a reply to it heard
  };
  // Signs (when signing) and publishes `p.request`, stamped now.
  void publish(Pending& p);
  // A SECURITY event naming pending requests of this client: their local REJECTED replies.
  void on_security_event(const motionlcm::event_t& event);
  // A reply taken as the coordinator's: to its pending request's handler.
  void on_reply(const motionlcm::reply_t& reply);
  // A reply for this client that is not the coordinator's (why): counted and logged, else ignored.
  void forged_reply(const motionlcm::reply_t& reply, const std::string& why);
  void take_state(const motionlcm::axis_state_t& state);
  // The channel requests go out on.
  [[nodiscard]] std::string_view request_channel() const;

  std::optional<security::RequestSigner> signer_;
  std::optional<security::MessageVerifier> reply_verifier_;  // SREPLY
  std::optional<security::MessageVerifier> event_verifier_;  // SEVENT
  std::uint64_t forged_replies_ = 0;
  std::optional<security::MessageVerifier> state_verifier_;  // SAXIS_STATE (gateway keys)
  std::uint64_t forged_states_ = 0;
  std::uint64_t stale_states_ = 0;
  std::uint64_t resent_ = 0;
  std::map<std::int64_t, Pending> pending_;
  std::map<std::string, motionlcm::axis_state_t> axes_;
  std::function<void(const motionlcm::axis_state_t&)> state_handler_;
  std::function<void(const motionlcm::event_t&)> event_handler_;
};

}  // namespace motion::client
