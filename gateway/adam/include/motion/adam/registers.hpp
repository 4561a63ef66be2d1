// ADAM NEMA8–NEMA23 integrated stepper: the register map as data (manual §7 "Register Address",
// with the corrections of §8 "Register Explanation" where the two disagree), the drive's 32-bit
// word order, and the register-level access rules a simulated slave applies.
//
// WORD ORDER (derived from every CRC-valid 32-bit example of §8, e.g. §8.29 subdivision 4000 read
// as 0F A0 00 00): a 32-bit value occupies registers N and N+1, register N holds the LOW 16 bits.
// 0xAABBCCDD goes on the wire as CC DD AA BB. This is the opposite of libmodbus's
// MODBUS_GET_INT32_FROM_INT16 / MODBUS_SET_INT32_TO_INT16: use encode32()/decode32() only.
//
// Thread contract: the table is immutable static data; every function is pure and thread-safe.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "motion/adam/rtu.hpp"

namespace motion::adam {

// Protocol addresses as they appear in the PDU (no 40001 offset). 32-bit entries name their
// first (low-word) address.
enum class Reg : std::uint16_t {
  kHardwareVersion = 0x0000,     // §8.1, 2 regs
  kFirmwareVersion = 0x0002,     // §8.2, 2 regs
  kPosition = 0x0004,            // §8.3, INT32
  kStatus = 0x0006,              // §8.4, UINT32
  kSerialTimeout = 0x0008,       // §8.5
  kBaudRate = 0x0009,            // §8.6
  kSmoothing = 0x000A,           // §8.7
  kDynamicErrorAlarm = 0x000B,   // §8.8
  kStaticErrorAlarm = 0x000C,    // §8.9
  kRatedCurrent = 0x000D,        // §8.10
  kCurrentPercentages = 0x000E,  // §8.11
  kEncoderLines = 0x000F,        // §8.12
  kDeviationWarning = 0x0010,    // §8.13
  kPositionDeviation = 0x0011,   // §8.14
  kProtectionBits = 0x0012,      // §8.15
  kFilterFrequency = 0x0013,     // §7 only
  kProgramStep = 0x0015,         // §8.16
  kPeakSpeed = 0x0016,           // §8.17
  kMinEncoderLines = 0x0017,     // §8.18
  kSpeedRpm = 0x0019,            // §8.19
  kCurrentMa = 0x001A,           // §8.20
  kInputDelayX0 = 0x001B,        // §8.21 … §8.28 (X0…X7 at 0x001B…0x0022)
  kInputDelayX1 = 0x001C,
  kInputDelayX2 = 0x001D,
  kInputDelayX3 = 0x001E,
  kInputDelayX4 = 0x001F,
  kInputDelayX5 = 0x0020,
  kInputDelayX6 = 0x0021,
  kInputDelayX7 = 0x0022,
  kSubdivision = 0x0024,           // §8.29, UINT32
  kInductance = 0x0026,            // §8.30
  kResistance = 0x0027,            // §8.31
  kPositionLoopIntegral = 0x0029,  // §8.61
  kSwSpeed1 = 0x002C,              // §7 only, 0x002C…0x0033
  kSwSpeed2 = 0x002D,
  kSwSpeed3 = 0x002E,
  kSwSpeed4 = 0x002F,
  kSwSpeed5 = 0x0030,
  kSwSpeed6 = 0x0031,
  kSwSpeed7 = 0x0032,
  kSwSpeed8 = 0x0033,
  kMaxBusVoltage = 0x0044,      // §8.32
  kMaxCurrent = 0x0045,         // §8.33
  kMaxLaggingPulses = 0x0046,   // §8.34
  kMaxLeadingPulses = 0x0047,   // §8.35
  kMinBusVoltage = 0x0048,      // §8.36
  kDriverId = 0x0066,           // §8.37
  kRotationDirection = 0x006B,  // §8.38
  kInputPolarity = 0x006C,      // §8.39
  kNegativeLimit = 0x006E,      // §8.45, INT32
  kPositiveLimit = 0x0070,      // §8.46, INT32
  kStartSpeed = 0x0096,         // §8.40
  kStopSpeed = 0x0097,          // §8.41
  kAccelerationTime = 0x0098,   // §8.42
  kDecelerationTime = 0x0099,   // §8.43
  kWorkingSpeed = 0x009A,       // §8.44
  kLimitInputs = 0x009B,        // §8.47
  kEnableHomeInputs = 0x009C,   // §8.48
  kSecondaryHome = 0x009D,      // §8.48
  kTorqueMode = 0x009E,         // §8.49
  kWorkingMode = 0x009F,        // §8.50
  kOutputsOn = 0x00A0,          // §8.51
  kOutputsOff = 0x00A1,         // §8.51
  kOutputState = 0x00A2,        // §8.51
  kAlarm = 0x00A3,              // §8.52
  kClearAlarm = 0x00A4,         // §8.52
  kAlarmOutput = 0x00A5,        // §8.51
  kRunningOutput = 0x00A6,      // §8.51
  kInPositionOutput = 0x00A7,   // §8.51
  kReminderX11 = 0x00A8,        // §8.53, coded 32-bit
  kTableSize = 0x00AA,          // §8.54
  kTablePointer = 0x00AB,       // §8.54
  kTableStart = 0x00AC,         // §8.54
  kEstopConfig = 0x00AD,        // §8.55
  kHomeDoneOutput = 0x00AE,     // §8.48
  kSpeedSwitch1 = 0x00AF,       // §8.56
  kSpeedSwitch2 = 0x00B0,
  kSpeedSwitch3 = 0x00B1,
  kSpeedSwitch4 = 0x00B2,
  kSpeedSwitch1Ext = 0x00B3,
  kSpeedSwitch2Ext = 0x00B4,
  kSpeedSwitch3Ext = 0x00B5,
  kDynamicPositioning = 0x00B6,  // §8.57, UINT32
  kSpeedSwitch4Ext = 0x00B8,
  kIoVelocityRun = 0x00BA,  // §8.58, UINT32
  kRotorOffset = 0x00BE,    // §8.59
  kPositionLoopP = 0x00BF,  // §8.60
  kSpeedLoopP = 0x00C0,     // §8.62
  kSpeedLoopI = 0x00C1,     // §8.63a
  kReminderX17 = 0x00C2,    // §8.53
  kReminderX18 = 0x00C4,
  kReminderX19 = 0x00C6,
  kVelocityCommand = 0x00C8,      // §8.65① VelocityCommand
  kHomingCommand = 0x00C9,        // §8.48   HomingCommand
  kJogCommand = 0x00CA,           // §8.65② JogCommand
  kTorqueCommand = 0x00CB,        // §8.49   TorqueCommand
  kTimedRun = 0x00CC,             // §8.65③ INT32 ms
  kRelativeMove = 0x00CE,         // §8.65④ INT32 pulses, standstill only
  kAbsoluteMove = 0x00D0,         // §8.65⑥ INT32 pulses, standstill only
  kPresetPosition = 0x00D2,       // §8.66   INT32 pulses
  kEnableCommand = 0x00D4,        // §8.67   EnableCommand
  kSpeedCentiRpm = 0x00D6,        // §8.63b  INT32 0.01 rpm
  kTargetSpeed = 0x00D8,          // §8.64   INT32 0.01 rpm
  kProgramCommand = 0x00DB,       // §8.68   ProgramCommand
  kSaveCommand = 0x00DC,          // §8.69   SaveCommand
  kTableExecute = 0x00DD,         // §8.54   TableExecute
  kRelativeMovePreempt = 0x00DE,  // §8.65⑤ INT32 pulses
  kAbsoluteMovePreempt = 0x00E8,  // §8.65⑦ INT32 pulses
};
[[nodiscard]] constexpr std::uint16_t address(Reg r) noexcept { return static_cast<std::uint16_t>(r); }

enum class RegType : std::uint8_t {
  kU16,
  kI16,
  kU32,       // 2 registers, low word first
  kI32,       // 2 registers, low word first, two's complement
  kString32,  // 2 registers (version strings, §8.1/§8.2), see decode_version()
};
[[nodiscard]] constexpr std::uint16_t register_count(RegType t) noexcept {
  return (t == RegType::kU16 || t == RegType::kI16) ? 1 : 2;
}
[[nodiscard]] constexpr unsigned bit_width(RegType t) noexcept { return 16U * register_count(t); }

enum class Access : std::uint8_t { kReadOnly, kReadWrite, kWriteOnly };

struct RegisterInfo {
  Reg reg;
  std::string_view name;  // snake_case, unique; find_register(name)
  RegType type;
  Access access;
  bool persistent;  // "memory value": kept over power cycles after Save (0x00DC = 1)
  std::string_view unit;
  std::int64_t min;  // documented range of the value (signed types: signed range)
  std::int64_t max;
  std::optional<std::int64_t> default_value;  // nullopt: "-", per model, or measured
  std::string_view meaning;                   // one line, with the manual section and any [C]/[I] decision

