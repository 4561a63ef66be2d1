// Values written to the ADAM drive's control registers (manual §8.6, §8.15, §8.47–§8.50, §8.53,
// §8.54, §8.65–§8.69), as enums and bit-field structs with encode/decode, plus builders of the
// Modbus requests a master sends (unicast or broadcast, unit 0). Every command starts at the
// moment it is written (§8.65: "all running instructions can be executed separately"); there is
// no arm/trigger step.
//
// Thread contract: pure functions and value types, thread-safe.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>

#include "motion/adam/registers.hpp"
#include "motion/adam/result.hpp"
#include "motion/adam/rtu.hpp"

namespace motion::adam {

// 0x00C8 (§8.65①). Speed from 0x009A.
enum class VelocityCommand : std::uint16_t {
  kRampedStop = 0,  // decelerate over 0x0099 to the stop speed, then stop
  kRunForward = 1,
  kEmergencyStop = 256,  // speed to 0 at once
  kRunReverse = 257,
};

// 0x00D4 (§8.67). restart gets no reply, even when addressed to one node.
enum class EnableCommand : std::uint16_t { kEnable = 0, kRelease = 1, kRestart = 0x0100 };

// 0x00DB (§8.68) and 0x00DC (§8.69).
enum class ProgramCommand : std::uint16_t { kStop = 0, kRun = 1 };
enum class SaveCommand : std::uint16_t { kRestoreFactory = 0, kSave = 1 };

// 0x00A4 (§8.52): the only documented value.
inline constexpr std::uint16_t kClearAlarmValue = 0;

// 0x009F (§8.50).
enum class WorkingMode : std::uint16_t { kTwinPulse = 1, kPulseDirection = 2, kIoControl = 3 };

// 0x0009 (§8.6).
enum class BaudCode : std::uint16_t {
  kB300 = 1,
  kB600 = 2,
  kB1200 = 3,
  kB2400 = 4,
  kB4800 = 5,
  kB9600 = 6,
  kB14400 = 7,
  kB19200 = 8,
  kB38400 = 9,
  kB56000 = 10,
  kB57600 = 11,
  kB115200 = 12,
  kB230400 = 13,
  kB460800 = 14,
  kB921600 = 15,
};
[[nodiscard]] std::optional<std::uint32_t> baud_rate(BaudCode code) noexcept;  // nullopt: not 1…15
[[nodiscard]] std::optional<BaudCode> baud_code(std::uint32_t bits_per_second) noexcept;

// 0x0012 (§8.15): 1 = prohibited / disabled.
enum class ProtectionBit : std::uint16_t {
  kPhaseOpenAlarmOff = 1U << 0,
  kUnderVoltageAlarmOff = 1U << 1,
  kUnderVoltageResetOff = 1U << 2,
  kTestModeOff = 1U << 3,
  kDisabledAtPowerOn = 1U << 4,
  kOfflineBrakeReleaseOff = 1U << 5,
};

enum class Rotation : std::uint8_t { kCw = 0, kCcw = 1 };         // jog, secondary home
enum class Travel : std::uint8_t { kForward = 0, kReverse = 1 };  // homing, torque
enum class StopMethod : std::uint8_t { kDecelerate = 0, kImmediate = 1 };

// 0x00CA (§8.65②): bit 15 direction, 14…6 speed rpm (0…511), 5 stop method, 0 run.
struct JogCommand {
  Rotation direction = Rotation::kCw;
  std::uint16_t speed_rpm = 0;  // 0…511
  StopMethod stop = StopMethod::kDecelerate;
  bool run = false;  // false: stop with `stop`
  friend bool operator==(const JogCommand&, const JogCommand&) = default;
};
[[nodiscard]] Result<std::uint16_t> encode(const JogCommand& c);
[[nodiscard]] JogCommand decode_jog(std::uint16_t word) noexcept;

// 0x00C9 (§8.48): bit 15 direction, 14…6 speed rpm (0…511), 5 stop on home signal, 4…0
// secondary-home speed in 5 rpm units (0 = no secondary pass).
struct HomingCommand {
  Travel direction = Travel::kForward;
  std::uint16_t speed_rpm = 0;  // 0…511
  StopMethod stop = StopMethod::kDecelerate;
  std::uint8_t secondary_speed_code = 0;  // 0…31, × 5 rpm
  friend bool operator==(const HomingCommand&, const HomingCommand&) = default;
};
inline constexpr std::uint16_t kSecondaryHomeRpmPerCode = 5;
[[nodiscard]] Result<std::uint16_t> encode(const HomingCommand& c);
[[nodiscard]] HomingCommand decode_homing(std::uint16_t word) noexcept;

// 0x00CB (§8.49): bit 15 direction, 14…1 offset pulses (collision homing), 0 run.
struct TorqueCommand {
  Travel direction = Travel::kForward;
  std::uint16_t offset_pulses = 0;  // 0…16383
  bool run = false;
  friend bool operator==(const TorqueCommand&, const TorqueCommand&) = default;
};
[[nodiscard]] Result<std::uint16_t> encode(const TorqueCommand& c);
[[nodiscard]] TorqueCommand decode_torque(std::uint16_t word) noexcept;

// 0x00DD (§8.54): bit 15 absolute/relative, bits 14…12 pointer arithmetic (0 add, 1 subtract),
// bits 11…0 pointer step. Executes the entry at the table pointer, then moves the pointer.
enum class TableEntryKind : std::uint8_t { kAbsolute = 0, kRelative = 1 };
enum class PointerArithmetic : std::uint8_t { kAdd = 0, kSubtract = 1 };
struct TableExecute {
  TableEntryKind kind = TableEntryKind::kAbsolute;
  PointerArithmetic arithmetic = PointerArithmetic::kAdd;
  std::uint16_t step = 0;  // 0…4095
  friend bool operator==(const TableExecute&, const TableExecute&) = default;
};
[[nodiscard]] Result<std::uint16_t> encode(const TableExecute& c);
// nullopt when bits 14…12 hold anything but 0 or 1.
[[nodiscard]] std::optional<TableExecute> decode_table_execute(std::uint16_t word) noexcept;

// 0x009B hardware limits, and 0x009C enable (high byte) / home (low byte) inputs (§8.47, §8.48):
// per byte bits 7…5 function (000 off, 001 on), bit 4 active level (0 low/PNP, 1 high/NPN),
// bits 3…0 input X0…X15 zero-based.
struct InputAssignment {
  bool enabled = false;
  bool active_high = false;
  std::uint8_t input = 0;  // 0…15 = X0…X15
  friend bool operator==(const InputAssignment&, const InputAssignment&) = default;
};
struct InputPair {  // 0x009B: high = negative limit, low = positive limit; 0x009C: high = enable, low = home
  InputAssignment high;
  InputAssignment low;
  friend bool operator==(const InputPair&, const InputPair&) = default;
};
[[nodiscard]] Result<std::uint16_t> encode(const InputPair& c);
[[nodiscard]] InputPair decode_input_pair(std::uint16_t word) noexcept;

// Position reminders 0x00A8 (X11), 0x00C2/C4/C6 (X17…X19), §8.53: bit 31 = comparison,
// bits 30…0 = threshold, 31-bit two's complement.
enum class ReminderComparison : std::uint8_t { kAtOrAbove = 0, kBelow = 1 };
struct PositionReminder {
  ReminderComparison comparison = ReminderComparison::kAtOrAbove;
  std::int32_t threshold = 0;  // −2^30 … 2^30 − 1
  friend bool operator==(const PositionReminder&, const PositionReminder&) = default;
};
[[nodiscard]] Result<std::uint32_t> encode(const PositionReminder& r);
[[nodiscard]] PositionReminder decode_reminder(std::uint32_t raw) noexcept;

// ---- Request builders (unit 0 = broadcast) -----------------------------------------------------

// FC 0x06 of one 16-bit value.
[[nodiscard]] rtu::Request write16(std::uint8_t unit, Reg reg, std::uint16_t value);
// FC 0x10, quantity 2, low word first: the only way the manual writes a 32-bit register.
[[nodiscard]] rtu::Request write32(std::uint8_t unit, Reg reg, std::int32_t value);
[[nodiscard]] rtu::Request write32(std::uint8_t unit, Reg reg, std::uint32_t value);
// FC 0x03 of a whole entry (1 or 2 registers).
[[nodiscard]] rtu::Request read(std::uint8_t unit, Reg reg);

[[nodiscard]] rtu::Request command(std::uint8_t unit, VelocityCommand c);
[[nodiscard]] rtu::Request command(std::uint8_t unit, EnableCommand c);
[[nodiscard]] rtu::Request command(std::uint8_t unit, ProgramCommand c);
[[nodiscard]] rtu::Request command(std::uint8_t unit, SaveCommand c);
// A Save (0x00DC = 1) erases flash for 0.1 s, all outputs off meanwhile (§8.69): its reply comes
// that much later.
inline constexpr std::chrono::milliseconds kSaveEraseTime{100};
[[nodiscard]] bool is_save(const rtu::Request& request) noexcept;
[[nodiscard]] rtu::Request clear_alarm(std::uint8_t unit);

// 32-bit motion commands (§8.65③–⑦, §8.66).
enum class MoveCommand : std::uint16_t {
  kTimedRunMs = address(Reg::kTimedRun),
  kRelativeAtStandstill = address(Reg::kRelativeMove),
  kAbsoluteAtStandstill = address(Reg::kAbsoluteMove),
  kRelativePreempting = address(Reg::kRelativeMovePreempt),
  kAbsolutePreempting = address(Reg::kAbsoluteMovePreempt),
  kPresetPosition = address(Reg::kPresetPosition),
};
[[nodiscard]] rtu::Request move(std::uint8_t unit, MoveCommand kind, std::int32_t value);

}  // namespace motion::adam
