// Which of the coordinator's replies reach the page (README "Security"). With security.mode
// enforce and security.coordinator_public_key, only its signed replies (signed_message_t on
// SREPLY) that verify (security::MessageVerifier: the coordinator's key, the signature, the time
// window, a counter above the last) are shown as a request's progress or outcome: a plain REPLY
// (the coordinator sends each reply signed too) and a signed one that does not verify (forged,
// altered, stale, replayed) are not, so nobody on the lab network can make the page show a move
// as done, failed or rejected. Otherwise (mode off, or no coordinator key) the plain REPLYs.
//
// Thread contract: not thread-safe; motion-web calls it under the mutex that guards its LabView.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include <motionlcm/reply_t.hpp>
#include <motionlcm/signed_message_t.hpp>

#include "motion/config/config.hpp"
#include "motion/security/signed_messages.hpp"
#include "motion/web/lab_view.hpp"

namespace motion::web {

class ReplyGate {
 public:
  // From the configuration, for a receiver started at now_us (µs since the epoch: nothing signed
  // before it counts); the reason when security.coordinator_public_key cannot be read.
  [[nodiscard]] static std::variant<ReplyGate, std::string> from_config(const config::Config& config,
                                                                        std::int64_t now_us);

  // True: only signed replies count (listen on SREPLY); false: plain replies (REPLY).
  [[nodiscard]] bool verifies() const { return verifier_.has_value(); }

  // A plain REPLY into `view`: what goes to the browsers, nothing when verifying.
  [[nodiscard]] std::vector<Outgoing> on_plain(LabView& view, const motionlcm::reply_t& reply) const;
  // A signed reply into `view` when it verifies at now_us; else nothing, and refused() and
  // last_refusal() say so.
  [[nodiscard]] std::vector<Outgoing> on_signed(LabView& view, const motionlcm::signed_message_t& envelope,
                                                std::int64_t now_us);

  [[nodiscard]] std::uint64_t refused() const { return refused_; }
  [[nodiscard]] const std::string& last_refusal() const { return last_refusal_; }

 private:
  std::optional<security::MessageVerifier> verifier_;
  std::uint64_t refused_ = 0;
  std::string last_refusal_;
};

}  // namespace motion::web
