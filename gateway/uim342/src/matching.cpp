#include "motion/uim342/matching.hpp"

#include "motion/uim342/notifications.hpp"

namespace motion::uim342 {
namespace {
constexpr std::size_t kReportedControlWord = 2;  // d2 of an error report
}  // namespace

std::optional<ExpectedReply> ack_key(const Instruction& request) {
  const auto* forms = find_forms(request.function);
  if (!forms || forms->reply == Layout::kNone) return std::nullopt;
  if (request.operation == Operation::kSet && forms->set_ack != forms->function) {
    return ExpectedReply{forms->set_ack, forms->set_ack_index};
  }
  return ExpectedReply{request.function, request.sub_index()};
}

std::optional<ExpectedReply> expected_reply(const Instruction& request) {
  if (!request.ack_requested) return std::nullopt;
  return ack_key(request);
}

ReplyKind classify_reply(const Instruction& pending, const Message& incoming) {
  if (incoming.control_word == kNotificationControlWord) return ReplyKind::kNotification;
  if (incoming.ack_requested()) return ReplyKind::kUnrelated;
  const auto payload = incoming.payload();
  const auto expected = expected_reply(pending);
  const auto is_ack = [&] {
    if (!expected || incoming.control_word != code(expected->function)) return false;
    return !expected->sub_index || (!payload.empty() && payload[0] == *expected->sub_index);
  };
  if (incoming.control_word == code(FunctionCode::kER)) {
    if (pending.function == FunctionCode::kER && is_ack()) return ReplyKind::kAck;
    if (payload.size() > kReportedControlWord &&
        (payload[kReportedControlWord] & kFunctionCodeMask) == code(pending.function)) {
      return ReplyKind::kErrorReport;
    }
    return ReplyKind::kUnrelated;
  }
  return is_ack() ? ReplyKind::kAck : ReplyKind::kUnrelated;
}

}  // namespace motion::uim342
