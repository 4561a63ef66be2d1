// Typed view of the ADAM drive's status register 0x0006–0x0007 (§8.4, UINT32, low word at
// 0x0006) and alarm register 0x00A3 (§8.52).
//
// Note: the drive reports NO "enabled" flag. 0x00D4 (enable/release) is write-only and status
// bit 16 (X16) is only the LEVEL of the enable input. A master that needs the enable state must
// remember what it wrote (and the power-on default from 0x0012 bit 4).
//
// Thread contract: pure functions and value types, thread-safe.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

namespace motion::adam {

// Status bits 9…8 (X9 MSB, X8 LSB; §8.4). "about to start/stop" read as the ramp phases (assumed).
enum class MotionPhase : std::uint8_t { kIdle = 0, kAccelerating = 1, kDecelerating = 2, kCruising = 3 };

struct DriveStatus {
  std::uint8_t inputs = 0;                 // bits 0…7: X0…X7 level (after polarity inversion)
  MotionPhase phase = MotionPhase::kIdle;  // bits 8–9
  bool deviation_exceeded = false;         // bit 10, X10: |deviation| > 0x0010
  bool reminder_x11 = false;               // bit 11, X11: reminder 0x00A8 holds
  bool in_position = false;                // bit 12, X12
  bool negative_limit = false;             // bit 13, X13
  bool positive_limit = false;             // bit 14, X14
  bool at_home = false;                    // bit 15, X15
  bool enable_input_high = false;          // bit 16, X16: enable INPUT level, not the drive state
  bool reminder_x17 = false;               // bit 17
  bool reminder_x18 = false;               // bit 18
  bool reminder_x19 = false;               // bit 19
  bool deviation_negative = false;         // bit 20, X20: sign of the position deviation

  [[nodiscard]] bool input(unsigned n) const noexcept { return n < 8 && ((inputs >> n) & 1U) != 0; }
  // Motion in progress: a ramp/cruise phase, or not yet in position (bits 9…8 and X12, §8.4).
  [[nodiscard]] bool moving() const noexcept { return phase != MotionPhase::kIdle || !in_position; }
  [[nodiscard]] bool at_limit() const noexcept { return negative_limit || positive_limit; }
  friend bool operator==(const DriveStatus&, const DriveStatus&) = default;
};

inline constexpr std::uint32_t kStatusReservedMask = 0xFFE00000U;  // bits 21…31, always 0

[[nodiscard]] DriveStatus decode_status(std::uint32_t raw) noexcept;
[[nodiscard]] std::uint32_t encode_status(const DriveStatus& status) noexcept;  // for the simulator
// From the two registers as read (0x0006, 0x0007).
[[nodiscard]] DriveStatus decode_status(std::uint16_t at_0x0006, std::uint16_t at_0x0007) noexcept;

// Alarm codes, 4 bits each (§8.52). Values 11…15 are undocumented and kept as-is.
enum class AlarmCode : std::uint8_t {
  kNone = 0,
  kOverCurrent = 1,
  kOverVoltage = 2,
  kUnderVoltage = 3,
  kPhaseAOpen = 4,
  kPhaseBOpen = 5,
  kPositionError = 6,
  kInternal24vFault = 7,  // manual (§8.52): "internal 24V offset"; name assumed
  kPhaseAVoltage = 8,     // manual (§8.52): "AI voltage error"; name assumed
  kPhaseBVoltage = 9,     // manual (§8.52): "BI voltage error"; name assumed
  kEncoderError = 10,
};
// The manual's text for the code ("Over-current", …), "Unknown alarm" for 11…15.
[[nodiscard]] std::string_view alarm_text(AlarmCode code) noexcept;

struct AlarmState {
  AlarmCode current = AlarmCode::kNone;  // bits 3…0
  std::array<AlarmCode, 3> history{};    // bits 7…4 (most recent), 11…8, 15…12 (oldest)
  [[nodiscard]] bool active() const noexcept { return current != AlarmCode::kNone; }
  friend bool operator==(const AlarmState&, const AlarmState&) = default;
};
[[nodiscard]] AlarmState decode_alarms(std::uint16_t raw) noexcept;
[[nodiscard]] std::uint16_t encode_alarms(const AlarmState& state) noexcept;

}  // namespace motion::adam
