// Matching drive frames to a pending request (manual §2.1, §2.3, §2.4, §5). Key a pending request
// by (node ID, expected reply); this header covers the part that depends on the frame content only
// — the producer check (which node answered) is the caller's, because a group or global request is
// answered by every addressed drive and only the caller knows group membership.
// Thread contract: pure functions, thread-safe.
#pragma once

#include <cstdint>
#include <optional>

#include "motion/uim342/instructions.hpp"
#include "motion/uim342/message.hpp"

namespace motion::uim342 {

// The reply that acknowledges a request: its CW (bit 7 clear) and, for sub-indexed replies, the
// sub-index echoed in d0. JV=/SP= -> DV with d0 = 2, PR= -> d0 = 3, PA= -> d0 = 4.
struct ExpectedReply {
  FunctionCode function{};
  std::optional<std::uint8_t> sub_index;
  friend bool operator==(const ExpectedReply&, const ExpectedReply&) = default;
};

// The ACK the drive sends when bit 7 is set. nullopt for SY (never answered) and unknown codes;
// the ACK bit itself is not looked at (see expects_ack).
[[nodiscard]] std::optional<ExpectedReply> ack_key(const Instruction& request);
// ack_key when the request asked for an ACK, else nullopt (only error reports can follow; not
// stated in §2.1, assumed).
[[nodiscard]] std::optional<ExpectedReply> expected_reply(const Instruction& request);

enum class ReplyKind : std::uint8_t {
  kAck,           // the ACK of the pending request (only when it asked for one)
  kErrorReport,   // CW 0x0F whose d2 (bit 7 masked) is the request's function code
  kNotification,  // CW 0x5A: unsolicited, may arrive between a request and its ACK
  kUnrelated,     // anything else (another request's reply, a malformed frame, ...)
};

// Classifies a frame from the drive the request was sent to. For a pending ER[i] request, a CW 0x0F
// frame with d0 = i is taken as its ACK (ER ACKs and error reports share the layout; a report
// concerning ER itself has d2 = 0x0F/0x8F and a d0 other than i).
[[nodiscard]] ReplyKind classify_reply(const Instruction& pending, const Message& incoming);

}  // namespace motion::uim342
