// The UIM342 SimpleCAN 3.0 instruction set (manual §5.1-§5.28, Instruction Set Summary): function
// codes, sub-index enums, typed instruction/reply bodies, and one table of instruction forms that
// drives both the encoder and the decoder.
//
// Model. An Instruction (host -> drive) is {function, get|set, ACK bit, body}; a Reply (drive ->
// host, CW bit 7 = 0) is {function of its CW, body}. The body is one of a few wire layouts
// (Empty, Index, Byte, IndexedWord, Unsigned, Signed, ...). Which layout a form uses is fixed by
// the table (e.g. `AC` get = Empty, `AC=N` = Unsigned, AC reply = Unsigned). A query differs from
// a set only by DL (§5), so decoding picks the form by DL.
// Error reports (CW 0x0F) decode as Reply{ER, ErrorRecord}; real-time notifications (CW 0x5A) are
// in notifications.hpp.
//
// Decisions where the manual is inconsistent or silent:
// * JV/SP/PR/PA set: encoded with 4 data bytes; decoded from 1..4 bytes, zero-extended (the
//   manual's §2.5 examples send positive values in 2 bytes; §5.18-§5.21 define 4).
// * MF has a get form (Summary; §5.13 shows only the set); IL sub-index 16 (§1.5; the §5.26 table
//   says 3, kept as an alias) is the stall behaviour; ER slots 0, 6, 10..18 (§5.6).
// * Reserved bytes inside DL (MS[0] d3, DI d2/d3, BG ACK d0..d3, ML d3/d6/d7 are kept) are written as
//   zero and ignored when decoding.
// * SY is the only instruction without an ACK form; a received 0xFE decodes as SY with the ACK
//   bit set (treated like 0x7E: §5.8 gives no ACK form, assumed). ML exists only with the ACK bit:
//   0x0B is rejected.
// Thread contract: pure functions over values and an immutable table, thread-safe.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>

#include "motion/can_frame/frame.hpp"
#include "motion/uim342/errors.hpp"
#include "motion/uim342/message.hpp"

