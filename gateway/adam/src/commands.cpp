#include "motion/adam/commands.hpp"

#include <algorithm>
#include <array>
#include <utility>

namespace motion::adam {
namespace {

// A bit field [lsb, lsb + width) of a 16- or 32-bit word.
struct Field {
  unsigned lsb;
  unsigned width;
  [[nodiscard]] constexpr std::uint32_t max() const { return (1U << width) - 1U; }
  [[nodiscard]] constexpr bool fits(std::uint32_t v) const { return v <= max(); }
  [[nodiscard]] constexpr std::uint32_t put(std::uint32_t v) const { return (v & max()) << lsb; }
  [[nodiscard]] constexpr std::uint32_t get(std::uint32_t word) const { return (word >> lsb) & max(); }
};

// Jog / homing / torque word layouts (§8.65②, §8.48, §8.49).
constexpr Field kDirection{15, 1};
constexpr Field kSpeed{6, 9};
constexpr Field kStopMethod{5, 1};
constexpr Field kRunBit{0, 1};
constexpr Field kSecondarySpeed{0, 5};
constexpr Field kTorqueOffset{1, 14};
// Table execute (§8.54).
constexpr Field kTableKind{15, 1};
constexpr Field kTableArithmetic{12, 3};
constexpr Field kTableStep{0, 12};
// One byte of an input pair (§8.47).
constexpr Field kInputFunction{5, 3};
constexpr Field kInputLevel{4, 1};
constexpr Field kInputPort{0, 4};
// Position reminder (§8.53).
constexpr Field kReminderComparison{31, 1};
constexpr Field kReminderThreshold{0, 31};
constexpr std::int32_t kReminderMin = -(1 << 30);
constexpr std::int32_t kReminderMax = (1 << 30) - 1;

constexpr std::uint16_t word16(std::uint32_t v) { return static_cast<std::uint16_t>(v); }
template <typename E>
constexpr std::uint32_t raw(E e) {
  return static_cast<std::uint32_t>(e);
}

constexpr std::array<std::pair<BaudCode, std::uint32_t>, 15> kBaudRates{{
    {BaudCode::kB300, 300},
    {BaudCode::kB600, 600},
    {BaudCode::kB1200, 1200},
    {BaudCode::kB2400, 2400},
    {BaudCode::kB4800, 4800},
    {BaudCode::kB9600, 9600},
    {BaudCode::kB14400, 14400},
    {BaudCode::kB19200, 19200},
    {BaudCode::kB38400, 38400},
    {BaudCode::kB56000, 56000},
    {BaudCode::kB57600, 57600},
    {BaudCode::kB115200, 115200},
    {BaudCode::kB230400, 230400},
    {BaudCode::kB460800, 460800},
    {BaudCode::kB921600, 921600},
}};

std::uint32_t encode_input(const InputAssignment& a) {
  return kInputFunction.put(a.enabled ? 1U : 0U) | kInputLevel.put(a.active_high ? 1U : 0U) | kInputPort.put(a.input);
}
InputAssignment decode_input(std::uint32_t byte) {
  return {kInputFunction.get(byte) == 1U, kInputLevel.get(byte) == 1U, static_cast<std::uint8_t>(kInputPort.get(byte))};
}

}  // namespace

std::optional<std::uint32_t> baud_rate(BaudCode code) noexcept {
  const auto it = std::find_if(kBaudRates.begin(), kBaudRates.end(), [&](const auto& e) { return e.first == code; });
  return it == kBaudRates.end() ? std::nullopt : std::optional{it->second};
}

std::optional<BaudCode> baud_code(std::uint32_t bits_per_second) noexcept {
  const auto it =
      std::find_if(kBaudRates.begin(), kBaudRates.end(), [&](const auto& e) { return e.second == bits_per_second; });
  return it == kBaudRates.end() ? std::nullopt : std::optional{it->first};
}

Result<std::uint16_t> encode(const JogCommand& c) {
  if (!kSpeed.fits(c.speed_rpm)) return AdamErrc::kValueOutOfRange;
  return word16(kDirection.put(raw(c.direction)) | kSpeed.put(c.speed_rpm) | kStopMethod.put(raw(c.stop)) |
                kRunBit.put(c.run ? 1U : 0U));
}

JogCommand decode_jog(std::uint16_t word) noexcept {
  return {static_cast<Rotation>(kDirection.get(word)), static_cast<std::uint16_t>(kSpeed.get(word)),
          static_cast<StopMethod>(kStopMethod.get(word)), kRunBit.get(word) == 1U};
}

Result<std::uint16_t> encode(const HomingCommand& c) {
  if (!kSpeed.fits(c.speed_rpm) || !kSecondarySpeed.fits(c.secondary_speed_code)) return AdamErrc::kValueOutOfRange;
  return word16(kDirection.put(raw(c.direction)) | kSpeed.put(c.speed_rpm) | kStopMethod.put(raw(c.stop)) |
                kSecondarySpeed.put(c.secondary_speed_code));
}

HomingCommand decode_homing(std::uint16_t word) noexcept {
  return {static_cast<Travel>(kDirection.get(word)), static_cast<std::uint16_t>(kSpeed.get(word)),
          static_cast<StopMethod>(kStopMethod.get(word)), static_cast<std::uint8_t>(kSecondarySpeed.get(word))};
}

Result<std::uint16_t> encode(const TorqueCommand& c) {
  if (!kTorqueOffset.fits(c.offset_pulses)) return AdamErrc::kValueOutOfRange;
  return word16(kDirection.put(raw(c.direction)) | kTorqueOffset.put(c.offset_pulses) | kRunBit.put(c.run ? 1U : 0U));
}

TorqueCommand decode_torque(std::uint16_t word) noexcept {
  return {static_cast<Travel>(kDirection.get(word)), static_cast<std::uint16_t>(kTorqueOffset.get(word)),
          kRunBit.get(word) == 1U};
}

Result<std::uint16_t> encode(const TableExecute& c) {
  if (!kTableStep.fits(c.step)) return AdamErrc::kValueOutOfRange;
  return word16(kTableKind.put(raw(c.kind)) | kTableArithmetic.put(raw(c.arithmetic)) | kTableStep.put(c.step));
}

std::optional<TableExecute> decode_table_execute(std::uint16_t word) noexcept {
  const std::uint32_t arithmetic = kTableArithmetic.get(word);
  if (arithmetic > 1U) return std::nullopt;
  return TableExecute{static_cast<TableEntryKind>(kTableKind.get(word)), static_cast<PointerArithmetic>(arithmetic),
                      static_cast<std::uint16_t>(kTableStep.get(word))};
}

Result<std::uint16_t> encode(const InputPair& c) {
  if (!kInputPort.fits(c.high.input) || !kInputPort.fits(c.low.input)) return AdamErrc::kValueOutOfRange;
  return word16((encode_input(c.high) << 8) | encode_input(c.low));
}

InputPair decode_input_pair(std::uint16_t word) noexcept {
  return {decode_input(std::uint32_t{word} >> 8), decode_input(word & 0xFFU)};
}

Result<std::uint32_t> encode(const PositionReminder& r) {
  if (r.threshold < kReminderMin || r.threshold > kReminderMax) return AdamErrc::kValueOutOfRange;
  return kReminderComparison.put(raw(r.comparison)) | kReminderThreshold.put(static_cast<std::uint32_t>(r.threshold));
}

PositionReminder decode_reminder(std::uint32_t word) noexcept {
  std::uint32_t threshold = kReminderThreshold.get(word);
  if ((threshold & (1U << 30)) != 0) threshold |= 1U << 31;  // sign-extend from 31 bits
  return {static_cast<ReminderComparison>(kReminderComparison.get(word)), static_cast<std::int32_t>(threshold)};
}

rtu::Request write16(std::uint8_t unit, Reg reg, std::uint16_t value) {
  return {unit, rtu::WriteRegister{address(reg), value}};
}

rtu::Request write32(std::uint8_t unit, Reg reg, std::uint32_t value) {
  const auto words = encode32(value);
  return {unit, rtu::WriteRegisters{address(reg), {words[0], words[1]}}};
}

rtu::Request write32(std::uint8_t unit, Reg reg, std::int32_t value) {
  return write32(unit, reg, static_cast<std::uint32_t>(value));
}

rtu::Request read(std::uint8_t unit, Reg reg) { return {unit, rtu::ReadRegisters{address(reg), info(reg).count()}}; }

rtu::Request command(std::uint8_t unit, VelocityCommand c) {
  return write16(unit, Reg::kVelocityCommand, static_cast<std::uint16_t>(c));
}
rtu::Request command(std::uint8_t unit, EnableCommand c) {
  return write16(unit, Reg::kEnableCommand, static_cast<std::uint16_t>(c));
}
rtu::Request command(std::uint8_t unit, ProgramCommand c) {
  return write16(unit, Reg::kProgramCommand, static_cast<std::uint16_t>(c));
}
rtu::Request command(std::uint8_t unit, SaveCommand c) {
  return write16(unit, Reg::kSaveCommand, static_cast<std::uint16_t>(c));
}
bool is_save(const rtu::Request& request) noexcept {
  const auto* w = std::get_if<rtu::WriteRegister>(&request.pdu);
  return w != nullptr && w->address == address(Reg::kSaveCommand) &&
         w->value == static_cast<std::uint16_t>(SaveCommand::kSave);
}
rtu::Request clear_alarm(std::uint8_t unit) { return write16(unit, Reg::kClearAlarm, kClearAlarmValue); }

rtu::Request move(std::uint8_t unit, MoveCommand kind, std::int32_t value) {
  return write32(unit, static_cast<Reg>(kind), value);
}

}  // namespace motion::adam
