#include "motion/adam/rtu.hpp"

#include <string>

#include "motion/core/bytes.hpp"

namespace motion::adam::rtu {
namespace {

class ModbusCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "modbus"; }
  [[nodiscard]] std::string message(int code) const override {
    switch (static_cast<ExceptionCode>(code)) {
      case ExceptionCode::kIllegalFunction: return "illegal function";
      case ExceptionCode::kIllegalDataAddress: return "illegal data address";
      case ExceptionCode::kIllegalDataValue: return "illegal data value";
      case ExceptionCode::kServerDeviceFailure: return "server device failure";
      case ExceptionCode::kAcknowledge: return "acknowledge";
      case ExceptionCode::kServerDeviceBusy: return "server device busy";
      case ExceptionCode::kMemoryParityError: return "memory parity error";
      case ExceptionCode::kGatewayPathUnavailable: return "gateway path unavailable";
      case ExceptionCode::kGatewayTargetFailed: return "gateway target device failed to respond";
    }
    return "unknown modbus exception " + std::to_string(code);
  }
};

class FrameCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "modbus_rtu"; }
  [[nodiscard]] std::string message(int code) const override {
    switch (static_cast<FrameErrc>(code)) {
      case FrameErrc::kTooShort: return "frame shorter than 4 bytes";
      case FrameErrc::kTooLong: return "frame longer than 256 bytes";
      case FrameErrc::kBadCrc: return "CRC mismatch";
      case FrameErrc::kTruncated: return "frame shorter than its function's layout";
      case FrameErrc::kTrailingBytes: return "bytes after the end of the function's layout";
      case FrameErrc::kUnsupportedFunction: return "function code not used by the drive";
      case FrameErrc::kInvalidQuantity: return "register quantity outside the Modbus limits";
      case FrameErrc::kByteCountMismatch: return "byte count does not match the register quantity";
      case FrameErrc::kBroadcastRead: return "read request addressed to broadcast (0)";
      case FrameErrc::kInvalidUnit: return "unit address above 247";
      case FrameErrc::kUnexpectedResponse: return "response does not match the request";
    }
    return "unknown frame error " + std::to_string(code);
  }
};

using Bytes = std::vector<std::uint8_t>;

constexpr std::uint8_t fc_byte(FunctionCode fc) { return static_cast<std::uint8_t>(fc); }

void put_u16(Bytes& out, std::uint16_t value) {
  const std::size_t at = out.size();
  out.resize(at + 2);
  bytes::write_be<std::uint16_t>(out, at, value);
}

std::uint16_t get_u16(std::span<const std::uint8_t> in, std::size_t offset) {
  return bytes::read_be<std::uint16_t>(in, offset).value();  // callers check lengths first
}

std::vector<std::uint16_t> get_words(std::span<const std::uint8_t> in, std::size_t offset, std::size_t count) {
  std::vector<std::uint16_t> words(count);
  for (std::size_t i = 0; i < count; ++i) words[i] = get_u16(in, offset + 2 * i);
  return words;
}

// Frame checks shared by request and response decoding: size bounds and CRC.
std::optional<FrameErrc> check_envelope(std::span<const std::uint8_t> frame) {
  if (frame.size() < kMinFrameSize) return FrameErrc::kTooShort;
  if (frame.size() > kMaxFrameSize) return FrameErrc::kTooLong;
  if (!crc_ok(frame)) return FrameErrc::kBadCrc;
  return std::nullopt;
}

// Compares the frame size with the size its layout asks for.
std::optional<FrameErrc> check_size(std::size_t actual, std::size_t expected) {
  if (actual < expected) return FrameErrc::kTruncated;
  if (actual > expected) return FrameErrc::kTrailingBytes;
  return std::nullopt;
}

// unit + PDU, no CRC. Validation happens here so both encoders share it.
Result<Bytes> encode_adu_body(const Request& request) {
  if (request.unit > kMaxUnit) return FrameErrc::kInvalidUnit;
  Bytes out{request.unit, fc_byte(function_of(request.pdu))};
  if (const auto* read = std::get_if<ReadRegisters>(&request.pdu)) {
    if (request.unit == kBroadcastUnit) return FrameErrc::kBroadcastRead;
    if (read->quantity == 0 || read->quantity > kMaxReadQuantity) return FrameErrc::kInvalidQuantity;
    put_u16(out, read->start);
    put_u16(out, read->quantity);
  } else if (const auto* write = std::get_if<WriteRegister>(&request.pdu)) {
    put_u16(out, write->address);
    put_u16(out, write->value);
  } else {
    const auto& writes = std::get<WriteRegisters>(request.pdu);
    if (writes.values.empty() || writes.values.size() > kMaxWriteQuantity) return FrameErrc::kInvalidQuantity;
    put_u16(out, writes.start);
    put_u16(out, static_cast<std::uint16_t>(writes.values.size()));
    out.push_back(static_cast<std::uint8_t>(2 * writes.values.size()));
    for (const std::uint16_t v : writes.values) put_u16(out, v);
  }
  return out;
}

