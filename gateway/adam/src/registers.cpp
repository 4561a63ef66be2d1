#include "motion/adam/registers.hpp"

#include <algorithm>
#include <limits>

namespace motion::adam {
namespace {

using rtu::ExceptionCode;

constexpr std::int64_t kU16 = 0xFFFF;
constexpr std::int64_t kI16Min = std::numeric_limits<std::int16_t>::min();
constexpr std::int64_t kI16Max = std::numeric_limits<std::int16_t>::max();
constexpr std::int64_t kU32 = 0xFFFFFFFF;
constexpr std::int64_t kI32Min = std::numeric_limits<std::int32_t>::min();
constexpr std::int64_t kI32Max = std::numeric_limits<std::int32_t>::max();
constexpr std::optional<std::int64_t> kNone = std::nullopt;

constexpr auto RO = Access::kReadOnly;
constexpr auto RW = Access::kReadWrite;
constexpr auto WO = Access::kWriteOnly;
constexpr bool kMem = true;   // "memory value": persisted by Save
constexpr bool kVol = false;  // volatile / live / command

// clang-format off
// Address order. Sources: §7 table (defaults, access, units) corrected by §8 where they disagree;
// each [C] names the conflict and the choice; [I] marks what the manual does not state (an assumption).
constexpr RegisterInfo kMap[] = {
  {Reg::kHardwareVersion, "hardware_version", RegType::kString32, RO, kVol, "-", 0, kU32, kNone, "§8.1 hardware version, fixed per model; C string in a low-word-first UINT32 [I]"},
  {Reg::kFirmwareVersion, "firmware_version", RegType::kString32, RO, kVol, "-", 0, kU32, kNone, "§8.2 firmware version, fixed per model; C string in a low-word-first UINT32 [I]"},
  {Reg::kPosition, "position", RegType::kI32, RO, kVol, "pulses", kI32Min, kI32Max, kNone, "§8.3 real-time absolute position (encoder position in closed loop)"},
  {Reg::kStatus, "status", RegType::kU32, RO, kVol, "bits", 0, 0x1FFFFF, kNone, "§8.4 inputs X0…X7, motion state X8/X9, virtual inputs X10…X20 (decode_status)"},
  {Reg::kSerialTimeout, "serial_timeout", RegType::kU16, RW, kMem, "10 ms", 0, kU16, 0, "§8.5 serial watchdog, 0 = off; [C] §7 says ms, §8.5 text and example say 10 ms"},
  {Reg::kBaudRate, "baud_rate", RegType::kU16, RW, kMem, "code", 1, 15, 12, "§8.6 baud rate code 1…15 (BaudCode); effective at once, persists only after Save"},
  {Reg::kSmoothing, "smoothing", RegType::kU16, RW, kMem, "-", 1, 2500, 250, "§8.7 smoothing constant, pulse delay = 1000/value ms (25 suggested closed loop)"},
  {Reg::kDynamicErrorAlarm, "dynamic_error_alarm", RegType::kU16, RW, kMem, "full steps", 0, kU16, 200, "§8.8 dynamic position-error alarm threshold (closed loop), 0 = off"},
  {Reg::kStaticErrorAlarm, "static_error_alarm", RegType::kU16, RW, kMem, "full steps", 0, kU16, 100, "§8.9 static position-error alarm threshold (closed loop), 0 = off; [C] example reads 200, §7 default used"},
  {Reg::kRatedCurrent, "rated_current", RegType::kU16, RW, kMem, "0.01 A", 10, 650, kNone, "§8.10 rated current 0.10…6.50 A, default per model"},
  {Reg::kCurrentPercentages, "current_percentages", RegType::kU16, RW, kMem, "% | %", 0, kU16, kNone, "§8.11 bits 15…8 min running current % (closed loop), bits 7…0 idle current %; example reads 0x1919"},
  {Reg::kEncoderLines, "encoder_lines", RegType::kU16, RW, kMem, "lines", 0, kU16, 1000, "§8.12 encoder lines, counts/rev = 4 × lines"},
  {Reg::kDeviationWarning, "deviation_warning", RegType::kU16, RW, kMem, "full steps", 1, kU16, 20, "§8.13 position deviation above which X10 is set"},
  {Reg::kPositionDeviation, "position_deviation", RegType::kI16, RO, kVol, "0.01 pulse", kI16Min, kI16Max, kNone, "§8.14 rotor minus command position, + = leading; [C] §7 says UINT16 RW pulses, §8 used"},
  {Reg::kProtectionBits, "protection_bits", RegType::kU16, RW, kMem, "bits", 0, 0x3F, 0, "§8.15 protection/behaviour bits 0…5 (ProtectionBit); not in §7, [C] 'Read' but example writes → RW"},
  {Reg::kFilterFrequency, "filter_frequency", RegType::kU16, RW, kVol, "Hz", 0, kU16, 425, "§7 only, no semantics; [C] default '425K' does not fit 16 bits, [I] 425"},
  {Reg::kProgramStep, "program_step", RegType::kU16, RO, kVol, "step", 0, 4095, 0, "§8.16 execution position of the stored program"},
  {Reg::kPeakSpeed, "peak_speed", RegType::kU16, RW, kVol, "rpm", 0, kU16, kNone, "§8.17 highest speed seen, write 0 to reset"},
  {Reg::kMinEncoderLines, "min_encoder_lines", RegType::kU16, RW, kMem, "lines", 0, kU16, 200, "§8.18 below this many encoder lines the drive runs open loop; [C] text says 50, §7 and example 200"},
  {Reg::kSpeedRpm, "speed_rpm", RegType::kI16, RO, kVol, "rpm", kI16Min, kI16Max, kNone, "§8.19 real-time speed, negative = CCW"},
  {Reg::kCurrentMa, "current_ma", RegType::kU16, RO, kVol, "mA", 0, kU16, kNone, "§8.20 real-time current"},
  {Reg::kInputDelayX0, "input_delay_x0", RegType::kU16, RW, kMem, "ms", 0, kU16, 2, "§8.21 input X0 debounce delay"},
  {Reg::kInputDelayX1, "input_delay_x1", RegType::kU16, RW, kMem, "ms", 0, kU16, 2, "§8.22 input X1 debounce delay"},
  {Reg::kInputDelayX2, "input_delay_x2", RegType::kU16, RW, kMem, "ms", 0, kU16, 2, "§8.23 input X2 debounce delay"},
  {Reg::kInputDelayX3, "input_delay_x3", RegType::kU16, RW, kMem, "ms", 0, kU16, 2, "§8.24 input X3 debounce delay"},
  {Reg::kInputDelayX4, "input_delay_x4", RegType::kU16, RW, kMem, "ms", 0, kU16, 2, "§8.25 input X4 debounce delay"},
  {Reg::kInputDelayX5, "input_delay_x5", RegType::kU16, RW, kMem, "ms", 0, kU16, 2, "§8.26 input X5 debounce delay"},
  {Reg::kInputDelayX6, "input_delay_x6", RegType::kU16, RW, kMem, "ms", 0, kU16, 2, "§8.27 input X6 debounce delay"},
  {Reg::kInputDelayX7, "input_delay_x7", RegType::kU16, RW, kMem, "ms", 0, kU16, 2, "§8.28 input X7 debounce delay"},
  {Reg::kSubdivision, "subdivision", RegType::kU32, RW, kMem, "pulses/rev", 200, 1000000, 4000, "§8.29 microsteps per revolution; write both words with FC 0x10"},
  {Reg::kInductance, "inductance", RegType::kU16, RW, kMem, "0.01 mH", 0, kU16, kNone, "§8.30 motor inductance, measured at power-up unless saved; [C] §7 says mH"},
  {Reg::kResistance, "resistance", RegType::kU16, RW, kMem, "0.01 ohm", 0, kU16, kNone, "§8.31 motor resistance, measured at power-up unless saved; [C] §7 says ohm"},
  {Reg::kPositionLoopIntegral, "position_loop_integral", RegType::kU16, RW, kMem, "1/10000", 0, kU16, 100, "§8.61 position-loop integral (closed loop), smaller = stiffer"},
  {Reg::kSwSpeed1, "sw_speed_1", RegType::kU16, RW, kVol, "rpm", 0, kU16, 5, "§7 only: switch-selectable speed 1 [I]"},
  {Reg::kSwSpeed2, "sw_speed_2", RegType::kU16, RW, kVol, "rpm", 0, kU16, 10, "§7 only: switch-selectable speed 2 [I]"},
  {Reg::kSwSpeed3, "sw_speed_3", RegType::kU16, RW, kVol, "rpm", 0, kU16, 15, "§7 only: switch-selectable speed 3 [I]"},
  {Reg::kSwSpeed4, "sw_speed_4", RegType::kU16, RW, kVol, "rpm", 0, kU16, 30, "§7 only: switch-selectable speed 4 [I]"},
  {Reg::kSwSpeed5, "sw_speed_5", RegType::kU16, RW, kVol, "rpm", 0, kU16, 60, "§7 only: switch-selectable speed 5 [I]"},
  {Reg::kSwSpeed6, "sw_speed_6", RegType::kU16, RW, kVol, "rpm", 0, kU16, 90, "§7 only: switch-selectable speed 6 [I]"},
  {Reg::kSwSpeed7, "sw_speed_7", RegType::kU16, RW, kVol, "rpm", 0, kU16, 120, "§7 only: switch-selectable speed 7 [I]"},
  {Reg::kSwSpeed8, "sw_speed_8", RegType::kU16, RW, kVol, "rpm", 0, kU16, 150, "§7 only: switch-selectable speed 8 [I]"},
  {Reg::kMaxBusVoltage, "max_bus_voltage", RegType::kU16, RW, kVol, "0.01 V", 0, kU16, kNone, "§8.32 highest bus voltage seen, write 0 to reset"},
  {Reg::kMaxCurrent, "max_current", RegType::kU16, RW, kVol, "0.01 A", 0, kU16, kNone, "§8.33 highest current seen, write 0 to reset"},
  {Reg::kMaxLaggingPulses, "max_lagging_pulses", RegType::kU16, RW, kVol, "pulses", 0, kU16, kNone, "§8.34 most lagging pulses seen, write 0 to reset"},
  {Reg::kMaxLeadingPulses, "max_leading_pulses", RegType::kU16, RW, kVol, "pulses", 0, kU16, kNone, "§8.35 most leading pulses seen, write 0 to reset"},
  {Reg::kMinBusVoltage, "min_bus_voltage", RegType::kU16, RW, kVol, "0.01 V", 0, kU16, kNone, "§8.36 lowest bus voltage seen, write 0 to reset"},
  {Reg::kDriverId, "driver_id", RegType::kU16, RW, kMem, "-", 1, kU16, 1, "§8.37 node address = driver_id + switch SW − 1"},
  {Reg::kRotationDirection, "rotation_direction", RegType::kU16, RW, kMem, "0 CW / 1 CCW", 0, 1, 0, "§8.38 physical shaft direction for positive moves"},
  {Reg::kInputPolarity, "input_polarity", RegType::kU16, WO, kVol, "bits", 0, kU16, 0, "§8.39 bit n toggles X(n) inversion, bit 8+n restores it; not saved"},
  {Reg::kNegativeLimit, "negative_limit", RegType::kI32, RW, kMem, "pulses", kI32Min, kI32Max, kI32Min, "§8.45 negative software limit (ignored once hardware limits are set)"},
  {Reg::kPositiveLimit, "positive_limit", RegType::kI32, RW, kMem, "pulses", kI32Min, kI32Max, kI32Max, "§8.46 positive software limit (ignored once hardware limits are set)"},
  {Reg::kStartSpeed, "start_speed", RegType::kU16, RW, kMem, "rpm", 0, 300, 50, "§8.40 speed motion starts at; a lower target speed is raised to it"},
  {Reg::kStopSpeed, "stop_speed", RegType::kU16, RW, kMem, "rpm", 0, 1000, 50, "§8.41 speed at which the deceleration ends"},
  {Reg::kAccelerationTime, "acceleration_time", RegType::kU16, RW, kMem, "ms", 0, kU16, 120, "§8.42 time from start speed to target speed"},
  {Reg::kDecelerationTime, "deceleration_time", RegType::kU16, RW, kMem, "ms", 0, kU16, 120, "§8.43 time from target speed to stop speed"},
  {Reg::kWorkingSpeed, "working_speed", RegType::kU16, RW, kMem, "rpm", 0, 1000, 300, "§8.44 working speed used by 0x00C8/0x00CC; [I] same setpoint as 0x00D8"},
  {Reg::kLimitInputs, "limit_inputs", RegType::kU16, RW, kMem, "bits", 0, kU16, kNone, "§8.47 hardware limit inputs (LimitInputs), example reads 0"},
  {Reg::kEnableHomeInputs, "enable_home_inputs", RegType::kU16, RW, kMem, "bits", 0, kU16, kNone, "§8.48 enable input (high byte) and home input (low byte), LimitInputs layout"},
  {Reg::kSecondaryHome, "secondary_home", RegType::kU16, RW, kMem, "bits", 0, kU16, kNone, "§8.48 bit 15 direction (0 CW), bits 14…0 secondary-home distance in pulses"},
  {Reg::kTorqueMode, "torque_mode", RegType::kU16, RW, kMem, "bits", 0, kU16, kNone, "§8.49 bits 15…8 mode (1 collision home, 2 one-way torque, 3 constant torque), bits 7…0 level"},
  {Reg::kWorkingMode, "working_mode", RegType::kU16, RW, kMem, "mode", 1, 3, 3, "§8.50 WorkingMode: 1 twin pulse, 2 pulse+direction, 3 I/O control"},
  {Reg::kOutputsOn, "outputs_on", RegType::kU16, WO, kVol, "bit mask", 0, 0xFF, kNone, "§8.51 bit n switches Y(n) on"},
  {Reg::kOutputsOff, "outputs_off", RegType::kU16, WO, kVol, "bit mask", 0, 0xFF, kNone, "§8.51 bit n switches Y(n) off"},
  {Reg::kOutputState, "output_state", RegType::kU16, RO, kVol, "bit mask", 0, 0xFF, kNone, "§8.51 bit n = Y(n) is on"},
  {Reg::kAlarm, "alarm", RegType::kU16, RO, kVol, "4-bit codes", 0, kU16, kNone, "§8.52 current alarm (bits 3…0) and three history nibbles (decode_alarms)"},
  {Reg::kClearAlarm, "clear_alarm", RegType::kU16, WO, kVol, "-", 0, 0, kNone, "§8.52 write 0 to clear the alarm"},
  {Reg::kAlarmOutput, "alarm_output", RegType::kU16, RW, kMem, "bits", 0, kU16, 0x0101, "§8.51 alarm output: bits 15…8 polarity, bits 7…0 port Y0…Y7 = 1…8, 0 = off"},
  {Reg::kRunningOutput, "running_output", RegType::kU16, RW, kMem, "bits", 0, kU16, 0x0202, "§8.51 running output, same layout as alarm_output"},
  {Reg::kInPositionOutput, "in_position_output", RegType::kU16, RW, kMem, "bits", 0, kU16, 0x0202, "§8.51 in-position output, same layout as alarm_output"},
  {Reg::kReminderX11, "reminder_x11", RegType::kI32, RW, kMem, "coded", kI32Min, kI32Max, kNone, "§8.53 position reminder for X11 (PositionReminder coding)"},
  {Reg::kTableSize, "table_size", RegType::kU16, RW, kMem, "entries", 1, 2048, kNone, "§8.54 number of table entries"},
  {Reg::kTablePointer, "table_pointer", RegType::kU16, RW, kMem, "entry", 0, 4095, kNone, "§8.54 index of the next table entry to execute"},
  {Reg::kTableStart, "table_start", RegType::kU16, RW, kMem, "registers", 0, 2048, kNone, "§8.54 table start as an offset from register 300; [C] range says 300…2048 but the example writes 200 for register 500 [I]"},
  {Reg::kEstopConfig, "estop_config", RegType::kU16, RW, kMem, "bits", 0, 0x7FFF, kNone, "§8.55 e-stop inputs (two groups) and output"},
  {Reg::kHomeDoneOutput, "home_done_output", RegType::kU16, RW, kMem, "bits", 0, kU16, kNone, "§8.48 home-done output: bits 15…8 polarity, bits 7…0 port Y0…Y7 = 1…8"},
  {Reg::kSpeedSwitch1, "speed_switch_1", RegType::kU16, RW, kMem, "bits", 0, kU16, kNone, "§8.56 speed switching slot 1 (highest priority)"},
  {Reg::kSpeedSwitch2, "speed_switch_2", RegType::kU16, RW, kMem, "bits", 0, kU16, kNone, "§8.56 speed switching slot 2"},
  {Reg::kSpeedSwitch3, "speed_switch_3", RegType::kU16, RW, kMem, "bits", 0, kU16, kNone, "§8.56 speed switching slot 3"},
  {Reg::kSpeedSwitch4, "speed_switch_4", RegType::kU16, RW, kMem, "bits", 0, kU16, kNone, "§8.56 speed switching slot 4"},
  {Reg::kSpeedSwitch1Ext, "speed_switch_1_ext", RegType::kU16, RW, kMem, "bit 15 + rpm", 0, kU16, 0, "§8.56 slot 1: bit 15 input-code bit 4, bits 14…0 speed 0…5000 rpm"},
  {Reg::kSpeedSwitch2Ext, "speed_switch_2_ext", RegType::kU16, RW, kMem, "bit 15 + rpm", 0, kU16, 0, "§8.56 slot 2 extension"},
  {Reg::kSpeedSwitch3Ext, "speed_switch_3_ext", RegType::kU16, RW, kMem, "bit 15 + rpm", 0, kU16, 0, "§8.56 slot 3 extension"},
  {Reg::kDynamicPositioning, "dynamic_positioning", RegType::kU32, RW, kMem, "bits", 0, kU32, 0, "§8.57 input-triggered fixed-length stop while moving"},
  {Reg::kSpeedSwitch4Ext, "speed_switch_4_ext", RegType::kU16, RW, kMem, "bit 15 + rpm", 0, kU16, 0, "§8.56 slot 4 extension"},
  {Reg::kIoVelocityRun, "io_velocity_run", RegType::kU32, RW, kMem, "bits", 0, kU32, kNone, "§8.58 input-level-triggered velocity run, four 8-bit groups"},
  {Reg::kRotorOffset, "rotor_offset", RegType::kI16, RW, kMem, "pulses", -80, 80, 0, "§8.59 rotor synchronisation offset (closed loop); [C] §7 unit 1/4000 deg"},
  {Reg::kPositionLoopP, "position_loop_p", RegType::kU16, RW, kMem, "1/100", 0, kU16, 100, "§8.60 position-loop proportional gain"},
  {Reg::kSpeedLoopP, "speed_loop_p", RegType::kU16, RW, kMem, "1/100", 0, kU16, 3200, "§8.62 speed-loop proportional gain; [C] example reads 100, §7 default used"},
  {Reg::kSpeedLoopI, "speed_loop_i", RegType::kU16, RW, kMem, "1/100", 0, kU16, 25, "§8.63a speed-loop integral; [C] example reads 1000, §7 default used"},
  {Reg::kReminderX17, "reminder_x17", RegType::kI32, RW, kMem, "coded", kI32Min, kI32Max, 1073741823, "§8.53 position reminder for X17"},
  {Reg::kReminderX18, "reminder_x18", RegType::kI32, RW, kMem, "coded", kI32Min, kI32Max, 1073741823, "§8.53 position reminder for X18"},
  {Reg::kReminderX19, "reminder_x19", RegType::kI32, RW, kMem, "coded", kI32Min, kI32Max, 1073741823, "§8.53 position reminder for X19"},
  {Reg::kVelocityCommand, "velocity_command", RegType::kU16, WO, kVol, "code", 0, 257, kNone, "§8.65① VelocityCommand: 0 ramped stop, 1 forward, 256 e-stop, 257 reverse"},
  {Reg::kHomingCommand, "homing_command", RegType::kU16, WO, kVol, "bits", 0, kU16, kNone, "§8.48 start homing (HomingCommand)"},
  {Reg::kJogCommand, "jog_command", RegType::kU16, WO, kVol, "bits", 0, kU16, kNone, "§8.65② jog start/stop (JogCommand)"},
  {Reg::kTorqueCommand, "torque_command", RegType::kU16, WO, kVol, "bits", 0, kU16, kNone, "§8.49 start/stop constant torque (TorqueCommand), closed loop"},
  {Reg::kTimedRun, "timed_run", RegType::kI32, WO, kVol, "ms", kI32Min, kI32Max, kNone, "§8.65③ run |value| ms at working speed, sign = direction"},
  {Reg::kRelativeMove, "relative_move", RegType::kI32, WO, kVol, "pulses", kI32Min, kI32Max, kNone, "§8.65④ relative move, executed only at standstill"},
  {Reg::kAbsoluteMove, "absolute_move", RegType::kI32, WO, kVol, "pulses", kI32Min, kI32Max, kNone, "§8.65⑥ absolute move, executed only at standstill"},
  {Reg::kPresetPosition, "preset_position", RegType::kI32, RW, kVol, "pulses", kI32Min, kI32Max, 0, "§8.66 set the position counter; [C] §7 says RO, §8.66 writes it"},
  {Reg::kEnableCommand, "enable_command", RegType::kU16, WO, kVol, "code", 0, 0x0100, kNone, "§8.67 EnableCommand: 0 enable, 1 release, 0x0100 restart (no reply)"},
  {Reg::kSpeedCentiRpm, "speed_centi_rpm", RegType::kI32, RO, kVol, "0.01 rpm", kI32Min, kI32Max, 0, "§8.63b real-time speed; [C] §8.63b says rpm, §7 0.01 rpm (used)"},
  {Reg::kTargetSpeed, "target_speed", RegType::kI32, RW, kMem, "0.01 rpm", -999999, 999999, 30000, "§8.64 target speed (§7 'Actual speed'); [I] same setpoint as 0x009A"},
  {Reg::kProgramCommand, "program_command", RegType::kU16, WO, kVol, "code", 0, 1, kNone, "§8.68 ProgramCommand: 1 run stored program, 0 stop"},
  {Reg::kSaveCommand, "save_command", RegType::kU16, WO, kVol, "code", 0, 1, kNone, "§8.69 SaveCommand: 1 save to flash, 0 restore factory settings"},
  {Reg::kTableExecute, "table_execute", RegType::kU16, WO, kVol, "bits", 0, kU16, kNone, "§8.54 execute the table entry at the pointer (TableExecute)"},
  {Reg::kRelativeMovePreempt, "relative_move_preempt", RegType::kI32, WO, kVol, "pulses", kI32Min, kI32Max, kNone, "§8.65⑤ relative move, pre-empts the running command"},
  {Reg::kAbsoluteMovePreempt, "absolute_move_preempt", RegType::kI32, WO, kVol, "pulses", kI32Min, kI32Max, kNone, "§8.65⑦ absolute move, pre-empts the running command (§7 rows garbled)"},
};
// clang-format on

constexpr bool sorted_without_overlap() {
  for (std::size_t i = 1; i < std::size(kMap); ++i) {
    if (kMap[i - 1].first() + kMap[i - 1].count() > kMap[i].first()) return false;
  }
  return true;
}
static_assert(sorted_without_overlap(), "register map must be sorted by address without overlaps");

bool in_programming_area(std::uint32_t address) {
  return address >= kProgrammingAreaFirst && address <= kProgrammingAreaLast;
}

std::int64_t raw_of(RegType type, std::uint32_t raw) {
  switch (type) {
    case RegType::kI16: return decode16_signed(static_cast<std::uint16_t>(raw));
    case RegType::kI32: return static_cast<std::int32_t>(raw);
    case RegType::kU16:
    case RegType::kU32:
    case RegType::kString32: break;
  }
  return raw;
}

}  // namespace

std::span<const RegisterInfo> register_map() noexcept { return kMap; }

const RegisterInfo* register_containing(std::uint16_t addr) noexcept {
  const auto it = std::upper_bound(std::begin(kMap), std::end(kMap), addr,
                                   [](std::uint16_t a, const RegisterInfo& r) { return a < r.first(); });
  if (it == std::begin(kMap)) return nullptr;
  const RegisterInfo& candidate = *(it - 1);
  return addr < candidate.first() + candidate.count() ? &candidate : nullptr;
}

const RegisterInfo* find_register(std::uint16_t addr) noexcept {
  const RegisterInfo* r = register_containing(addr);
  return (r != nullptr && r->first() == addr) ? r : nullptr;
}

const RegisterInfo* find_register(std::string_view name) noexcept {
  const auto it = std::find_if(std::begin(kMap), std::end(kMap), [&](const RegisterInfo& r) { return r.name == name; });
  return it == std::end(kMap) ? nullptr : &*it;
}

const RegisterInfo& info(Reg reg) noexcept { return *find_register(address(reg)); }

std::string decode_version(std::uint16_t at_n, std::uint16_t at_n_plus_1) {
  const std::uint32_t packed = decode32(at_n, at_n_plus_1);
  std::string out;
  for (unsigned shift = 0; shift < 32; shift += 8) {
    const auto c = static_cast<char>((packed >> shift) & 0xFFU);
    if (c == '\0') break;
    out.push_back(c);
  }
  return out;
}

std::int64_t decode_value(const RegisterInfo& reg, std::span<const std::uint16_t> words) noexcept {
  if (words.empty()) return 0;
  const std::uint32_t raw = reg.count() == 1 || words.size() < 2 ? words[0] : decode32(words[0], words[1]);
  return raw_of(reg.type, raw);
}

Result<std::array<std::uint16_t, 2>> encode_value(const RegisterInfo& reg, std::int64_t value) {
  if (value < reg.min || value > reg.max) return AdamErrc::kValueOutOfRange;
  const auto raw = static_cast<std::uint32_t>(value);  // two's complement for negative values
  if (reg.count() == 1) return std::array<std::uint16_t, 2>{static_cast<std::uint16_t>(raw), 0};
  return encode32(raw);
}

std::optional<ExceptionCode> check_read(std::uint16_t start, std::uint16_t quantity,
                                        const AccessRules& rules) noexcept {
  if (quantity == 0 || quantity > rtu::kMaxReadQuantity) return ExceptionCode::kIllegalDataValue;
  for (std::uint32_t a = start; a < std::uint32_t{start} + quantity; ++a) {
    if (a > 0xFFFF) return ExceptionCode::kIllegalDataAddress;
    if (in_programming_area(a) || rules.holes_read_as_zero) continue;
    if (register_containing(static_cast<std::uint16_t>(a)) == nullptr) return ExceptionCode::kIllegalDataAddress;
  }
  return std::nullopt;
}

std::optional<ExceptionCode> check_write(std::uint16_t start, std::span<const std::uint16_t> values,
                                         const AccessRules& rules) noexcept {
  if (values.empty() || values.size() > kMaxDriveWriteRegisters) return ExceptionCode::kIllegalDataValue;
  const std::uint32_t end = std::uint32_t{start} + static_cast<std::uint32_t>(values.size());
  if (end > 0x10000) return ExceptionCode::kIllegalDataAddress;
  std::optional<ExceptionCode> value_error;
  for (std::uint32_t a = start; a < end;) {
    if (in_programming_area(a)) {
      ++a;
      continue;
    }
    const RegisterInfo* reg = register_containing(static_cast<std::uint16_t>(a));
    if (reg == nullptr || !reg->writable()) return ExceptionCode::kIllegalDataAddress;
    const std::uint32_t reg_end = std::uint32_t{reg->first()} + reg->count();
    const bool whole = reg->first() == a && reg_end <= end;
    if (!whole) {
      if (!rules.allow_partial_32bit_write) return ExceptionCode::kIllegalDataAddress;
      a = std::min(reg_end, end);
      continue;
    }
    const auto words = values.subspan(a - start, reg->count());
    const std::int64_t value = decode_value(*reg, words);
    if (rules.check_value_ranges && (value < reg->min || value > reg->max))
      value_error = ExceptionCode::kIllegalDataValue;
    a = reg_end;
  }
  return value_error;  // address errors take precedence over value errors
}

std::optional<ExceptionCode> check_request(const rtu::RequestPdu& pdu, const AccessRules& rules) noexcept {
  if (const auto* read = std::get_if<rtu::ReadRegisters>(&pdu)) return check_read(read->start, read->quantity, rules);
  if (const auto* write = std::get_if<rtu::WriteRegister>(&pdu)) {
    const std::uint16_t value = write->value;
    return check_write(write->address, std::span<const std::uint16_t>(&value, 1), rules);
  }
  if (const auto* writes = std::get_if<rtu::WriteRegisters>(&pdu))
    return check_write(writes->start, writes->values, rules);
  return ExceptionCode::kIllegalFunction;  // no function this drive serves (§6)
}

bool expects_reply(const rtu::Request& request) noexcept {
  if (rtu::is_broadcast(request)) return false;
  if (const auto* write = std::get_if<rtu::WriteRegister>(&request.pdu)) {
    constexpr std::uint16_t kRestart = 0x0100;  // EnableCommand::kRestart (§8.67)
    if (write->address == address(Reg::kEnableCommand) && write->value == kRestart) return false;
  }
  return true;
}

}  // namespace motion::adam
