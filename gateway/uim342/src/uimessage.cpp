#include "motion/uim342/uimessage.hpp"

#include <algorithm>

#include "motion/core/bytes.hpp"

namespace motion::uim342 {
namespace {

constexpr std::size_t kIdAt = 1;
constexpr std::size_t kControlWordAt = 2;
constexpr std::size_t kLengthAt = 3;
constexpr std::size_t kDataAt = 4;
constexpr std::size_t kAuxAt = 12;
constexpr std::size_t kCrcAt = 13;
constexpr std::size_t kEndAt = 15;

std::uint16_t crc_of(std::span<const std::uint8_t> frame, CrcCoverage coverage) {
  const std::size_t first = coverage == CrcCoverage::kStartToAux ? 0 : kIdAt;
  return crc16_modbus(frame.subspan(first, kCrcAt - first));
}

bool accepts(CrcAcceptance accept, CrcCoverage coverage) {
  switch (accept) {
    case CrcAcceptance::kStartToAux: return coverage == CrcCoverage::kStartToAux;
    case CrcAcceptance::kIdToAux: return coverage == CrcCoverage::kIdToAux;
    case CrcAcceptance::kEither: return true;
  }
  return false;
}

Result<UiFrame> encode_body(const UiMessage& message, std::uint8_t start) {
  if (message.message.length > kMaxDataLength) return CodecErrc::kLengthOutOfRange;
  UiFrame out{};
  out[0] = start;
  out[kIdAt] = message.id;
  out[kControlWordAt] = message.message.control_word;
  out[kLengthAt] = message.message.length;
  const auto payload = message.message.payload();
  std::copy(payload.begin(), payload.end(), out.begin() + kDataAt);
  out[kAuxAt] = message.aux;
  out[kEndAt] = kUiEnd;
  return out;
}

}  // namespace

std::uint16_t crc16_modbus(std::span<const std::uint8_t> bytes) noexcept {
  std::uint16_t crc = 0xFFFF;
  for (const std::uint8_t b : bytes) {
    crc ^= b;
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 1U) != 0 ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001U) : static_cast<std::uint16_t>(crc >> 1);
    }
  }
  return crc;
}

Result<UiFrame> encode_ui_message(const UiMessage& message, CrcCoverage coverage) {
  auto frame = encode_body(message, kUiStartWithCrc);
  if (!frame) return frame;
  UiFrame out = *frame;
  bytes::write_le(std::span<std::uint8_t>(out), kCrcAt, crc_of(out, coverage));  // R0 low byte first
  return out;
}

Result<UiFrame> encode_ui_message_without_crc(const UiMessage& message) {
  return encode_body(message, kUiStartWithoutCrc);
}

Result<DecodedUiMessage> decode_ui_message(std::span<const std::uint8_t> frame, CrcAcceptance accept) {
  if (frame.size() != kUiMessageSize) return CodecErrc::kBadFrameSize;
  if (frame[0] != kUiStartWithCrc && frame[0] != kUiStartWithoutCrc) return CodecErrc::kBadStartByte;
  if (frame[kEndAt] != kUiEnd) return CodecErrc::kBadEndByte;
  const std::uint8_t length = frame[kLengthAt];
  if (length > kMaxDataLength) return CodecErrc::kLengthOutOfRange;

  DecodedUiMessage out;
  if (frame[0] == kUiStartWithCrc) {
    const auto received = *bytes::read_le<std::uint16_t>(frame, kCrcAt);
    for (const CrcCoverage coverage : {CrcCoverage::kStartToAux, CrcCoverage::kIdToAux}) {
      if (accepts(accept, coverage) && crc_of(frame, coverage) == received) {
        out.crc = coverage;
        break;
      }
    }
    if (!out.crc) return CodecErrc::kBadCrc;
  }
  const auto message = Message::make(frame[kControlWordAt], frame.subspan(kDataAt, length));
  if (!message) return message.error();
  out.message = UiMessage{frame[kIdAt], *message, frame[kAuxAt]};
  return out;
}

Result<UiMessage> instruction_to_ui(const CanMessage& instruction, std::uint8_t host) {
  if (instruction.address.producer != host) return CodecErrc::kProducerNotHost;
  return UiMessage{instruction.address.consumer, instruction.message, 0};
}

CanMessage drive_message_from_ui(const UiMessage& drive_message, std::uint8_t host) {
  return {drive_to_host(drive_message.id, host), drive_message.message};
}

CanMessage instruction_from_ui(const UiMessage& instruction, std::uint8_t host) {
  return {host_to(instruction.id, host), instruction.message};
}

UiMessage drive_message_to_ui(const CanMessage& drive_message) {
  return {drive_message.address.producer, drive_message.message, 0};
}

}  // namespace motion::uim342