namespace motion::uim342 {

// CW bits 6..0 (manual "Instruction Set Summary" and §5 headers).
enum class FunctionCode : std::uint8_t {
  kPP = 0x01,
  kIC = 0x06,
  kIE = 0x07,
  kML = 0x0B,
  kSN = 0x0C,
  kER = 0x0F,
  kMT = 0x10,
  kMS = 0x11,
  kMO = 0x15,
  kBG = 0x16,
  kST = 0x17,
  kMF = 0x18,
  kAC = 0x19,
  kDC = 0x1A,
  kSS = 0x1B,
  kSD = 0x1C,
  kJV = 0x1D,
  kSP = 0x1E,
  kPR = 0x1F,
  kPA = 0x20,
  kOG = 0x21,
  kBL = 0x2D,
  kDV = 0x2E,
  kIL = 0x34,
  kTG = 0x35,
  kDI = 0x37,
  kQE = 0x3D,
  kRT = 0x5A,
  kSY = 0x7E,
};
[[nodiscard]] constexpr std::uint8_t code(FunctionCode f) noexcept { return static_cast<std::uint8_t>(f); }
[[nodiscard]] constexpr std::uint8_t control_word(FunctionCode f, bool ack_requested) noexcept {
  return static_cast<std::uint8_t>(code(f) | (ack_requested ? kAckRequestBit : 0));
}
// "PP", "MO", ...; "??" for an unknown code.
[[nodiscard]] std::string_view mnemonic(FunctionCode f) noexcept;

// ---- Sub-index and value enums (wire values) -------------------------------------------------

enum class ProtocolParameter : std::uint8_t { kBitRate = 5, kNodeId = 7, kGroupId = 8 };  // PP §5.1
enum class BitRate : std::uint8_t { kKbps1000 = 0, kKbps800 = 1, kKbps500 = 2, kKbps250 = 3, kKbps125 = 4 };
[[nodiscard]] std::optional<std::uint32_t> bits_per_second(BitRate rate) noexcept;

enum class InitialConfig : std::uint8_t {  // IC §5.2; every value is 0/1
  kAutoDriverOn = 0,                       // 1 = switch the driver on after power-up
  kPositiveDirection = 1,                  // 0 = CW, 1 = CCW (factory default)
  kRunUserProgram = 2,
  kLockOnInputEstop = 3,  // lock the system when an input-logic E-stop fires
  kAccelerationUnit = 4,  // AccelerationUnit
  kEncoderType = 5,       // 0 = incremental, 1 = absolute
  kClosedLoop = 6,        // 0 = open loop, 1 = closed loop
  kSoftwareLimits = 7,
};
enum class AccelerationUnit : std::uint8_t { kPulsesPerS2 = 0, kMilliseconds = 1 };  // IC[4]

enum class InformationEnable : std::uint8_t {
  kIn1Change = 0,
  kIn2Change = 1,
  kIn3Change = 2,
  kPositionReached = 8
};  // IE §5.3

enum class QuadratureEncoder : std::uint8_t {  // QE §5.7
  kLinesPerRevolution = 0,                     // 1..65535
  kStallTolerance = 1,                         // 10..65535 counts
  kAbsoluteResolutionBits = 2,                 // 17 or 20
  kBatteryStatus = 3,                          // 1 = OK, 0 = low
  kCountsPerRevolution = 4,                    // 200..25600 (micro-steps x 200)
};

enum class MotorDriver : std::uint8_t {  // MT §5.9
  kMicrostepping = 0,                    // 1, 2, 4, 8, 16, 32, 64
  kWorkingCurrent = 1,                   // 5..80 (0.1 A)
  kIdleCurrentPercent = 2,               // 0..100
  kAutoEnableDelayMs = 3,                // 0..60000
};

enum class SystemOperation : std::uint8_t { kReboot = 1, kRestoreFactoryDefaults = 2 };  // SY §5.8

// ER §5.6: slot 0 = latest error, 6 = power-on error, 10..18 = history (10 = latest).
inline constexpr std::uint8_t kErrorSlotLatest = 0;
inline constexpr std::uint8_t kErrorSlotPowerOn = 6;
inline constexpr std::uint8_t kErrorSlotHistoryFirst = 10;
inline constexpr std::uint8_t kErrorSlotHistoryLast = 18;

enum class ParameterGroup : std::uint8_t {  // MF §5.13: group = 2 + 2*port (+1 falling)
  kNormal = 0,
  kReserved = 1,
  kIn1Rising = 2,
  kIn1Falling = 3,
  kIn2Rising = 4,
  kIn2Falling = 5,
  kIn3Rising = 6,
  kIn3Falling = 7,
};

enum class MotionStatusIndex : std::uint8_t { kStatus = 0, kKinematics = 1 };  // MS §5.24
enum class DesiredValue : std::uint8_t {                                       // DV §5.25
  kMotionMode = 0,
  kMotorCurrent = 1,
  kSpeed = 2,
  kRelativePosition = 3,
  kAbsolutePosition = 4,
};
enum class MotionMode : std::uint8_t { kJog = 0, kPtp = 1 };

enum class InputPort : std::uint8_t { kIn1 = 0, kIn2 = 1, kIn3 = 2 };  // IL[0..2], TG[0..2], IE[0..2]
inline constexpr std::uint8_t kInputLogicStallBehaviour = 16;          // IL[16] (§1.5); manual table: 3
inline constexpr std::uint8_t kInputLogicStallBehaviourAlias = 3;
enum class StallBehaviour : std::uint8_t { kStopAndHold = 0, kDriverOff = 1 };

inline constexpr std::uint16_t kTriggerContinuous = 0;  // TG: 1..60000 = low-pass filter ms
inline constexpr std::uint16_t kTriggerMaxFilterMs = 60000;
inline constexpr std::uint16_t kTriggerOneTime = 60001;

// IL action codes (§4.3, §5.26), bits 6..0 of an action byte.
enum class InputAction : std::uint8_t {
  kNone = 0x00,
  kDriverOff = 0x01,
  kEmergencyStop = 0x02,   // SD
  kDecelerateStop = 0x03,  // DC
  kOriginThenReverseRelative = 0x04,
  kOriginThenEmergencyStop = 0x05,
  kOriginThenDecelerateStop = 0x06,
  kJogReverse = 0x07,
  kJog = 0x08,
  kReverseRelative = 0x09,
  kRelative = 0x0A,
  kAbsolute = 0x0B,
};

// One IL action byte: bit 7 = FG (1 = do not run at power-up, wait for a real edge).
struct EdgeAction {
  InputAction action = InputAction::kNone;
  bool wait_for_edge = true;  // FG
  [[nodiscard]] constexpr std::uint8_t byte() const noexcept {
    return static_cast<std::uint8_t>((wait_for_edge ? 0x80 : 0x00) | (static_cast<std::uint8_t>(action) & 0x7F));
  }
  [[nodiscard]] static constexpr EdgeAction from_byte(std::uint8_t b) noexcept {
    return {static_cast<InputAction>(b & 0x7F), (b & 0x80) != 0};
  }
  friend bool operator==(const EdgeAction&, const EdgeAction&) = default;
};

// MS[0] d1 (status byte A) and d2 (status byte B), manual §3.7.
enum class IoStatusBit : std::uint8_t { kDriverOn = 0x04, kIn1 = 0x08, kIn2 = 0x10, kIn3 = 0x20, kOp1 = 0x40 };
enum class StatusFlag : std::uint8_t {
  kStopped = 0x01,
  kInPosition = 0x02,
  kStalled = 0x08,
  kLocked = 0x20,
  kError = 0x80
};

// ---- Bodies: one type per wire layout ---------------------------------------------------------

struct Empty {  // no data (or don't-care bytes, BG ACK)
  friend bool operator==(const Empty&, const Empty&) = default;
};
struct Index {  // d0 = sub-index (indexed gets, SY)
  std::uint8_t index = 0;
  friend bool operator==(const Index&, const Index&) = default;
};
struct Byte {  // d0 = value (MO, MF)
  std::uint8_t value = 0;
  friend bool operator==(const Byte&, const Byte&) = default;
};
struct IndexedByte {  // d0 = sub-index, d1 = value (PP, ER clear, MS clear)
  std::uint8_t index = 0;
  std::uint8_t value = 0;
  friend bool operator==(const IndexedByte&, const IndexedByte&) = default;
};
struct IndexedWord {  // d0 = sub-index, [d2:d1] = u16 (IC, IE, QE, MT, TG, IL[16])
  std::uint8_t index = 0;
  std::uint16_t value = 0;
  friend bool operator==(const IndexedWord&, const IndexedWord&) = default;
};
struct InputActions {  // IL[0..2]: d0 = port, d1 = falling-edge action, d2 = rising-edge action
  std::uint8_t index = 0;
  EdgeAction falling;
  EdgeAction rising;
  friend bool operator==(const InputActions&, const InputActions&) = default;
};
struct Unsigned {  // [d3..d0] u32 (AC, DC, SS, SD, BL)
  std::uint32_t value = 0;
  friend bool operator==(const Unsigned&, const Unsigned&) = default;
};
struct Signed {  // [d3..d0] s32 (JV, SP, PR, PA)
  std::int32_t value = 0;
  friend bool operator==(const Signed&, const Signed&) = default;
};
struct IndexedSigned {  // d0 = sub-index, [d4..d1] s32 (DV replies; ACK of JV/SP/PR/PA sets)
  std::uint8_t index = 0;
  std::int32_t value = 0;
  friend bool operator==(const IndexedSigned&, const IndexedSigned&) = default;
};
struct DigitalOutput {  // DI set: d0 = desired outputs (bit0 = OP1), d1 = 1 (write enable)
  std::uint8_t outputs = 0;
  std::uint8_t write_enable = 1;
  friend bool operator==(const DigitalOutput&, const DigitalOutput&) = default;
};
struct DigitalIo {  // DI reply: d0 bit0..2 = IN1..IN3, d1 bit0 = OP1
  std::uint8_t inputs = 0;
  std::uint8_t outputs = 0;
  [[nodiscard]] bool input(InputPort port) const { return ((inputs >> static_cast<unsigned>(port)) & 1U) != 0; }
  [[nodiscard]] bool op1() const { return (outputs & 1U) != 0; }
  friend bool operator==(const DigitalIo&, const DigitalIo&) = default;
};
enum class Model : std::uint8_t { kUnknown, kUim342xs, kUim342s, kUim342c02, kUim342c04, kUim342c08, kUim342h08 };
struct ModelInfo {                            // ML reply, §5.4
  std::array<std::uint8_t, 4> model_bytes{};  // d0..d3 (d3 factory use)
  std::uint16_t firmware = 0;                 // [d5:d4]
  std::uint16_t factory = 0;                  // [d7:d6], factory use
  [[nodiscard]] Model model() const noexcept;
  friend bool operator==(const ModelInfo&, const ModelInfo&) = default;
};
struct SerialNumber {  // SN reply, §5.5
  std::uint32_t serial = 0;
  std::uint16_t manufacturer = 0;
  std::uint16_t vendor = 0;
  friend bool operator==(const SerialNumber&, const SerialNumber&) = default;
};
struct ErrorRecord {                      // ER reply and error report (CW 0x0F, DL 6), §2.3 / §5.6
  std::uint8_t index = 0;                 // d0: ER slot (0 in spontaneous error reports)
  std::uint8_t code = 0;                  // d1: DriveErrc value, 0 = empty slot
  std::uint8_t control_word = 0;          // d2: CW of the rejected instruction as received (bit 7 may be set)
  std::uint8_t sub_index = 0;             // d3
  std::array<std::uint8_t, 2> factory{};  // d4, d5: factory use
  [[nodiscard]] std::error_code error() const { return {code, drive_category()}; }
  [[nodiscard]] FunctionCode failed_function() const {
    return static_cast<FunctionCode>(control_word & kFunctionCodeMask);
  }
  friend bool operator==(const ErrorRecord&, const ErrorRecord&) = default;
};
struct MotionStatus {          // MS[0] reply: d1 status A, d2 status B, [d7..d4] relative position
  std::uint8_t io_status = 0;  // d1: mode (bits 1:0) + IoStatusBit
  std::uint8_t flags = 0;      // d2: StatusFlag
  std::int32_t relative_position = 0;
  [[nodiscard]] MotionMode mode() const { return static_cast<MotionMode>(io_status & 0x03); }
  [[nodiscard]] bool has(IoStatusBit bit) const { return (io_status & static_cast<std::uint8_t>(bit)) != 0; }
  [[nodiscard]] bool has(StatusFlag flag) const { return (flags & static_cast<std::uint8_t>(flag)) != 0; }
  friend bool operator==(const MotionStatus&, const MotionStatus&) = default;
};
struct MotionKinematics {  // MS[1] reply: [d3..d1] speed (s24), [d7..d4] absolute position
  std::int32_t speed = 0;  // -8388608..8388607 pulse/s
  std::int32_t absolute_position = 0;
  friend bool operator==(const MotionKinematics&, const MotionKinematics&) = default;
};

using Body =
    std::variant<Empty, Index, Byte, IndexedByte, IndexedWord, InputActions, Unsigned, Signed, IndexedSigned,
                 DigitalOutput, DigitalIo, ModelInfo, SerialNumber, ErrorRecord, MotionStatus, MotionKinematics>;

enum class Operation : std::uint8_t { kGet, kSet };  // BG, ST, OG, SY, ER/MS clear are "set" forms

struct Instruction {
  FunctionCode function = FunctionCode::kMO;
  Operation operation = Operation::kGet;
  bool ack_requested = true;  // CW bit 7
  Body body = Empty{};
  [[nodiscard]] std::uint8_t control_word() const { return uim342::control_word(function, ack_requested); }
  // d0 when the form carries a sub-index (the value an ACK echoes and an error report's d3 holds).
  [[nodiscard]] std::optional<std::uint8_t> sub_index() const;
  friend bool operator==(const Instruction&, const Instruction&) = default;
};

struct Reply {
  FunctionCode function = FunctionCode::kMO;  // CW of the reply (DV for the ACK of JV/SP/PR/PA sets)
  Body body = Empty{};
  [[nodiscard]] std::optional<std::uint8_t> sub_index() const;
  friend bool operator==(const Reply&, const Reply&) = default;
};

// ---- The table of forms ------------------------------------------------------------------------

// Wire layouts. A layout fixes DL and the body type.
enum class Layout : std::uint8_t {
  kNone,           // the form does not exist
  kEmpty,          // DL 0, Empty
  kZeros4,         // DL 4, Empty; d0..d3 don't care (BG ACK)
  kIndex,          // DL 1, Index
  kByte,           // DL 1, Byte
  kIndexedByte,    // DL 2, IndexedByte
  kIndexedWord,    // DL 3, IndexedWord
  kInputLogic,     // DL 3, InputActions for ports 0..2, IndexedWord otherwise
  kU32,            // DL 4, Unsigned
  kS32,            // DL 4, Signed
  kIndexedS32,     // DL 5, IndexedSigned
  kDigitalOutput,  // DL 4, DigitalOutput
  kDigitalIo,      // DL 4, DigitalIo
  kModel,          // DL 8, ModelInfo
  kSerial,         // DL 8, SerialNumber
  kErrorRecord,    // DL 6, ErrorRecord
  kMotionStatus,   // DL 8, MotionStatus (d0 = 0) or MotionKinematics (d0 = 1)
};
[[nodiscard]] std::uint8_t layout_length(Layout layout) noexcept;

enum class AckForms : std::uint8_t { kBoth, kAckOnly, kNoAckOnly };

struct InstructionForms {
  FunctionCode function;
  std::string_view mnemonic;
  Layout get;    // instruction layout of the get form
  Layout set;    // instruction layout of the set form
  Layout reply;  // layout of drive frames carrying this function code
  AckForms ack_forms;
  FunctionCode set_ack;        // CW of the set ACK: the function itself, or DV for JV/SP/PR/PA
  std::uint8_t set_ack_index;  // DV sub-index of that ACK (0 when set_ack is the function itself)
  bool set_accepts_short;      // decode sets from 1..4 bytes (§2.5 examples)
};

// All instructions of §5.1-§5.28 (RT is not an instruction: see notifications.hpp).
[[nodiscard]] std::span<const InstructionForms> instruction_table() noexcept;
[[nodiscard]] const InstructionForms* find_forms(std::uint8_t function_code) noexcept;
[[nodiscard]] inline const InstructionForms* find_forms(FunctionCode f) noexcept { return find_forms(code(f)); }

// ---- Encode / decode ----------------------------------------------------------------------------

[[nodiscard]] Result<Message> encode(const Instruction& instruction);
[[nodiscard]] Result<Instruction> decode_instruction(const Message& message);
[[nodiscard]] Result<Message> encode(const Reply& reply);
// Any drive frame except RT (CW 0x5A): ACKs and error reports. Rejects CWs with bit 7 set.
[[nodiscard]] Result<Reply> decode_reply(const Message& message);

// CAN shortcuts: the host (producer `host`) addresses `target`; the drive `node` answers `host`.
[[nodiscard]] Result<can::Frame> instruction_frame(std::uint8_t target, const Instruction& instruction,
                                                   std::uint8_t host = kMasterId);
[[nodiscard]] Result<can::Frame> reply_frame(std::uint8_t node, const Reply& reply, std::uint8_t host = kMasterId);

struct AddressedInstruction {
  CanAddress address;
  Instruction instruction;
};
struct AddressedReply {
  CanAddress address;
  Reply reply;
};
[[nodiscard]] Result<AddressedInstruction> decode_instruction_frame(const can::Frame& frame);
[[nodiscard]] Result<AddressedReply> decode_reply_frame(const can::Frame& frame);

// Manual mnemonic notation (§2.2): "MO", "MO=1", "PP[5]", "PP[5]=2", "IL[0]=0x06,0x80".
[[nodiscard]] std::string to_string(const Instruction& instruction);
[[nodiscard]] std::string to_string(const Reply& reply);

// ---- Typed constructors (host side) -------------------------------------------------------------

namespace request {
// Gets without data: MO, MF, AC, DC, SS, SD, BL, JV, SP, PR, PA, ML, SN, DI.
[[nodiscard]] Instruction get(FunctionCode function);
[[nodiscard]] Instruction get(ProtocolParameter p);
[[nodiscard]] Instruction get(InitialConfig c);
[[nodiscard]] Instruction get(InformationEnable e);
[[nodiscard]] Instruction get(QuadratureEncoder q);
[[nodiscard]] Instruction get(MotorDriver m);
[[nodiscard]] Instruction get(MotionStatusIndex s);
[[nodiscard]] Instruction get(DesiredValue d);
[[nodiscard]] Instruction get_error(std::uint8_t slot);
[[nodiscard]] Instruction get_input_logic(std::uint8_t index);  // 0..2 ports, 16 stall behaviour
[[nodiscard]] Instruction get_trigger(InputPort port);

[[nodiscard]] Instruction set(ProtocolParameter p, std::uint8_t value);
[[nodiscard]] Instruction set(InitialConfig c, std::uint16_t value);
[[nodiscard]] Instruction set(InformationEnable e, bool enabled);
[[nodiscard]] Instruction set(QuadratureEncoder q, std::uint16_t value);
[[nodiscard]] Instruction set(MotorDriver m, std::uint16_t value);
[[nodiscard]] Instruction set_input_logic(InputPort port, EdgeAction falling, EdgeAction rising);
[[nodiscard]] Instruction set_stall_behaviour(StallBehaviour behaviour);
[[nodiscard]] Instruction set_trigger(InputPort port, std::uint16_t mode);
[[nodiscard]] Instruction clear_error(std::uint8_t slot);
[[nodiscard]] Instruction clear_motion_status();                       // MS[0]=0
[[nodiscard]] Instruction driver_on(bool on);                          // MO=N
[[nodiscard]] Instruction select_group(ParameterGroup group);          // MF=N
[[nodiscard]] Instruction set_acceleration(std::uint32_t value);       // AC=N
[[nodiscard]] Instruction set_deceleration(std::uint32_t value);       // DC=N
[[nodiscard]] Instruction set_cut_in_speed(std::uint32_t pps);         // SS=N
[[nodiscard]] Instruction set_stop_deceleration(std::uint32_t pps2);   // SD=N
[[nodiscard]] Instruction set_backlash(std::uint32_t pulses);          // BL=N
[[nodiscard]] Instruction set_jog_velocity(std::int32_t pps);          // JV=N
[[nodiscard]] Instruction set_ptp_speed(std::int32_t pps);             // SP=N
[[nodiscard]] Instruction set_relative_position(std::int32_t pulses);  // PR=N
[[nodiscard]] Instruction set_absolute_position(std::int32_t pulses);  // PA=N
[[nodiscard]] Instruction set_outputs(std::uint8_t outputs);           // DI=N
[[nodiscard]] Instruction begin();                                     // BG
[[nodiscard]] Instruction stop();                                      // ST
[[nodiscard]] Instruction set_origin();                                // OG
[[nodiscard]] Instruction system(SystemOperation op);                  // SY[i], never acknowledged
// Same instruction with CW bit 7 cleared (no ACK; errors are still reported).
[[nodiscard]] Instruction without_ack(Instruction instruction);
}  // namespace request

// ---- Drive side helpers (simulator) -------------------------------------------------------------

// The ACK of a set, when it follows from the instruction alone (§2.1, §5.11, §5.18-§5.21): an echo
// for PP IC IE QE MT MO MF AC DC SS SD BL IL TG; DV[i] for JV/SP/PR/PA; an all-zero record for
// ER[i]=0; no data for BG (4 zero bytes), ST, OG. nullopt for gets, SY, and sets whose ACK reports
// drive state (MS[0]=0, DI=N).
[[nodiscard]] std::optional<Reply> echo_ack(const Instruction& set);
// Error report for a rejected instruction (§2.3, ER layout of §5.6; d0 = 0 assumed): d0 = 0, d2 =
// CW as received, d3 = sub-index.
[[nodiscard]] Reply error_report(DriveErrc error, std::uint8_t received_control_word, std::uint8_t sub_index);

}  // namespace motion::uim342
