// UIMessage: the 16-byte framing the UIM2513 (RS232), UIM2523 (Ethernet) and UIM2533 (USB)
// gateways use for the same SimpleCAN messages (manual §2.6, Appendix-1):
//   byte 0 SM (0xAA = with CRC, 0xAD = without) | 1 ID | 2 CW | 3 DL | 4..11 d0..d7 | 12 d8 (aux)
//   | 13 R0 = CRC low byte | 14 R1 = CRC high byte | 15 EM = 0xCC
// CRC-16/MODBUS (poly 0xA001 reflected, init 0xFFFF). Which bytes it covers is ambiguous: the
// manual says SM..d8 (13 bytes), the gateway software in the field uses ID..d8
// (12 bytes). Both are offered as CrcCoverage; the default is the manual's reading.
// Thread contract: pure functions, thread-safe.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include "motion/uim342/errors.hpp"
#include "motion/uim342/message.hpp"

namespace motion::uim342 {

inline constexpr std::size_t kUiMessageSize = 16;
inline constexpr std::uint8_t kUiStartWithCrc = 0xAA;
inline constexpr std::uint8_t kUiStartWithoutCrc = 0xAD;
inline constexpr std::uint8_t kUiEnd = 0xCC;

enum class CrcCoverage : std::uint8_t {
  kStartToAux,  // bytes 0..12, "0xAA ID CW ... d8, qty = 13" (manual; variant A)
  kIdToAux,     // bytes 1..12 (UIROBOT SDK / gateway emulators; variant B)
};
enum class CrcAcceptance : std::uint8_t { kStartToAux, kIdToAux, kEither };

// CRC-16/MODBUS; check value over "123456789" is 0x4B37.
[[nodiscard]] std::uint16_t crc16_modbus(std::span<const std::uint8_t> bytes) noexcept;

struct UiMessage {
  std::uint8_t id = 0;  // addressee for instructions, sender for drive messages
  Message message;
  std::uint8_t aux = 0;  // d8, don't care
  friend bool operator==(const UiMessage&, const UiMessage&) = default;
};

using UiFrame = std::array<std::uint8_t, kUiMessageSize>;

// SM = 0xAA with the CRC over `coverage`. Fails only when DL exceeds 8.
[[nodiscard]] Result<UiFrame> encode_ui_message(const UiMessage& message,
                                                CrcCoverage coverage = CrcCoverage::kStartToAux);
// SM = 0xAD, R0 = R1 = 0 (not checked by the receiver).
[[nodiscard]] Result<UiFrame> encode_ui_message_without_crc(const UiMessage& message);

struct DecodedUiMessage {
  UiMessage message;
  std::optional<CrcCoverage> crc;  // the coverage that matched; nullopt for SM = 0xAD
};
// Rejects sizes other than 16, bad SM/EM, DL > 8 and CRC mismatches (per `accept`). Data bytes
// beyond DL are ignored (they are covered by the CRC, so they were checked).
[[nodiscard]] Result<DecodedUiMessage> decode_ui_message(std::span<const std::uint8_t> frame,
                                                         CrcAcceptance accept = CrcAcceptance::kEither);

// The one ID byte of a UIMessage is the drive's side of the exchange (§2.6, §2.1): the consumer of
// a host instruction, the producer of a drive frame (ACK, error report, notification). The host's
// side is implicit: the gateway sends instructions as the master and hands every drive frame to
// it. These map a SimpleCAN message to and from that form; `host` is the master ID (§2.5: 4).
// Host side (the gateway transport): instructions out, drive frames in. Fails with
// producer_not_host when the instruction's producer is not `host` (it could not be told apart).
[[nodiscard]] Result<UiMessage> instruction_to_ui(const CanMessage& instruction, std::uint8_t host = kMasterId);
[[nodiscard]] CanMessage drive_message_from_ui(const UiMessage& drive_message, std::uint8_t host = kMasterId);
// Gateway side (simulators, tests): instructions in, drive frames out.
[[nodiscard]] CanMessage instruction_from_ui(const UiMessage& instruction, std::uint8_t host = kMasterId);
[[nodiscard]] UiMessage drive_message_to_ui(const CanMessage& drive_message);

}  // namespace motion::uim342
