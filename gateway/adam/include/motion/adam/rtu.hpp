// Modbus RTU codec for the ADAM NEMA8–NEMA23 integrated stepper (manual "RS485 Modbus/RTU", §3–§6),
// pure over byte spans: no I/O, no clocks, no allocation beyond the returned vectors.
//
// Wire rules (manual §6 note): every 16-bit field high byte first; CRC-16/MODBUS (init 0xFFFF,
// reflected poly 0xA001, no final XOR) over address … last data byte, sent LOW byte first.
// Function codes the drive documents (§6): 0x03 read registers, 0x06 write one register,
// 0x10 write registers. Nothing else (no 0x04, no coils): a slave answers any other code with
// exception 0x01. Address 0 is broadcast (§5): executed by every node, never answered; a
// broadcast read is meaningless and is refused on both encode and decode.
// Exception responses are not in the manual; we use the standard Modbus frame (address,
// function | 0x80, code, CRC).
//
// Decoding order (a received frame is delimited by t3.5 silence, see FrameTiming):
//   1. size 4…256, else too_short / too_long;
//   2. CRC over the whole frame, else bad_crc (trailing garbage almost always fails here, but a
//      single stray 0x00 after a valid frame still passes the CRC: CRC(frame + CRC low byte) is
//      0x00<CRC high> by construction; step 3 then rejects it as trailing_bytes);
//   3. PDU length against the function's layout, else truncated / trailing_bytes;
//   4. PDU contents (quantity limits, byte count = 2·quantity) → Modbus exceptions (slave side).
//
// Thread contract: every function here is pure and thread-safe.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <system_error>
#include <type_traits>
#include <variant>
#include <vector>

#include "motion/adam/result.hpp"

