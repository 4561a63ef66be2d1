#include "motion/adam/slave.hpp"

#include <variant>

namespace motion::adam {
namespace {

ServeResult outcome_only(ServeOutcome outcome) {
  ServeResult result;
  result.outcome = outcome;
  return result;
}

ServeResult refuse(std::uint8_t unit, std::uint8_t function, rtu::ExceptionCode code, const SlaveConfig& config,
                   std::optional<rtu::Request> request) {
  ServeResult result;
  result.request = std::move(request);
  result.exception = code;
  if (unit == rtu::kBroadcastUnit) {
    result.outcome = ServeOutcome::kRejectedSilently;
    return result;
  }
  result.outcome = ServeOutcome::kException;
  if (config.exceptions == ExceptionMode::kStandard) result.reply = rtu::encode_exception(unit, function, code);
  return result;
}

}  // namespace

ServeResult serve(std::span<const std::uint8_t> frame, const SlaveConfig& config, RegisterBank& bank) {
  const rtu::ParsedRequest parsed = rtu::decode_request(frame);
  if (const auto* error = std::get_if<rtu::FrameErrc>(&parsed)) {
    ServeResult result = outcome_only(ServeOutcome::kDiscarded);
    result.frame_error = *error;
    return result;
  }
  if (const auto* rejected = std::get_if<rtu::RejectedRequest>(&parsed)) {
    if (rejected->unit != config.unit && rejected->unit != rtu::kBroadcastUnit)
      return outcome_only(ServeOutcome::kNotAddressed);
    return refuse(rejected->unit, rejected->function, rejected->code, config, std::nullopt);
  }
  const auto& request = std::get<rtu::Request>(parsed);
  if (request.unit != config.unit && request.unit != rtu::kBroadcastUnit)
    return outcome_only(ServeOutcome::kNotAddressed);
  const auto function = static_cast<std::uint8_t>(rtu::function_of(request.pdu));

  if (const auto code = check_request(request.pdu, config.rules))
    return refuse(request.unit, function, *code, config, request);

  std::optional<rtu::ExceptionCode> bank_error;
  std::optional<rtu::Response> response;
  if (const auto* read = std::get_if<rtu::ReadRegisters>(&request.pdu)) {
    std::vector<std::uint16_t> values(read->quantity);
    bank_error = bank.read(read->start, values);
    if (!bank_error) response = rtu::Response{request.unit, rtu::ReadRegistersReply{std::move(values)}};
  } else if (const auto* write = std::get_if<rtu::WriteRegister>(&request.pdu)) {
    const std::uint16_t value = write->value;
    bank_error = bank.write(write->address, std::span<const std::uint16_t>(&value, 1));
    response = rtu::write_acknowledgement(request);
  } else {
    const auto& writes = std::get<rtu::WriteRegisters>(request.pdu);
    bank_error = bank.write(writes.start, writes.values);
    response = rtu::write_acknowledgement(request);
  }
  if (bank_error) return refuse(request.unit, function, *bank_error, config, request);

  ServeResult result;
  result.request = request;
  if (!expects_reply(request)) {
    result.outcome = ServeOutcome::kExecutedSilently;
    return result;
  }
  result.outcome = ServeOutcome::kReplied;
  result.reply = rtu::encode_response(*response);
  return result;
}

}  // namespace motion::adam