  [[nodiscard]] constexpr std::uint16_t first() const noexcept { return address(reg); }
  [[nodiscard]] constexpr std::uint16_t count() const noexcept { return register_count(type); }
  [[nodiscard]] constexpr bool readable() const noexcept { return access != Access::kWriteOnly; }
  [[nodiscard]] constexpr bool writable() const noexcept { return access != Access::kReadOnly; }
};

// Every documented register, ordered by address.
[[nodiscard]] std::span<const RegisterInfo> register_map() noexcept;
// The entry starting at `address` (the low word of a 32-bit entry); nullptr when none.
[[nodiscard]] const RegisterInfo* find_register(std::uint16_t address) noexcept;
// The entry covering `address` (also the high word of a 32-bit entry); nullptr for holes.
[[nodiscard]] const RegisterInfo* register_containing(std::uint16_t address) noexcept;
[[nodiscard]] const RegisterInfo* find_register(std::string_view name) noexcept;
// The entry of a Reg (every Reg has one).
[[nodiscard]] const RegisterInfo& info(Reg reg) noexcept;

// Programming area (§8.54): program steps and table data from register 300 (decimal) up.
// The manual gives no upper end; we assume the rest of the address space.
inline constexpr std::uint16_t kProgrammingAreaFirst = 300;
inline constexpr std::uint16_t kProgrammingAreaLast = 0xFFFF;

// Frame size limits of the drive: "an instruction should not exceed 200 bytes" (§8.54).
inline constexpr std::size_t kMaxDriveFrameBytes = 200;
inline constexpr std::uint16_t kMaxDriveWriteRegisters = 95;  // (200 − 9) / 2
inline constexpr std::uint16_t kMaxDriveReadRegisters = 97;  // assumed (§6 gives no limit): keeps the reply ≤ 200 bytes

// Node addresses (§5): 0 = broadcast, 1…64 = nodes.
inline constexpr std::uint8_t kMaxNodeAddress = 64;

// --- 32-bit word order (the ONE place it is decided) -------------------------------------------

// {register N, register N+1} = {low word, high word}.
[[nodiscard]] constexpr std::array<std::uint16_t, 2> encode32(std::uint32_t value) noexcept {
  return {static_cast<std::uint16_t>(value & 0xFFFFU), static_cast<std::uint16_t>(value >> 16)};
}
[[nodiscard]] constexpr std::array<std::uint16_t, 2> encode32(std::int32_t value) noexcept {
  return encode32(static_cast<std::uint32_t>(value));
}
[[nodiscard]] constexpr std::uint32_t decode32(std::uint16_t at_n, std::uint16_t at_n_plus_1) noexcept {
  return (std::uint32_t{at_n_plus_1} << 16) | at_n;
}
[[nodiscard]] constexpr std::int32_t decode32_signed(std::uint16_t at_n, std::uint16_t at_n_plus_1) noexcept {
  return static_cast<std::int32_t>(decode32(at_n, at_n_plus_1));  // two's complement (C++20)
}
[[nodiscard]] constexpr std::int16_t decode16_signed(std::uint16_t raw) noexcept {
  return static_cast<std::int16_t>(raw);
}
[[nodiscard]] constexpr std::uint16_t encode16(std::int16_t value) noexcept {
  return static_cast<std::uint16_t>(value);
}

// Version strings (§8.1, §8.2). Not stated in the manual (assumed): the two registers form a UINT32
// (low word first) holding a C string least significant byte first: registers {0x3731, 0x0030} →
// "170".
[[nodiscard]] std::string decode_version(std::uint16_t at_n, std::uint16_t at_n_plus_1);

// Value of one register entry from its registers (count() words), sign-extended for signed types.
[[nodiscard]] std::int64_t decode_value(const RegisterInfo& reg, std::span<const std::uint16_t> words) noexcept;
// Words of a value for the entry (count() words); value_out_of_range outside [min, max].
[[nodiscard]] Result<std::array<std::uint16_t, 2>> encode_value(const RegisterInfo& reg, std::int64_t value);

// --- Register-level access rules for a slave ----------------------------------------------------

struct AccessRules {
  // Undocumented addresses (the holes of the §7 table): read as 0 instead of exception 0x02.
  bool holes_read_as_zero = false;
  // Writes that cover only one half of a 32-bit register: accepted instead of exception 0x02.
  // The manual does not say; its examples always write both halves in one FC 0x10 frame.
  bool allow_partial_32bit_write = false;
  // Reject values outside the documented range with exception 0x03. The real drive's
  // behaviour is not stated in the manual.
  bool check_value_ranges = true;
};
// FC 0x03: every address documented (or holes allowed), quantity ≤ 125. Reading a write-only
// command register is allowed (it returns whatever the slave stores; the manual does not say).
[[nodiscard]] std::optional<rtu::ExceptionCode> check_read(std::uint16_t start, std::uint16_t quantity,
                                                           const AccessRules& rules = {}) noexcept;
// FC 0x06 / 0x10: every address documented and writable (0x02), no split 32-bit entry (0x02),
// quantity ≤ 95 (0x03), values within range (0x03).
[[nodiscard]] std::optional<rtu::ExceptionCode> check_write(std::uint16_t start, std::span<const std::uint16_t> values,
                                                            const AccessRules& rules = {}) noexcept;
// Dispatches on the request's function.
[[nodiscard]] std::optional<rtu::ExceptionCode> check_request(const rtu::RequestPdu& pdu,
                                                              const AccessRules& rules = {}) noexcept;

// Does the drive answer this request? No for broadcasts (§5) and for the restart command
// 0x00D4 = 0x0100 even when addressed (§8.67).
[[nodiscard]] bool expects_reply(const rtu::Request& request) noexcept;

}  // namespace motion::adam