bool fits_address_space(std::uint16_t start, std::size_t quantity) { return std::size_t{start} + quantity <= 0x10000; }

}  // namespace

const std::error_category& modbus_category() noexcept {
  static const ModbusCategory category;
  return category;
}

const std::error_category& frame_category() noexcept {
  static const FrameCategory category;
  return category;
}

void append_crc(std::vector<std::uint8_t>& frame) {
  const std::uint16_t crc = crc16(frame);
  const std::size_t at = frame.size();
  frame.resize(at + 2);
  bytes::write_le<std::uint16_t>(frame, at, crc);
}

bool crc_ok(std::span<const std::uint8_t> frame) noexcept {
  if (frame.size() < 3) return false;
  const auto sent = bytes::read_le<std::uint16_t>(frame, frame.size() - 2);
  return sent && *sent == crc16(frame.first(frame.size() - 2));
}

FunctionCode function_of(const RequestPdu& pdu) noexcept {
  switch (pdu.index()) {
    case 0: return FunctionCode::kReadHoldingRegisters;
    case 1: return FunctionCode::kWriteSingleRegister;
    default: return FunctionCode::kWriteMultipleRegisters;
  }
}

Result<std::vector<std::uint8_t>> encode_request_without_crc(const Request& request) {
  return encode_adu_body(request);
}

Result<std::vector<std::uint8_t>> encode_request(const Request& request) {
  auto body = encode_adu_body(request);
  if (!body) return body.error();
  append_crc(body.value());
  return body;
}

// ---- Responses -------------------------------------------------------------------------------

Result<Response> decode_response(std::span<const std::uint8_t> frame) {
  if (const auto error = check_envelope(frame)) return *error;
  const std::uint8_t unit = frame[0];
  const std::uint8_t function = frame[1];
  const std::size_t size = frame.size();

  if ((function & kExceptionFlag) != 0) {
    if (const auto error = check_size(size, 5)) return *error;
    return Response{unit, ExceptionReply{static_cast<std::uint8_t>(function & ~kExceptionFlag),
                                         static_cast<ExceptionCode>(frame[2])}};
  }
  switch (static_cast<FunctionCode>(function)) {
    case FunctionCode::kReadHoldingRegisters: {
      if (size < 5) return FrameErrc::kTruncated;
      const std::size_t byte_count = frame[2];
      if (const auto error = check_size(size, 5 + byte_count)) return *error;
      if (byte_count == 0 || byte_count % 2 != 0) return FrameErrc::kByteCountMismatch;
      return Response{unit, ReadRegistersReply{get_words(frame, 3, byte_count / 2)}};
    }
    case FunctionCode::kWriteSingleRegister:
      if (const auto error = check_size(size, 8)) return *error;
      return Response{unit, WriteRegisterReply{get_u16(frame, 2), get_u16(frame, 4)}};
    case FunctionCode::kWriteMultipleRegisters:
      if (const auto error = check_size(size, 8)) return *error;
      return Response{unit, WriteRegistersReply{get_u16(frame, 2), get_u16(frame, 4)}};
  }
  return FrameErrc::kUnsupportedFunction;
}

Result<Response> decode_response(std::span<const std::uint8_t> frame, const Request& request) {
  auto decoded = decode_response(frame);
  if (!decoded) return decoded;
  const Response& response = decoded.value();
  const auto function = fc_byte(function_of(request.pdu));
  if (response.unit != request.unit) return FrameErrc::kUnexpectedResponse;
  if (const auto* exception = std::get_if<ExceptionReply>(&response.pdu)) {
    if (exception->function != function) return FrameErrc::kUnexpectedResponse;
    return decoded;
  }
  if (const auto* read = std::get_if<ReadRegisters>(&request.pdu)) {
    const auto* reply = std::get_if<ReadRegistersReply>(&response.pdu);
    if (reply == nullptr) return FrameErrc::kUnexpectedResponse;
    if (reply->values.size() != read->quantity) return FrameErrc::kByteCountMismatch;
  } else if (const auto* write = std::get_if<WriteRegister>(&request.pdu)) {
    const auto* reply = std::get_if<WriteRegisterReply>(&response.pdu);
    if (reply == nullptr || *reply != *write) return FrameErrc::kUnexpectedResponse;
  } else {
    const auto& writes = std::get<WriteRegisters>(request.pdu);
    const auto* reply = std::get_if<WriteRegistersReply>(&response.pdu);
    if (reply == nullptr || reply->start != writes.start || reply->quantity != writes.values.size())
      return FrameErrc::kUnexpectedResponse;
  }
  return decoded;
}

