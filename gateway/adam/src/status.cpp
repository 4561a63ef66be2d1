#include "motion/adam/status.hpp"

#include "motion/adam/registers.hpp"

namespace motion::adam {
namespace {

// Single-bit flags of the status word, in bit order (§8.4).
struct FlagBit {
  unsigned bit;
  bool DriveStatus::*flag;
};
constexpr FlagBit kFlags[] = {
    {10, &DriveStatus::deviation_exceeded}, {11, &DriveStatus::reminder_x11},       {12, &DriveStatus::in_position},
    {13, &DriveStatus::negative_limit},     {14, &DriveStatus::positive_limit},     {15, &DriveStatus::at_home},
    {16, &DriveStatus::enable_input_high},  {17, &DriveStatus::reminder_x17},       {18, &DriveStatus::reminder_x18},
    {19, &DriveStatus::reminder_x19},       {20, &DriveStatus::deviation_negative},
};
constexpr unsigned kPhaseShift = 8;

constexpr std::string_view kAlarmTexts[] = {
    "Normal",                   // 0
    "Over-current",             // 1
    "Over-voltage",             // 2
    "Under-voltage",            // 3
    "Phase A open circuit",     // 4
    "Phase B open circuit",     // 5
    "offset pulses or others",  // 6 (position error)
    "internal 24V offset",      // 7
    "AI voltage error",         // 8
    "BI voltage error",         // 9
    "Encoder error",            // 10
};
constexpr unsigned kAlarmNibbles = 4;

}  // namespace

DriveStatus decode_status(std::uint32_t raw) noexcept {
  DriveStatus s;
  s.inputs = static_cast<std::uint8_t>(raw & 0xFFU);
  s.phase = static_cast<MotionPhase>((raw >> kPhaseShift) & 0x3U);
  for (const auto& f : kFlags) s.*f.flag = ((raw >> f.bit) & 1U) != 0;
  return s;
}

DriveStatus decode_status(std::uint16_t at_0x0006, std::uint16_t at_0x0007) noexcept {
  return decode_status(decode32(at_0x0006, at_0x0007));
}

std::uint32_t encode_status(const DriveStatus& s) noexcept {
  std::uint32_t raw = s.inputs | (static_cast<std::uint32_t>(s.phase) << kPhaseShift);
  for (const auto& f : kFlags) {
    if (s.*f.flag) raw |= 1U << f.bit;
  }
  return raw;
}

std::string_view alarm_text(AlarmCode code) noexcept {
  const auto index = static_cast<std::size_t>(code);
  return index < std::size(kAlarmTexts) ? kAlarmTexts[index] : std::string_view{"Unknown alarm"};
}

AlarmState decode_alarms(std::uint16_t raw) noexcept {
  AlarmState state;
  const auto nibble = [&](unsigned i) {
    return static_cast<AlarmCode>((static_cast<unsigned>(raw) >> (4 * i)) & 0xFU);
  };
  state.current = nibble(0);
  for (unsigned i = 1; i < kAlarmNibbles; ++i) state.history[i - 1] = nibble(i);
  return state;
}

std::uint16_t encode_alarms(const AlarmState& state) noexcept {
  std::uint32_t raw = static_cast<std::uint32_t>(state.current) & 0xFU;
  for (unsigned i = 1; i < kAlarmNibbles; ++i)
    raw |= (static_cast<std::uint32_t>(state.history[i - 1]) & 0xFU) << (4 * i);
  return static_cast<std::uint16_t>(raw);
}

}  // namespace motion::adam
