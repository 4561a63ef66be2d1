// Instruction handling of the simulated UIM342: acceptance, checks, error reports, the registers
// behind every get/set and the ACK forms (manual §2.1-§2.5, §5.1-§5.28). Motion, inputs and
// alarms are in uim342_motion.cpp.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <utility>

#include "motion/sim/uim342_drive.hpp"
#include "motion/uim342/message.hpp"
#include "motion/uim342/parameters.hpp"
#include "uim342_setup.hpp"

namespace motion::sim {
namespace {

namespace u = uim342;
using FC = u::FunctionCode;

template <typename E>
constexpr std::size_t at(E e) {
  return static_cast<std::size_t>(e);
}

// AC, DC, SP, PR, PA address the MF-selected parameter group, then MF returns to 0 (§5.13).
bool uses_parameter_group(FC f) { return f == FC::kAC || f == FC::kDC || f == FC::kSP || f == FC::kPR || f == FC::kPA; }

// The u16 register behind IC/IE/QE/MT/TG[i] and IL[16] (nullptr for other instructions).
std::uint16_t* word_register(Uim342Drive::Parameters& p, FC f, std::uint8_t i) {
  switch (f) {
    case FC::kIC: return i < p.initial_config.size() ? &p.initial_config[i] : nullptr;
    case FC::kIE: return i < p.information_enable.size() ? &p.information_enable[i] : nullptr;
    case FC::kQE: return i < p.encoder.size() ? &p.encoder[i] : nullptr;
    case FC::kMT: return i < p.driver.size() ? &p.driver[i] : nullptr;
    case FC::kTG: return i < p.trigger.size() ? &p.trigger[i] : nullptr;
    case FC::kIL:
      return (i == u::kInputLogicStallBehaviour || i == u::kInputLogicStallBehaviourAlias) ? &p.stall_behaviour
                                                                                           : nullptr;
    default: return nullptr;
  }
}

// The u32 register behind SS/SD/BL and the group's AC/DC.
std::uint32_t* unsigned_register(Uim342Drive::Parameters& p, FC f, std::uint8_t group) {
  switch (f) {
    case FC::kSS: return &p.cut_in_speed;
    case FC::kSD: return &p.stop_deceleration;
    case FC::kBL: return &p.backlash;
    case FC::kAC: return &p.groups[group].acceleration;
    case FC::kDC: return &p.groups[group].deceleration;
    default: return nullptr;
  }
}

// The s32 register behind the group's SP/PR/PA (group 0: the desired values DV[2..4]).
std::int32_t* signed_register(Uim342Drive::Parameters& p, FC f, std::uint8_t group) {
  switch (f) {
    case FC::kJV:
    case FC::kSP: return &p.groups[group].speed;
    case FC::kPR: return &p.groups[group].relative;
    case FC::kPA: return &p.groups[group].absolute;
    default: return nullptr;
  }
}

std::uint8_t* protocol_register(Uim342Drive::Parameters& p, std::uint8_t i) {
  switch (static_cast<u::ProtocolParameter>(i)) {
    case u::ProtocolParameter::kBitRate: return &p.bit_rate_code;
    case u::ProtocolParameter::kNodeId: return &p.node_id;
    case u::ProtocolParameter::kGroupId: return &p.group_id;
  }
  return nullptr;
}

std::int32_t wire32(std::int64_t value) { return static_cast<std::int32_t>(value); }  // s32 counter wraps

// ER[0] and ER[10] are the latest error, ER[11..18] the earlier ones (the §5.6 table; §2.3 says
// "latest + 7"); ER[6], the power-on error, is never set by the simulator.
std::optional<std::size_t> history_slot(std::uint8_t index) {
  if (index == u::kErrorSlotLatest) return 0;
  if (index >= u::kErrorSlotHistoryFirst && index <= u::kErrorSlotHistoryLast) return index - u::kErrorSlotHistoryFirst;
  return std::nullopt;
}

}  // namespace

Uim342Drive::Uim342Drive(const config::Drive& drive, SimDriveContext context, Uim342Identity identity,
                         std::optional<Uim342HomeSwitch> home_switch, MicroStepsApply micro_steps_apply)
    : context_(std::move(context)),
      identity_(identity),
      factory_(setup_parameters(drive, identity)),
      persisted_(factory_),
      active_(factory_),
      home_switch_(home_switch),
      micro_steps_apply_(micro_steps_apply) {}

double Uim342Drive::shaft_full_steps(TimePoint now) const {
  return shaft_base_full_steps_ + static_cast<double>(kinematics_.position_counts(now) - counts_base_) /
                                      std::max<std::uint16_t>(applied_micro_steps_, 1);
}

void Uim342Drive::apply_micro_steps(std::uint16_t micro_steps, TimePoint now) {
  shaft_base_full_steps_ = shaft_full_steps(now);
  counts_base_ = kinematics_.position_counts(now);
  applied_micro_steps_ = std::max<std::uint16_t>(micro_steps, 1);
}

std::int64_t Uim342Drive::position(TimePoint now) const { return kinematics_.position_counts(now) - origin_offset_; }

void Uim342Drive::power_up(TimePoint now) {
  if (home_switch_) {
    const auto& sw = *home_switch_;
    inputs_[sw.port] = sw.side * (kinematics_.position_counts(now) - sw.edge) >= 0 ? sw.active_level : !sw.active_level;
  }
  reboot(now);
}

void Uim342Drive::on_frame(const can::Frame& frame, TimePoint now) {
  if (!frame.extended || frame.rtr) return;  // 11-bit frames belong to CANopen nodes on the same bus
  const auto decoded = u::decode_can(frame);
  if (!decoded) return;  // not a SimpleCAN identifier
  const u::CanAddress address = decoded->address;
  const bool addressed = address.consumer == node_id_ || address.consumer == u::kGlobalId ||
                         (group_id_ != 0 && address.consumer == group_id_);
  if (!addressed) return;
  process(now);  // settle what happened before this frame (motion end, filtered inputs)

  const u::Message& message = decoded->message;
  const auto instruction = u::decode_instruction(message);
  if (!instruction) {
    // ML without the ACK bit does not exist (§5.4): ignored. Everything else the codec
    // cannot read is an unknown function or a DL fitting no form: syntax error (0x32, §2.3; assumed).
    if (instruction.error() != make_error_code(u::CodecErrc::kAckFormNotSupported)) {
      reject(u::DriveErrc::kSyntaxError, message.control_word, 0, address.producer);
    }
    return;
  }
  handle(*instruction, address.producer, message.control_word, frame, now);
  finish_if_done(now);  // a zero-length move ends at once, after its ACK
}

void Uim342Drive::handle(const Instruction& instruction, std::uint8_t host, std::uint8_t received_cw,
                         const can::Frame& frame, TimePoint now) {
  const FC f = instruction.function;
  const std::uint8_t group = uses_parameter_group(f) ? std::exchange(selected_group_, 0) : 0;
  std::error_code error = u::check_instruction(instruction, acceleration_unit());
  if (!error) error = state_error(instruction, group, now);
  if (error) {
    reject(static_cast<u::DriveErrc>(error.value()), received_cw, instruction.sub_index().value_or(0), host);
    return;
  }
  if (f == FC::kSY) {  // never acknowledged (§5.8)
    if (std::get<u::Index>(instruction.body).index ==
        static_cast<std::uint8_t>(u::SystemOperation::kRestoreFactoryDefaults)) {
      // The configuration's set-up stands in for the factory values; the protocol parameters are
      // kept so that the drive stays reachable on the simulated bus.
      const Parameters protocol = persisted_;
      persisted_ = factory_;
      persisted_.bit_rate_code = protocol.bit_rate_code;
      persisted_.node_id = protocol.node_id;
      persisted_.group_id = protocol.group_id;
    }
    reboot(now);
    return;
  }
  u::Reply reply;
  switch (f) {
    case FC::kAC:
    case FC::kDC:
    case FC::kSP:
    case FC::kPR:
    case FC::kPA:
    case FC::kJV:
    case FC::kMF: reply = motion_parameter(instruction, group, now); break;
    case FC::kMO:
    case FC::kBG:
    case FC::kST:
    case FC::kOG:
    case FC::kDI: reply = motion_command(instruction, frame, now); break;
    case FC::kML:
    case FC::kSN:
    case FC::kMS:
    case FC::kDV: reply = status(instruction, now); break;
    default: reply = configuration(instruction, now); break;
  }
  // Gets without the ACK bit are not answered either.
  if (instruction.ack_requested) send(reply, host);
}

std::error_code Uim342Drive::state_error(const Instruction& instruction, std::uint8_t group, TimePoint now) const {
  using E = u::DriveErrc;
  const FC f = instruction.function;
  const bool running = moving(now);
  if (f == FC::kBG) {
    if (!driver_on_) return E::kBgWhileDriverOff;
    if (emergency_stopping_ || locked_) return E::kBgDuringEmergencyStop;  // locked until reboot
    return {};
  }
  if (f == FC::kOG) return running ? make_error_code(E::kOgWhileRunning) : std::error_code{};
  if (instruction.operation != u::Operation::kSet) return {};
  switch (f) {
    case FC::kPP:
    case FC::kIC:
    case FC::kMT:
    case FC::kQE: return running ? make_error_code(E::kNotAllowedWhileRunning) : std::error_code{};
    case FC::kJV:  // mode changes in motion
      return running && motion_.ptp ? make_error_code(E::kNotAllowedWhileRunning) : std::error_code{};
    case FC::kPR:
    case FC::kPA:
      return group == 0 && running && !motion_.ptp ? make_error_code(E::kNotAllowedWhileRunning) : std::error_code{};
    case FC::kSP:  // "#50": in PTP set PR/PA before SP (§5.19)
      return group == 0 && mode_ == u::MotionMode::kJog ? make_error_code(E::kSyntaxError) : std::error_code{};
    case FC::kSD:
    case FC::kDC: {
      if (acceleration_unit() != u::AccelerationUnit::kPulsesPerS2) return {};  // a time is not comparable to SD
      const auto value = std::get<u::Unsigned>(instruction.body).value;
      const bool too_small =
          f == FC::kSD ? value < active_.groups[0].deceleration : (group == 0 && value > active_.stop_deceleration);
      return too_small ? make_error_code(E::kSdLessThanDc) : std::error_code{};
    }
    default: return {};
  }
}

u::Reply Uim342Drive::configuration(const Instruction& instruction, TimePoint now) {
  const FC f = instruction.function;
  const std::uint8_t i = instruction.sub_index().value_or(0);
  if (instruction.operation == u::Operation::kSet) {
    if (f == FC::kER) {
      if (const auto slot = history_slot(i)) error_history_[*slot] = {};
    } else {
      store(instruction, active_, 0);
      if (persists(instruction, 0)) store(instruction, persisted_, 0);
      // §5.9: "powered off and restarted to take effect" (variant micro_steps_apply).
      if (f == FC::kMT && i == at(u::MotorDriver::kMicrostepping) &&
          micro_steps_apply_ == MicroStepsApply::kImmediately) {
        apply_micro_steps(active_.driver[at(u::MotorDriver::kMicrostepping)], now);
      }
    }
    return *u::echo_ack(instruction);
  }
  switch (f) {
    case FC::kPP: return {f, u::IndexedByte{i, *protocol_register(active_, i)}};
    case FC::kIL:
      if (i < active_.input_logic.size()) return {f, active_.input_logic[i]};
      return {f, u::IndexedWord{i, active_.stall_behaviour}};
    case FC::kSS:
    case FC::kSD:
    case FC::kBL: return {f, u::Unsigned{*unsigned_register(active_, f, 0)}};
    case FC::kER: {
      u::ErrorRecord record{};
      if (const auto slot = history_slot(i)) record = error_history_[*slot];
      record.index = i;
      return {f, record};
    }
    default: return {f, u::IndexedWord{i, *word_register(active_, f, i)}};
  }
}

u::Reply Uim342Drive::motion_parameter(const Instruction& instruction, std::uint8_t group, TimePoint now) {
  const FC f = instruction.function;
  const bool set = instruction.operation == u::Operation::kSet;
  if (f == FC::kMF) {
    if (set) selected_group_ = std::get<u::Byte>(instruction.body).value;
    return {f, u::Byte{selected_group_}};
  }
  if (set) {
    store(instruction, active_, group);
    if (persists(instruction, group)) store(instruction, persisted_, group);
    if (group == 0) {
      // JV selects JOG, PR/PA select PTP and which of them BG uses (§5.18-§5.21).
      if (f == FC::kJV) mode_ = u::MotionMode::kJog;
      if (f == FC::kPR || f == FC::kPA) {
        mode_ = u::MotionMode::kPtp;
        ptp_relative_ = f == FC::kPR;
      }
    }
    return *u::echo_ack(instruction);
  }
  if (f == FC::kAC || f == FC::kDC) return {f, u::Unsigned{*unsigned_register(active_, f, group)}};
  if (group != 0) return {f, u::Signed{*signed_register(active_, f, group)}};  // the stored group value
  switch (f) {
    case FC::kPR: return {f, u::Signed{wire32(relative_position(now))}};
    case FC::kPA: return {f, u::Signed{wire32(position(now))}};
    default: return {f, u::Signed{speed(now)}};  // JV, SP: the actual speed
  }
}

u::Reply Uim342Drive::motion_command(const Instruction& instruction, const can::Frame& frame, TimePoint now) {
  const FC f = instruction.function;
  const bool set = instruction.operation == u::Operation::kSet;
  switch (f) {
    case FC::kMO:
      if (set) {
        const bool on = std::get<u::Byte>(instruction.body).value != 0;
        if (!on) halt(now, frame.timestamp_us);  // the shaft freewheels, motion ends
        driver_on_ = on;
        auto_enable_at_ = kNever;
      }
      return {f, u::Byte{static_cast<std::uint8_t>(driver_on_ ? 1 : 0)}};
    case FC::kBG: begin(now, frame.timestamp_us); return {f, u::Empty{}};
    case FC::kST:
      stop_with(now, static_cast<double>(active_.stop_deceleration), true, frame.timestamp_us);  // SD is always a rate
      return {f, u::Empty{}};
    case FC::kOG: set_origin(now); return {f, u::Empty{}};
    default: {  // DI: d1 bit 0 enables the write of OP1
      if (set) {
        const auto& out = std::get<u::DigitalOutput>(instruction.body);
        if ((out.write_enable & 1U) != 0) output_ = (out.outputs & 1U) != 0;
      }
      std::uint8_t inputs = 0;
      for (std::size_t port = 0; port < inputs_.size(); ++port)
        inputs = static_cast<std::uint8_t>(inputs | (inputs_[port] ? 1U << port : 0U));
      return {FC::kDI, u::DigitalIo{inputs, static_cast<std::uint8_t>(output_ ? 1 : 0)}};
    }
  }
}

u::Reply Uim342Drive::status(const Instruction& instruction, TimePoint now) {
  const FC f = instruction.function;
  switch (f) {
    case FC::kML: return {f, u::ModelInfo{identity_.model_bytes, identity_.firmware, 0}};
    case FC::kSN: return {f, u::SerialNumber{identity_.serial, identity_.manufacturer, identity_.vendor}};
    case FC::kMS: {
      const std::uint8_t i = instruction.sub_index().value_or(0);
      if (instruction.operation == u::Operation::kSet) {
        // MS[0]=0 clears PAIF, TLIF, ERR (§3.7) and the relative counter.
        in_position_ = stalled_ = error_ = false;
        relative_origin_ = position(now);
      }
      if (i == static_cast<std::uint8_t>(u::MotionStatusIndex::kKinematics)) {
        return {f,
                u::MotionKinematics{std::clamp(speed(now), u::kMs1SpeedMin, u::kMs1SpeedMax), wire32(position(now))}};
      }
      return {f, u::MotionStatus{io_status(), status_flags(now), wire32(relative_position(now))}};
    }
    default: {  // DV
      const auto i = static_cast<u::DesiredValue>(instruction.sub_index().value_or(0));
      std::int32_t value = 0;
      switch (i) {
        case u::DesiredValue::kMotionMode: value = static_cast<std::int32_t>(mode_); break;
        case u::DesiredValue::kMotorCurrent: value = active_.driver[at(u::MotorDriver::kWorkingCurrent)]; break;
        case u::DesiredValue::kSpeed: value = active_.groups[0].speed; break;
        case u::DesiredValue::kRelativePosition: value = active_.groups[0].relative; break;
        case u::DesiredValue::kAbsolutePosition: value = active_.groups[0].absolute; break;
      }
      return {f, u::IndexedSigned{static_cast<std::uint8_t>(i), value}};
    }
  }
}

void Uim342Drive::store(const Instruction& instruction, Parameters& target, std::uint8_t group) const {
  const FC f = instruction.function;
  const auto& body = instruction.body;
  if (const auto* b = std::get_if<u::IndexedByte>(&body); b && f == FC::kPP) {
    *protocol_register(target, b->index) = b->value;
  } else if (const auto* w = std::get_if<u::IndexedWord>(&body)) {
    *word_register(target, f, w->index) = w->value;
  } else if (const auto* actions = std::get_if<u::InputActions>(&body)) {
    target.input_logic[actions->index] = *actions;
  } else if (const auto* v = std::get_if<u::Unsigned>(&body)) {
    *unsigned_register(target, f, group) = v->value;
  } else if (const auto* s = std::get_if<u::Signed>(&body)) {
    *signed_register(target, f, group) = s->value;
  }
}

bool Uim342Drive::persists(const Instruction& instruction, std::uint8_t group) const {
  switch (instruction.function) {
    case FC::kPP:
    case FC::kIC:
    case FC::kIE:
    case FC::kBL: return true;   // FLASH (§5.1), IC/IE/BL too
    case FC::kJV: return false;  // RAM (§5.18)
    case FC::kSP:
    case FC::kPR:
    case FC::kPA: return group != 0 && !driver_on_;  // group 0: desired values, RAM
    default: return !driver_on_;                     // QE MT AC DC SS SD IL TG: EEPROM only while the driver is off
  }
}

void Uim342Drive::send(const u::Reply& reply, std::uint8_t host) {
  const auto frame = u::reply_frame(node_id_, reply, host);
  if (!frame) {
    spdlog::error("sim uim342 {}: cannot encode {}: {}", context_.drive, u::to_string(reply), frame.error().message());
    return;
  }
  context_.send(*frame);
}

void Uim342Drive::notify(const u::Notification& notification) {
  const auto enable = u::enabled_by(notification);
  if (enable && !notification_enabled(*enable)) return;
  const auto frame = u::notification_frame(node_id_, notification);
  if (frame) context_.send(*frame);
}

void Uim342Drive::reject(u::DriveErrc error, std::uint8_t received_cw, std::uint8_t sub_index, std::uint8_t host) {
  // Sent whether or not the ACK was requested, kept in the ER history (§2.3).
  const u::Reply report = u::error_report(error, received_cw, sub_index);
  std::rotate(error_history_.rbegin(), error_history_.rbegin() + 1, error_history_.rend());
  error_history_[0] = std::get<u::ErrorRecord>(report.body);
  error_ = true;
  send(report, host);
}

std::uint8_t Uim342Drive::io_status() const {
  unsigned bits = static_cast<unsigned>(mode_);
  if (driver_on_) bits |= static_cast<unsigned>(u::IoStatusBit::kDriverOn);
  constexpr u::IoStatusBit kInputBits[] = {u::IoStatusBit::kIn1, u::IoStatusBit::kIn2, u::IoStatusBit::kIn3};
  for (std::size_t port = 0; port < inputs_.size(); ++port) {
    if (inputs_[port]) bits |= static_cast<unsigned>(kInputBits[port]);
  }
  if (output_) bits |= static_cast<unsigned>(u::IoStatusBit::kOp1);
  return static_cast<std::uint8_t>(bits);
}

std::uint8_t Uim342Drive::status_flags(TimePoint now) const {
  unsigned flags = 0;
  const auto set_if = [&flags](bool condition, u::StatusFlag flag) {
    if (condition) flags |= static_cast<unsigned>(flag);
  };
  set_if(!moving(now), u::StatusFlag::kStopped);
  set_if(in_position_, u::StatusFlag::kInPosition);
  set_if(stalled_, u::StatusFlag::kStalled);
  set_if(locked_, u::StatusFlag::kLocked);
  set_if(error_, u::StatusFlag::kError);
  return static_cast<std::uint8_t>(flags);
}

u::AccelerationUnit Uim342Drive::acceleration_unit() const {
  return static_cast<u::AccelerationUnit>(active_.initial_config[at(u::InitialConfig::kAccelerationUnit)] != 0 ? 1 : 0);
}

bool Uim342Drive::notification_enabled(u::InformationEnable which) const {
  return active_.information_enable[at(which)] != 0;
}

}  // namespace motion::sim