namespace motion::adam::rtu {

// --- Function and exception codes --------------------------------------------------------------

enum class FunctionCode : std::uint8_t {
  kReadHoldingRegisters = 0x03,
  kWriteSingleRegister = 0x06,
  kWriteMultipleRegisters = 0x10,
};
inline constexpr std::uint8_t kExceptionFlag = 0x80;

// Modbus application protocol v1.1b3 §7. The drive's own use of them is undocumented.
enum class ExceptionCode : std::uint8_t {
  kIllegalFunction = 0x01,
  kIllegalDataAddress = 0x02,
  kIllegalDataValue = 0x03,
  kServerDeviceFailure = 0x04,
  kAcknowledge = 0x05,
  kServerDeviceBusy = 0x06,
  kMemoryParityError = 0x08,
  kGatewayPathUnavailable = 0x0A,
  kGatewayTargetFailed = 0x0B,
};
[[nodiscard]] const std::error_category& modbus_category() noexcept;  // name() == "modbus"
[[nodiscard]] inline std::error_code make_error_code(ExceptionCode e) noexcept {
  return {static_cast<int>(e), modbus_category()};
}

// Why a frame could not be decoded or encoded (category "modbus_rtu"). A slave discards such
// frames silently; a master treats them like a timeout.
enum class FrameErrc {
  kTooShort = 1,         // fewer than 4 bytes (address + function + CRC)
  kTooLong,              // more than 256 bytes (Modbus RTU ADU limit)
  kBadCrc,               // CRC-16/MODBUS over the frame does not match its last two bytes
  kTruncated,            // CRC fine but fewer bytes than the function's layout needs
  kTrailingBytes,        // CRC fine but more bytes than the function's layout uses
  kUnsupportedFunction,  // response decoding: a function code the drive does not use
  kInvalidQuantity,      // encoding: quantity outside the Modbus limits (1…125 read, 1…123 write)
  kByteCountMismatch,    // response decoding: byte count ≠ 2 × registers (or ≠ the request's)
  kBroadcastRead,        // a read addressed to 0: nobody can answer it
  kInvalidUnit,          // encoding: unit address above 247
  kUnexpectedResponse,   // response does not belong to the request (unit, function, echo, count)
};
[[nodiscard]] const std::error_category& frame_category() noexcept;  // name() == "modbus_rtu"
[[nodiscard]] inline std::error_code make_error_code(FrameErrc e) noexcept {
  return {static_cast<int>(e), frame_category()};
}

// --- Limits -------------------------------------------------------------------------------------

inline constexpr std::uint8_t kBroadcastUnit = 0;
inline constexpr std::uint8_t kMaxUnit = 247;  // Modbus; the drive uses 1…64 (§5)
inline constexpr std::size_t kMinFrameSize = 4;
inline constexpr std::size_t kMaxFrameSize = 256;        // Modbus RTU ADU
inline constexpr std::uint16_t kMaxReadQuantity = 125;   // Modbus FC 0x03
inline constexpr std::uint16_t kMaxWriteQuantity = 123;  // Modbus FC 0x10

// --- CRC ----------------------------------------------------------------------------------------

// CRC-16/MODBUS. Check value: {01 03 00 00 00 01} → 0x0A84 (sent 84 0A).
[[nodiscard]] constexpr std::uint16_t crc16(std::span<const std::uint8_t> bytes) noexcept {
  std::uint16_t crc = 0xFFFF;
  for (const std::uint8_t byte : bytes) {
    crc = static_cast<std::uint16_t>(crc ^ byte);
    for (int bit = 0; bit < 8; ++bit) {
      const bool lsb = (crc & 1U) != 0;
      crc = static_cast<std::uint16_t>(crc >> 1);
      if (lsb) crc = static_cast<std::uint16_t>(crc ^ 0xA001U);
    }
  }
  return crc;
}
// Appends the CRC of `frame` (low byte first).
void append_crc(std::vector<std::uint8_t>& frame);
// True when the last two bytes are the CRC of the rest (and the frame has ≥ 3 bytes).
[[nodiscard]] bool crc_ok(std::span<const std::uint8_t> frame) noexcept;

// --- Typed PDUs ---------------------------------------------------------------------------------

struct ReadRegisters {  // FC 0x03 request
  std::uint16_t start = 0;
  std::uint16_t quantity = 0;
  friend bool operator==(const ReadRegisters&, const ReadRegisters&) = default;
};
struct WriteRegister {  // FC 0x06 request; its normal response is the same PDU (echo)
  std::uint16_t address = 0;
  std::uint16_t value = 0;
  friend bool operator==(const WriteRegister&, const WriteRegister&) = default;
};
struct WriteRegisters {  // FC 0x10 request
  std::uint16_t start = 0;
  std::vector<std::uint16_t> values;  // register start+i gets values[i]
  friend bool operator==(const WriteRegisters&, const WriteRegisters&) = default;
};
using RequestPdu = std::variant<ReadRegisters, WriteRegister, WriteRegisters>;

struct Request {
  std::uint8_t unit = 0;
  RequestPdu pdu;
  friend bool operator==(const Request&, const Request&) = default;
};

struct ReadRegistersReply {  // FC 0x03 normal response
  std::vector<std::uint16_t> values;
  friend bool operator==(const ReadRegistersReply&, const ReadRegistersReply&) = default;
};
using WriteRegisterReply = WriteRegister;  // FC 0x06 normal response: echo of the request
struct WriteRegistersReply {               // FC 0x10 normal response
  std::uint16_t start = 0;
  std::uint16_t quantity = 0;
  friend bool operator==(const WriteRegistersReply&, const WriteRegistersReply&) = default;
};
struct ExceptionReply {
  std::uint8_t function = 0;  // the request's function code, without the 0x80 flag
  ExceptionCode code = ExceptionCode::kIllegalFunction;
  friend bool operator==(const ExceptionReply&, const ExceptionReply&) = default;
};
using ResponsePdu = std::variant<ReadRegistersReply, WriteRegisterReply, WriteRegistersReply, ExceptionReply>;

struct Response {
  std::uint8_t unit = 0;
  ResponsePdu pdu;
  friend bool operator==(const Response&, const Response&) = default;
};

[[nodiscard]] FunctionCode function_of(const RequestPdu& pdu) noexcept;
[[nodiscard]] inline bool is_broadcast(const Request& r) noexcept { return r.unit == kBroadcastUnit; }

// --- Master side: request encode, response decode ----------------------------------------------

// Whole ADU: unit, PDU, CRC. Errors: invalid_unit, invalid_quantity, broadcast_read.
[[nodiscard]] Result<std::vector<std::uint8_t>> encode_request(const Request& request);
// Same without the CRC: what libmodbus modbus_send_raw_request() wants (it appends the CRC).
[[nodiscard]] Result<std::vector<std::uint8_t>> encode_request_without_crc(const Request& request);

// Context-free response decoding (FC 0x03 values from its byte count). Errors: FrameErrc.
[[nodiscard]] Result<Response> decode_response(std::span<const std::uint8_t> frame);
// Decoding plus matching against the request that was sent: same unit, same function, FC 0x03
// with exactly request.quantity values, FC 0x06 echo identical, FC 0x10 same start and quantity.
// An exception reply to this request's function is a successful decode (ExceptionReply).
[[nodiscard]] Result<Response> decode_response(std::span<const std::uint8_t> frame, const Request& request);

// --- Slave side: request decode, response encode -----------------------------------------------

// A well-framed request (CRC fine) that the slave must refuse with a Modbus exception.
struct RejectedRequest {
  std::uint8_t unit = 0;
  std::uint8_t function = 0;
  ExceptionCode code = ExceptionCode::kIllegalFunction;
  friend bool operator==(const RejectedRequest&, const RejectedRequest&) = default;
};
// Request: serve it. RejectedRequest: answer with its exception (unless broadcast).
// FrameErrc: discard silently (bad CRC, bad length, broadcast read).
using ParsedRequest = std::variant<Request, RejectedRequest, FrameErrc>;
[[nodiscard]] ParsedRequest decode_request(std::span<const std::uint8_t> frame);

[[nodiscard]] std::vector<std::uint8_t> encode_response(const Response& response);
[[nodiscard]] std::vector<std::uint8_t> encode_exception(std::uint8_t unit, std::uint8_t function, ExceptionCode code);
// The normal response of a fully executed write request (FC 0x06 echo, FC 0x10 start+quantity).
// A read request has no value-free response: returns nullopt for ReadRegisters.
[[nodiscard]] std::optional<Response> write_acknowledgement(const Request& request);

// --- Receive-side framing helper ---------------------------------------------------------------

// How many bytes the request starting at `head` occupies, from its header alone (an alternative
// to waiting for t3.5 silence). nullopt: not enough bytes yet to know, or an unknown function
// (then only silence delimits the frame).
[[nodiscard]] std::optional<std::size_t> request_frame_size(std::span<const std::uint8_t> head) noexcept;

// --- Inter-frame timing (Modbus over serial line v1.02 §2.5.1.1) -------------------------------

enum class Parity : std::uint8_t { kNone, kEven, kOdd };
struct SerialFormat {
  std::uint32_t baud = 115200;  // the drive's default (§4); 8N1, no parity register exists
  Parity parity = Parity::kNone;
  std::uint8_t data_bits = 8;
  std::uint8_t stop_bits = 1;
};
struct FrameTiming {
  std::chrono::nanoseconds character;  // one character: start + data + parity + stop bits
  std::chrono::nanoseconds t1_5;       // max gap inside a frame
  std::chrono::nanoseconds t3_5;       // min silence between frames
};
// 1.5 and 3.5 character times; above 19200 bit/s fixed at 750 µs and 1750 µs. Requires baud > 0.
[[nodiscard]] FrameTiming frame_timing(const SerialFormat& format) noexcept;
// Time on the wire of `bytes` characters (no inter-frame gap).
[[nodiscard]] std::chrono::nanoseconds transmission_time(const SerialFormat& format, std::size_t bytes) noexcept;

}  // namespace motion::adam::rtu

template <>
struct std::is_error_code_enum<motion::adam::rtu::ExceptionCode> : std::true_type {};
template <>
struct std::is_error_code_enum<motion::adam::rtu::FrameErrc> : std::true_type {};