std::vector<std::uint8_t> encode_response(const Response& response) {
  Bytes out{response.unit};
  if (const auto* read = std::get_if<ReadRegistersReply>(&response.pdu)) {
    out.push_back(fc_byte(FunctionCode::kReadHoldingRegisters));
    out.push_back(static_cast<std::uint8_t>(2 * read->values.size()));
    for (const std::uint16_t v : read->values) put_u16(out, v);
  } else if (const auto* write = std::get_if<WriteRegisterReply>(&response.pdu)) {
    out.push_back(fc_byte(FunctionCode::kWriteSingleRegister));
    put_u16(out, write->address);
    put_u16(out, write->value);
  } else if (const auto* writes = std::get_if<WriteRegistersReply>(&response.pdu)) {
    out.push_back(fc_byte(FunctionCode::kWriteMultipleRegisters));
    put_u16(out, writes->start);
    put_u16(out, writes->quantity);
  } else {
    const auto& exception = std::get<ExceptionReply>(response.pdu);
    out.push_back(static_cast<std::uint8_t>(exception.function | kExceptionFlag));
    out.push_back(static_cast<std::uint8_t>(exception.code));
  }
  append_crc(out);
  return out;
}

std::vector<std::uint8_t> encode_exception(std::uint8_t unit, std::uint8_t function, ExceptionCode code) {
  return encode_response(Response{unit, ExceptionReply{function, code}});
}

std::optional<Response> write_acknowledgement(const Request& request) {
  if (const auto* write = std::get_if<WriteRegister>(&request.pdu)) return Response{request.unit, *write};
  if (const auto* writes = std::get_if<WriteRegisters>(&request.pdu)) {
    return Response{request.unit,
                    WriteRegistersReply{writes->start, static_cast<std::uint16_t>(writes->values.size())}};
  }
  return std::nullopt;
}

// ---- Requests (slave side) -------------------------------------------------------------------

ParsedRequest decode_request(std::span<const std::uint8_t> frame) {
  if (const auto error = check_envelope(frame)) return *error;
  const std::uint8_t unit = frame[0];
  const std::uint8_t function = frame[1];
  const std::size_t size = frame.size();
  const auto reject = [&](ExceptionCode code) { return RejectedRequest{unit, function, code}; };

  switch (static_cast<FunctionCode>(function)) {
    case FunctionCode::kReadHoldingRegisters: {
      if (const auto error = check_size(size, 8)) return *error;
      if (unit == kBroadcastUnit) return FrameErrc::kBroadcastRead;
      const std::uint16_t start = get_u16(frame, 2);
      const std::uint16_t quantity = get_u16(frame, 4);
      if (quantity == 0 || quantity > kMaxReadQuantity) return reject(ExceptionCode::kIllegalDataValue);
      if (!fits_address_space(start, quantity)) return reject(ExceptionCode::kIllegalDataAddress);
      return Request{unit, ReadRegisters{start, quantity}};
    }
    case FunctionCode::kWriteSingleRegister:
      if (const auto error = check_size(size, 8)) return *error;
      return Request{unit, WriteRegister{get_u16(frame, 2), get_u16(frame, 4)}};
    case FunctionCode::kWriteMultipleRegisters: {
      if (size < 9) return FrameErrc::kTruncated;
      const std::size_t byte_count = frame[6];
      if (const auto error = check_size(size, 9 + byte_count)) return *error;
      const std::uint16_t start = get_u16(frame, 2);
      const std::uint16_t quantity = get_u16(frame, 4);
      if (quantity == 0 || quantity > kMaxWriteQuantity || byte_count != std::size_t{2} * quantity)
        return reject(ExceptionCode::kIllegalDataValue);
      if (!fits_address_space(start, quantity)) return reject(ExceptionCode::kIllegalDataAddress);
      return Request{unit, WriteRegisters{start, get_words(frame, 7, quantity)}};
    }
  }
  return reject(ExceptionCode::kIllegalFunction);
}

std::optional<std::size_t> request_frame_size(std::span<const std::uint8_t> head) noexcept {
  if (head.size() < 2) return std::nullopt;
  switch (static_cast<FunctionCode>(head[1])) {
    case FunctionCode::kReadHoldingRegisters:
    case FunctionCode::kWriteSingleRegister: return 8;
    case FunctionCode::kWriteMultipleRegisters:
      if (head.size() < 7) return std::nullopt;
      return 9 + std::size_t{head[6]};
  }
  return std::nullopt;
}

// ---- Timing ----------------------------------------------------------------------------------

namespace {
// Time of `half_characters` / 2 characters, rounded up so a wait of this length is never short.
std::chrono::nanoseconds half_character_time(const SerialFormat& format, std::uint64_t half_characters) {
  const std::uint64_t bits_per_char =
      1U + format.data_bits + (format.parity == Parity::kNone ? 0U : 1U) + format.stop_bits;
  const std::uint64_t numerator = half_characters * bits_per_char * 1'000'000'000ULL;
  const std::uint64_t denominator = 2ULL * format.baud;
  return std::chrono::nanoseconds{static_cast<std::int64_t>((numerator + denominator - 1) / denominator)};
}
}  // namespace

std::chrono::nanoseconds transmission_time(const SerialFormat& format, std::size_t bytes) noexcept {
  return half_character_time(format, 2ULL * bytes);
}

FrameTiming frame_timing(const SerialFormat& format) noexcept {
  using std::chrono::microseconds;
  const auto character = half_character_time(format, 2);
  if (format.baud > 19200) return {character, microseconds{750}, microseconds{1750}};
  return {character, half_character_time(format, 3), half_character_time(format, 7)};
}

}  // namespace motion::adam::rtu
