#include "motion/sim/uc57_drive.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "motion/canopen/cob_id.hpp"
#include "motion/canopen/sync.hpp"
#include "motion/cia402/modes.hpp"
#include "motion/cia402/uc57_homing.hpp"
#include "motion/cia402/words.hpp"

namespace motion::sim {
namespace {

namespace od = cia402::uc57;
namespace idx = cia402::uc57::index;
using canopen::SdoAbortCode;
using cia402::ControlBit;
using cia402::State;
using cia402::StatusBit;

constexpr std::uint32_t key(std::uint16_t index, std::uint8_t sub) { return (std::uint32_t{index} << 8) | sub; }

SdoAbortCode abort_code(od::AccessError error) {
  switch (error) {
    case od::AccessError::kNoObject: return SdoAbortCode::kObjectDoesNotExist;
    case od::AccessError::kNoSubindex: return SdoAbortCode::kSubindexDoesNotExist;
    case od::AccessError::kReadOnly: return SdoAbortCode::kWriteOfReadOnly;
    case od::AccessError::kWriteOnly: return SdoAbortCode::kReadOfWriteOnly;
    case od::AccessError::kLengthMismatch: return SdoAbortCode::kLengthMismatch;
    case od::AccessError::kValueTooHigh: return SdoAbortCode::kValueTooHigh;
    case od::AccessError::kValueTooLow: return SdoAbortCode::kValueTooLow;
    case od::AccessError::kInvalidValue: return SdoAbortCode::kInvalidValue;
  }
  return SdoAbortCode::kGeneralError;
}

bool in_range(std::uint16_t index, std::uint16_t first, std::uint16_t last) { return index >= first && index <= last; }

// EMCY contents of the UC57 alarms Err1..Err6 (CiA 301 §7.2.7 codes, assumed: the manual gives none).
struct AlarmEmcy {
  std::uint16_t code;
  std::uint8_t error_register;
  bool needs_power_cycle;  // "Lock / power-off reset" (§5.1)
};
constexpr std::array<AlarmEmcy, 6> kAlarms = {{
    {0x2310, 0x03, true},   // Err1 overcurrent
    {0x3210, 0x05, false},  // Err2 overvoltage (auto reset)
    {0x5000, 0x81, true},   // Err3 hardware
    {0xFF04, 0x01, true},   // Err4 phase loss
    {0x5530, 0x81, true},   // Err5 EEPROM
    {0x3220, 0x05, false},  // Err6 undervoltage (auto reset)
}};
// A stall has no UC57 alarm code; CiA 402 following error is the closest standard code.
constexpr std::uint16_t kStallEmcyCode = 0x8611;
constexpr std::uint8_t kStallErrorRegister = 0x21;  // generic + device profile
constexpr std::uint16_t kPdoLengthErrorCode = 0x8210;  // PDO not processed: length error

bool motor_energised(State state) {
  return state == State::kSwitchedOn || state == State::kOperationEnabled || state == State::kQuickStopActive ||
         state == State::kFaultReactionActive;
}

constexpr double kStepAcceleration = 1e12;  // a ramp setting that means "no ramp"

}  // namespace

Uc57DriveSim::Uc57DriveSim(canopen::NodeId node, SimDriveContext context, Uc57SimOptions options)
    : node_(node), context_(std::move(context)), options_(options) {
  policy_.check_range = options_.check_range;
  policy_.pdo_configuration_writable = options_.pdo_configuration_writable;
  sdo_ = std::make_unique<canopen::SdoServer>(
      node_, [this](const can::Frame& f) { send(f); },
      canopen::SdoServerHandlers{[this](canopen::ObjectAddress a) { return sdo_read(a); },
                                 [this](const canopen::SdoWrite& w) { return sdo_write(w); }});
}

// ------------------------------------------------------------------------------------------------
// Power, NMT, heartbeat

void Uc57DriveSim::power_up(TimePoint now) {
  now_ = now;
  powered_at_ = now;
  frame_utime_ = 0;
  boot(now, /*communication_only=*/false);
  if (context_.report) context_.report(motionlcm::sim_report_t::POWERED_UP, 0, position(now), position(now));
}

void Uc57DriveSim::boot(TimePoint now, bool communication_only) {
  reset_objects(communication_only);
  sdo_->reset();
  rpdo_buffer_ = {};
  tpdo_ = {};
  if (!communication_only) {
    // Application reset: the power stage restarts (transitions 0 and 1), the motor is released.
    if (motion_.active) kinematics_.halt(now);
    motion_ = {};
    activity_ = Activity::kIdle;
    controlword_ = 0;
    fault_bits_ = 0;
    stalled_ = false;
    error_history_.clear();
    buffered_set_point_.reset();
    set_point_acknowledged_ = false;
    target_reached_ = true;
    in_position_ = false;
    homed_ = homing_attained_ = homing_finished_ = false;
    homing_legs_.clear();
    state_ = State::kStart;
    for (const auto event : {cia402::DriveEvent::kPowerOn, cia402::DriveEvent::kInitialized}) {
      if (const auto t = cia402::find_event_transition(state_, event)) state_ = t->to;
    }
  }
  // Initialisation ends with the boot-up message and Pre-operational (manual §4.1.2).
  send(canopen::encode_heartbeat(node_, canopen::NmtState::kBootUp));
  nmt_ = canopen::NmtState::kPreOperational;
  restart_heartbeat();
}

void Uc57DriveSim::on_nmt(const can::Frame& frame) {
  const auto request = canopen::decode_nmt(frame.payload());
  if (!request || (request->node != canopen::kAllNodes && request->node != node_)) return;
  switch (request->command) {
    case canopen::NmtCommand::kStart:
      if (nmt_ != canopen::NmtState::kOperational) tpdo_ = {};  // event TPDOs go out once started
      nmt_ = canopen::NmtState::kOperational;
      break;
    case canopen::NmtCommand::kStop:
      nmt_ = canopen::NmtState::kStopped;
      sdo_->reset();
      break;
    case canopen::NmtCommand::kEnterPreOperational: nmt_ = canopen::NmtState::kPreOperational; break;
    case canopen::NmtCommand::kResetNode: boot(now_, false); break;
    case canopen::NmtCommand::kResetCommunication: boot(now_, true); break;
  }
}

void Uc57DriveSim::restart_heartbeat() {
  const auto period_ms = stored(idx::kProducerHeartbeatTime, 0);
  next_heartbeat_ = period_ms > 0 ? now_ + std::chrono::milliseconds(period_ms) : kNever;
}

void Uc57DriveSim::send(const can::Frame& frame) const {
  if (context_.send) context_.send(frame);
}

// ------------------------------------------------------------------------------------------------
// Frame and time entry points

void Uc57DriveSim::on_frame(const can::Frame& frame, TimePoint now) {
  now_ = now;
  frame_utime_ = frame.timestamp_us;
  if (frame.extended || frame.rtr) return;  // UIM342 traffic on a shared bus; no RTR support
  const auto info = canopen::classify_cob_id(frame.id);
  if (info && info->kind == canopen::MessageKind::kNmt) {
    on_nmt(frame);
  } else if (nmt_ != canopen::NmtState::kStopped) {
    if (sdo_->on_request(frame, now)) {
      // handled: responses were sent by the server
    } else if (frame.id == canopen::kSyncCobId && canopen::decode_sync(frame.payload())) {
      on_sync();
    } else if (nmt_ == canopen::NmtState::kOperational) {
      for (unsigned n = 1; n <= 4; ++n) {
        const auto cob = static_cast<std::uint32_t>(stored(static_cast<std::uint16_t>(idx::kRpdoCommunication + n - 1), 1));
        if ((cob & canopen::kPdoCobIdInvalid) == 0 && (cob & can::kMaxStandardId) == frame.id) {
          on_rpdo(n, frame.payload());
        }
      }
    }
  }
  settle();
  service_event_tpdos();
}

TimePoint Uc57DriveSim::process(TimePoint now) {
  now_ = now;
  sdo_->process(now);
  settle();
  if (now >= next_heartbeat_) {
    send(canopen::encode_heartbeat(node_, nmt_));
    next_heartbeat_ += std::chrono::milliseconds(stored(idx::kProducerHeartbeatTime, 0));
    if (next_heartbeat_ <= now) restart_heartbeat();
  }
  service_event_tpdos();

  TimePoint next = std::min(next_heartbeat_, sdo_->next_deadline());
  if (motion_.active || activity_ == Activity::kStopping) next = std::min(next, kinematics_.end_time());
  if (nmt_ == canopen::NmtState::kOperational) {
    for (const auto& tpdo : tpdo_) next = std::min(next, tpdo.next_event);
  }
  return next;
}

bool Uc57DriveSim::control(const motionlcm::sim_control_t& control, TimePoint now) {
  now_ = now;
  frame_utime_ = control.utime;
  settle();
  switch (control.action) {
    case motionlcm::sim_control_t::STALL: {
      stalled_ = true;
      fault({kStallEmcyCode, kStallErrorRegister, {0, 0, 0, 0, 0}});
      break;
    }
    case motionlcm::sim_control_t::ALARM: {
      if (control.value < 1 || control.value > static_cast<int>(kAlarms.size())) return false;
      const auto code = static_cast<unsigned>(control.value);
      const AlarmEmcy& alarm = kAlarms[code - 1];
      fault_bits_ = static_cast<std::uint16_t>(fault_bits_ | (1U << (code - 1)));
      const auto bit = static_cast<std::uint16_t>(1U << (code - 1));
      fault({alarm.code, alarm.error_register,
             {static_cast<std::uint8_t>(code), static_cast<std::uint8_t>(bit & 0xFF), static_cast<std::uint8_t>(bit >> 8), 0, 0}});
      break;
    }
    case motionlcm::sim_control_t::SET_INPUT:
      if (control.value < 1 || control.value > 3) return false;
      forced_inputs_[static_cast<std::size_t>(control.value - 1)] = control.level != 0;
      break;
    default: return false;
  }
  service_event_tpdos();
  return true;
}

// ------------------------------------------------------------------------------------------------
// Object dictionary

void Uc57DriveSim::reset_objects(bool communication_only) {
  for (const od::OdEntry& entry : od::object_dictionary()) {
    if (communication_only && !in_range(entry.index, 0x1000, 0x1FFF)) continue;
    objects_[key(entry.index, entry.subindex)] = od::default_value(entry, node_);
  }
}

std::int64_t Uc57DriveSim::stored(std::uint16_t index, std::uint8_t sub) const {
  const auto it = objects_.find(key(index, sub));
  return it == objects_.end() ? 0 : it->second;
}

void Uc57DriveSim::store(std::uint16_t index, std::uint8_t sub, std::int64_t value) { objects_[key(index, sub)] = value; }

std::int64_t Uc57DriveSim::current_value(const od::OdEntry& entry, TimePoint now) const {
  switch (entry.index) {
    case idx::kStatusword: return statusword(now);
    case idx::kPositionActual: return position(now);
    case idx::kVelocityActual:
      return std::llround(od::pulses_per_second_to_rpm(kinematics_.at(now).velocity, pulses_per_rev()));
    case idx::kDigitalInputs: return digital_inputs();
    case idx::kInputLevels: return input_levels();
    case idx::kOutputStates: return output_states();
    case idx::kMotorStatus: return running(now) ? 1 : 0;
    case idx::kErrorRegister: return error_register();
    case idx::kFaultBits: return fault_bits_;
    case idx::kRunningTime:
      return std::chrono::duration_cast<std::chrono::seconds>(now - powered_at_).count() & 0xFFFFFFFF;
    case idx::kPreDefinedErrorField:
      if (entry.subindex == 0) return static_cast<std::int64_t>(error_history_.size());
      return entry.subindex <= error_history_.size() ? error_history_[entry.subindex - 1U] : 0;
    default: return stored(entry.index, entry.subindex);
  }
}

canopen::SdoReadResult Uc57DriveSim::sdo_read(canopen::ObjectAddress object) {
  const od::Lookup lookup = od::check_read(object.index, object.subindex);
  if (lookup.error) return {{}, abort_code(*lookup.error)};
  const od::OdEntry& entry = *lookup.entry;
  std::vector<std::uint8_t> data(od::size_bytes(entry.type));
  // Stored values may exceed a narrower type only through a bug; encode the low bytes then.
  const std::int64_t value = current_value(entry, now_);
  if (!od::encode_value(entry.type, value, data)) {
    for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(value) >> (8 * i));
  }
  return {std::move(data), std::nullopt};
}

std::optional<SdoAbortCode> Uc57DriveSim::sdo_write(const canopen::SdoWrite& write) {
  const od::OdEntry* entry = od::find_entry(write.object.index, write.object.subindex);
  auto data = write.data;
  // Expedited without size (0x22): the object's type gives the length.
  if (!write.size_indicated && entry != nullptr) data = data.first(std::min<std::size_t>(data.size(), od::size_bytes(entry->type)));
  const od::Lookup lookup = od::check_write(write.object.index, write.object.subindex, data, policy_);
  if (lookup.error) return abort_code(*lookup.error);
  std::array<std::uint8_t, 4> raw{};
  std::copy_n(data.begin(), std::min<std::size_t>(data.size(), od::size_bytes(lookup.entry->type)), raw.begin());
  const auto value = od::decode_value(lookup.entry->type, std::span<const std::uint8_t>(raw).first(od::size_bytes(lookup.entry->type)));
  if (const auto refused = check_pdo_parameter(*lookup.entry, *value)) return refused;
  apply_write(*lookup.entry, *value);
  return std::nullopt;
}

// CiA 301 rules for the PDO parameter records that the generic OD check cannot know.
std::optional<SdoAbortCode> Uc57DriveSim::check_pdo_parameter(const od::OdEntry& entry, std::int64_t value) const {
  const bool rpdo_comm = in_range(entry.index, 0x1400, 0x1403);
  const bool tpdo_comm = in_range(entry.index, 0x1800, 0x1803);
  const bool rpdo_map = in_range(entry.index, 0x1600, 0x1603);
  const bool tpdo_map = in_range(entry.index, 0x1A00, 0x1A03);
  const auto raw = static_cast<std::uint32_t>(value);
  if ((rpdo_comm || tpdo_comm) && entry.subindex == canopen::kPdoCobIdSub) {
    const auto current = static_cast<std::uint32_t>(stored(entry.index, entry.subindex));
    const bool stays_valid = (current & canopen::kPdoCobIdInvalid) == 0 && (raw & canopen::kPdoCobIdInvalid) == 0;
    // A valid PDO's identifier changes only through the invalid state; no 29-bit identifiers.
    if ((stays_valid && (raw & can::kMaxStandardId) != (current & can::kMaxStandardId)) ||
        (raw & canopen::kPdoCobIdExtended) != 0) {
      return SdoAbortCode::kInvalidValue;
    }
  }
  if ((rpdo_comm || tpdo_comm) && entry.subindex == canopen::kPdoTransmissionTypeSub) {
    const bool synchronous = value <= 240;
    const bool event_driven = value == 254 || value == 255;
    if (!synchronous && !event_driven) return SdoAbortCode::kInvalidValue;
  }
  if (!rpdo_map && !tpdo_map) return std::nullopt;
  const bool receive = rpdo_map;
  const auto valid_entry = [receive](std::uint32_t mapping) {
    const auto mapped = canopen::decode_mapping_entry(mapping);
    const od::OdEntry* object = od::find_entry(mapped.index, mapped.subindex);
    if (object == nullptr || !object->pdo_mappable) return false;
    if (mapped.bit_length != 8U * od::size_bytes(object->type)) return false;
    return receive ? od::writable(object->access) : od::readable(object->access);
  };
  if (entry.subindex == 0) {
    std::size_t bits = 0;
    for (std::uint8_t sub = 1; sub <= value; ++sub) {
      const auto mapping = static_cast<std::uint32_t>(stored(entry.index, sub));
      if (!valid_entry(mapping)) return SdoAbortCode::kObjectNotMappable;
      bits += canopen::decode_mapping_entry(mapping).bit_length;
    }
    if (bits > canopen::kMaxPdoBits) return SdoAbortCode::kPdoLengthExceeded;
    return std::nullopt;
  }
  // CiA 301: entries change only while the mapping is disabled (sub00 = 0). The manual's RO sub00
  // makes that impossible, so without the CiA switch entries are writable at any time.
  if (options_.pdo_configuration_writable && stored(entry.index, 0) != 0) return SdoAbortCode::kUnsupportedAccess;
  if (raw != 0 && !valid_entry(raw)) return SdoAbortCode::kObjectNotMappable;
  return std::nullopt;
}

void Uc57DriveSim::apply_write(const od::OdEntry& entry, std::int64_t value) {
  store(entry.index, entry.subindex, value);
  switch (entry.index) {
    case idx::kControlword: on_controlword(static_cast<std::uint16_t>(value)); break;
    case idx::kModesOfOperation:
      // The UC57 switches at once; the display follows the request (manual §4.2.3).
      store(idx::kModesOfOperationDisplay, 0, value);
      update_profile_velocity();
      break;
    case idx::kTargetVelocity: update_profile_velocity(); break;
    case idx::kProducerHeartbeatTime: restart_heartbeat(); break;
    case idx::kFaultResetCommand:
      if (value == 1) try_fault_reset();
      store(entry.index, entry.subindex, 0);
      break;
    case idx::kZeroPosition:
      if (value == 1 && !kinematics_.at(now_).moving) {
        position_shift_ += static_cast<double>(position(now_));
        kinematics_.set_position(now_, 0);
      }
      store(entry.index, entry.subindex, 0);
      break;
    default: break;
  }
}

// ------------------------------------------------------------------------------------------------
// PDOs and SYNC

canopen::PdoMapping Uc57DriveSim::pdo_mapping(canopen::PdoDirection direction, unsigned number) const {
  const auto index = canopen::pdo_mapping_index(direction, static_cast<std::uint16_t>(number));
  canopen::PdoMapping mapping;
  const auto count = stored(index, 0);
  for (std::uint8_t sub = 1; sub <= count; ++sub) {
    mapping.push_back(canopen::decode_mapping_entry(static_cast<std::uint32_t>(stored(index, sub))));
  }
  return mapping;
}

void Uc57DriveSim::on_rpdo(unsigned number, std::span<const std::uint8_t> payload) {
  const auto type = stored(static_cast<std::uint16_t>(idx::kRpdoCommunication + number - 1), canopen::kPdoTransmissionTypeSub);
  if (type <= 240 && options_.sync_rpdos_supported) {
    rpdo_buffer_[number - 1] = std::vector<std::uint8_t>(payload.begin(), payload.end());  // latest wins
    return;
  }
  apply_rpdo(number, payload);
}

void Uc57DriveSim::apply_rpdo(unsigned number, std::span<const std::uint8_t> payload) {
  const canopen::PdoMapping mapping = pdo_mapping(canopen::PdoDirection::kReceive, number);
  const auto size = canopen::pdo_payload_size(mapping);
  if (!size || mapping.empty()) return;
  if (payload.size() < *size) {  // CiA 301: not processed
    send_emcy({kPdoLengthErrorCode, static_cast<std::uint8_t>(error_register() | 0x11), {}});
    return;
  }
  const auto values = canopen::unpack_pdo(mapping, payload.first(*size));  // extra bytes are ignored
  if (!values) return;
  for (std::size_t i = 0; i < mapping.size(); ++i) {
    const od::OdEntry* entry = od::find_entry(mapping[i].index, mapping[i].subindex);
    if (entry == nullptr) continue;
    const std::int64_t value = od::is_signed(entry->type) ? canopen::sign_extend((*values)[i], mapping[i].bit_length)
                                                          : static_cast<std::int64_t>((*values)[i]);
    if (od::check_value(*entry, value, policy_)) continue;  // out of range: dropped
    apply_write(*entry, value);
  }
}

void Uc57DriveSim::on_sync() {
  if (nmt_ != canopen::NmtState::kOperational) return;
  // Buffered synchronous RPDOs first, in ascending RPDO number (not stated in the manual: assumed).
  for (unsigned n = 1; n <= 4; ++n) {
    if (auto buffered = std::move(rpdo_buffer_[n - 1])) {
      rpdo_buffer_[n - 1].reset();
      apply_rpdo(n, *buffered);
    }
  }
  settle();
  for (unsigned n = 1; n <= 4; ++n) {
    const auto comm = static_cast<std::uint16_t>(idx::kTpdoCommunication + n - 1);
    const auto type = stored(comm, canopen::kPdoTransmissionTypeSub);
    if (type > 240) continue;
    auto payload = tpdo_payload(n);
    if (!payload) continue;
    TpdoRuntime& tpdo = tpdo_[n - 1];
    if (type == 0) {
      if (tpdo.last_sent != payload) send_tpdo(n, std::move(*payload));
    } else if (++tpdo.sync_count >= static_cast<unsigned>(type)) {
      tpdo.sync_count = 0;
      send_tpdo(n, std::move(*payload));
    }
  }
}

std::optional<std::vector<std::uint8_t>> Uc57DriveSim::tpdo_payload(unsigned number) const {
  const auto comm = static_cast<std::uint16_t>(idx::kTpdoCommunication + number - 1);
  if ((static_cast<std::uint32_t>(stored(comm, canopen::kPdoCobIdSub)) & canopen::kPdoCobIdInvalid) != 0) return std::nullopt;
  const canopen::PdoMapping mapping = pdo_mapping(canopen::PdoDirection::kTransmit, number);
  if (mapping.empty()) return std::nullopt;
  std::vector<std::uint64_t> values;
  for (const auto& m : mapping) {
    const od::OdEntry* entry = od::find_entry(m.index, m.subindex);
    const std::int64_t value = entry != nullptr ? current_value(*entry, now_) : 0;
    const std::uint64_t mask = m.bit_length >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << m.bit_length) - 1;
    values.push_back(static_cast<std::uint64_t>(value) & mask);
  }
  const auto packed = canopen::pack_pdo(mapping, values);
  if (!packed) return std::nullopt;
  return std::vector<std::uint8_t>(packed->view().begin(), packed->view().end());
}

void Uc57DriveSim::send_tpdo(unsigned number, std::vector<std::uint8_t> payload) {
  const auto comm = static_cast<std::uint16_t>(idx::kTpdoCommunication + number - 1);
  const auto cob = static_cast<std::uint32_t>(stored(comm, canopen::kPdoCobIdSub)) & can::kMaxStandardId;
  if (const auto frame = can::Frame::make(cob, false, payload)) send(*frame);
  TpdoRuntime& tpdo = tpdo_[number - 1];
  tpdo.last_sent = std::move(payload);
  tpdo.inhibit_until = now_ + std::chrono::microseconds(100 * stored(comm, canopen::kPdoInhibitTimeSub));
  const auto event_ms = stored(comm, canopen::kPdoEventTimerSub);
  tpdo.next_event = event_ms > 0 ? now_ + std::chrono::milliseconds(event_ms) : kNever;
}

// Event-driven TPDOs (types 254/255): on change of a mapped value, not within the inhibit time,
// and periodically with the event timer.
void Uc57DriveSim::service_event_tpdos() {
  if (nmt_ != canopen::NmtState::kOperational) return;
  for (unsigned n = 1; n <= 4; ++n) {
    const auto type = stored(static_cast<std::uint16_t>(idx::kTpdoCommunication + n - 1), canopen::kPdoTransmissionTypeSub);
    if (type < 254) continue;
    auto payload = tpdo_payload(n);
    if (!payload) continue;
    TpdoRuntime& tpdo = tpdo_[n - 1];
    const bool changed = tpdo.last_sent != payload;
    if (changed && now_ < tpdo.inhibit_until) {
      tpdo.next_event = std::min(tpdo.next_event, tpdo.inhibit_until);
      continue;
    }
    if (changed || now_ >= tpdo.next_event) send_tpdo(n, std::move(*payload));
  }
}

void Uc57DriveSim::send_emcy(const canopen::Emergency& emergency) {
  const auto cob = static_cast<std::uint32_t>(stored(idx::kEmcyCobId, 0));
  if ((cob & canopen::kPdoCobIdInvalid) != 0 || nmt_ == canopen::NmtState::kStopped) return;
  can::Frame frame = canopen::encode_emcy(node_, emergency);
  frame.id = cob & can::kMaxStandardId;
  send(frame);
  if (emergency.error_code != 0) {
    error_history_.insert(error_history_.begin(), emergency.error_code);
    if (error_history_.size() > 8) error_history_.pop_back();
  }
}

// ------------------------------------------------------------------------------------------------
// CiA 402 device control

void Uc57DriveSim::on_controlword(std::uint16_t controlword) {
  const std::uint16_t previous = controlword_;
  controlword_ = controlword;
  if (state_ == State::kFault && cia402::rising_edge(previous, controlword, ControlBit::kFaultReset)) {
    try_fault_reset();
  } else {
    // "3+4": 0x0F in Ready to switch on goes on to Operation enabled; the fault-reset edge counts once.
    std::uint16_t edge_base = previous;
    for (int step = 0; step < 3; ++step) {
      const auto transition = cia402::find_command_transition(state_, edge_base, controlword);
      if (!transition || transition->trigger == cia402::Trigger{cia402::Command::kFaultReset}) break;
      enter_state(transition->to);
      edge_base = controlword;
    }
  }
  if (state_ == State::kOperationEnabled) on_operation_mode_bits(previous, controlword);
}

void Uc57DriveSim::enter_state(State next) {
  const State before = state_;
  state_ = next;
  if (before != State::kOperationEnabled || next == State::kOperationEnabled) return;
  if (motor_energised(next)) {  // quick stop, disable operation: ramp down with 6084h
    stop_motion(stop_deceleration(idx::kProfileDeceleration));
  } else if (motion_.active || activity_ != Activity::kIdle) {
    kinematics_.halt(now_);  // output stage off: the motor stops where it is
    settle();
  }
  buffered_set_point_.reset();
  set_point_acknowledged_ = false;
}

void Uc57DriveSim::on_operation_mode_bits(std::uint16_t previous, std::uint16_t controlword) {
  const bool halt = cia402::is_set(controlword, ControlBit::kHalt);
  const bool halt_raised = cia402::rising_edge(previous, controlword, ControlBit::kHalt);
  const bool new_set_point = cia402::rising_edge(previous, controlword, ControlBit::kNewSetPoint);
  const bool set_point_released = cia402::rising_edge(controlword, previous, ControlBit::kNewSetPoint);
  switch (mode()) {
    case static_cast<std::int8_t>(cia402::ModeOfOperation::kProfilePosition):
      if (halt_raised) stop_motion(stop_deceleration(idx::kProfileDeceleration));
      if (new_set_point && !halt) accept_set_point(cia402::is_set(controlword, ControlBit::kChangeSetImmediately));
      if (set_point_released && !buffered_set_point_) set_point_acknowledged_ = false;
      break;
    case static_cast<std::int8_t>(cia402::ModeOfOperation::kProfileVelocity): update_profile_velocity(); break;
    case static_cast<std::int8_t>(cia402::ModeOfOperation::kHoming):
      if (new_set_point && !halt) {
        start_homing();
      } else if (activity_ == Activity::kHoming && (halt_raised || set_point_released)) {
        // Halt or bit 4 1 -> 0 interrupts homing (manual §4.2.6).
        homing_legs_.clear();
        stop_motion(stop_deceleration(idx::kHomingAcceleration));
        finish_homing(false);
      }
      break;
    default: break;
  }
}

std::int8_t Uc57DriveSim::mode() const { return static_cast<std::int8_t>(stored(idx::kModesOfOperationDisplay, 0)); }

std::uint32_t Uc57DriveSim::pulses_per_rev() const {
  return od::pulses_per_revolution(static_cast<std::uint16_t>(stored(idx::kMicrostepping, 0)))
      .value_or(od::kDefaultPulsesPerRevolution);
}

// A trapezoid at `speed` (pulses/s) whose ramps come from two ramp objects; ramps in milliseconds
// span the change from the start speed to `speed` (C-02).
Profile Uc57DriveSim::ramp_profile(double speed, std::uint16_t accel_index, std::uint16_t decel_index,
                                   double start_speed) const {
  const double magnitude = std::abs(speed);
  // A stop from the current speed ramps across that speed.
  const double change = std::max(magnitude > 0 ? magnitude - start_speed : std::abs(kinematics_.at(now_).velocity), 0.0);
  const auto rate = [&](std::uint16_t index) {
    const double a = od::ramp_acceleration(options_.ramp_unit, stored(index, 0), change, pulses_per_rev());
    return std::isfinite(a) && a > 0 ? a : kStepAcceleration;
  };
  return {speed, rate(accel_index), rate(decel_index), std::min(start_speed, magnitude)};
}

// The deceleration of a stop with the ramp object `index`. A stop of a running profile whose ramps
// come from that object brakes at the profile's own deceleration: the ramp's setting spans the
// change between the start speed and the commanded speed (§4.2.4), not the change from the present
// speed to rest, so a halt never brakes more gently than the profile would have (a slow move halted
// near its target otherwise ran the whole ramp time from the present speed and passed the target).
// With nothing of that object running, the ramp spans the present speed.
double Uc57DriveSim::stop_deceleration(std::uint16_t index) const {
  if (activity_ != Activity::kIdle && running_.decel_index == index) return running_.profile.deceleration;
  return ramp_profile(0, index, index, 0).deceleration;
}

void Uc57DriveSim::run_profile(const Profile& profile, std::uint16_t decel_index, std::optional<std::int64_t> target) {
  running_ = {profile, decel_index};
  if (target) {
    kinematics_.move_to(now_, *target, profile);
  } else {
    kinematics_.jog(now_, profile);
  }
}

void Uc57DriveSim::begin_motion(std::int64_t target) {
  if (!motion_.active) {
    motion_.active = true;
    motion_.start = now_;
    motion_.start_utime = frame_utime_;
    if (context_.report) context_.report(motionlcm::sim_report_t::MOTION_STARTED, frame_utime_, position(now_), target);
  }
  motion_.target = target;
}

std::int64_t Uc57DriveSim::utime_at(TimePoint t) const {
  return motion_.start_utime + std::chrono::duration_cast<std::chrono::microseconds>(t - motion_.start).count();
}

bool Uc57DriveSim::motion_done() const { return !running(now_); }

// Kinematics reports the end instant itself as moving; the drive has arrived then.
bool Uc57DriveSim::running(TimePoint now) const {
  if (kinematics_.jogging()) return true;
  const TimePoint end = kinematics_.end_time();
  return end == kNever ? kinematics_.at(now).moving : now < end;
}

// Motion-end bookkeeping: PP arrival (target reached, in position, the buffered set-point),
// homing legs, the end of a stop.
void Uc57DriveSim::settle() {
  for (int guard = 0; guard < 8 && activity_ != Activity::kIdle && motion_done(); ++guard) {
    const TimePoint end = kinematics_.end_time() == kNever ? now_ : kinematics_.end_time();
    if (activity_ == Activity::kHoming && !homing_legs_.empty()) {
      start_homing_leg();
      continue;
    }
    if (activity_ == Activity::kHoming) finish_homing(homing_succeeds_);
    const Activity finished = activity_;
    activity_ = Activity::kIdle;
    target_reached_ = true;
    in_position_ = finished == Activity::kProfilePosition && position(now_) == motion_.target;
    if (motion_.active && context_.report) {
      context_.report(motionlcm::sim_report_t::MOTION_FINISHED, utime_at(end), position(now_), motion_.target);
    }
    const std::int64_t next_utime = utime_at(end);
    motion_ = {};
    if (buffered_set_point_ && state_ == State::kOperationEnabled) {
      SetPoint next = *buffered_set_point_;
      buffered_set_point_.reset();
      next.utime = next_utime;
      start_profile_position(next);
      if (!cia402::is_set(controlword_, ControlBit::kNewSetPoint)) set_point_acknowledged_ = false;
    }
  }
}

void Uc57DriveSim::stop_motion(double deceleration) {
  if (activity_ == Activity::kIdle) return;
  // Like the trapezoid's end (§4.2.4), the braking ends at the start speed with a step to rest.
  kinematics_.stop(now_, deceleration, running_.profile.cut_in);
  if (activity_ != Activity::kHoming) activity_ = Activity::kStopping;
  buffered_set_point_.reset();
  settle();
}

// --- profile position (manual §4.2.4, §7 MC_MOVABS/MC_MOVREL) ---

void Uc57DriveSim::accept_set_point(bool change_immediately) {
  SetPoint set_point{stored(idx::kTargetPosition, 0), cia402::is_set(controlword_, ControlBit::kRelative), frame_utime_};
  if (activity_ == Activity::kProfilePosition && !change_immediately) {
    if (buffered_set_point_) return;  // one-deep buffer full: the edge is ignored
    buffered_set_point_ = set_point;
  } else {
    start_profile_position(set_point);
  }
  set_point_acknowledged_ = true;
}

void Uc57DriveSim::start_profile_position(const SetPoint& set_point) {
  frame_utime_ = set_point.utime;
  const std::int64_t target = set_point.relative ? position(now_) + set_point.target : set_point.target;
  const double start_speed = od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kStartSpeed, 0)), pulses_per_rev());
  const double speed = od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kProfileVelocity, 0)), pulses_per_rev());
  run_profile(ramp_profile(speed, idx::kProfileAcceleration, idx::kProfileDeceleration, start_speed), idx::kProfileDeceleration, target);
  activity_ = Activity::kProfilePosition;
  target_reached_ = false;
  in_position_ = false;
  motion_.active = false;  // a replaced set-point reports a new start
  begin_motion(target);
}

// --- profile velocity (manual §4.2.5) ---

void Uc57DriveSim::update_profile_velocity() {
  const bool runs = state_ == State::kOperationEnabled &&
                    mode() == static_cast<std::int8_t>(cia402::ModeOfOperation::kProfileVelocity) &&
                    !cia402::is_set(controlword_, ControlBit::kHalt);
  const double velocity = od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kTargetVelocity, 0)), pulses_per_rev());
  if (!runs || velocity == 0) {
    if (activity_ == Activity::kProfileVelocity) {
      stop_motion(stop_deceleration(idx::kProfileDeceleration));
    }
    return;
  }
  if (activity_ != Activity::kIdle && activity_ != Activity::kProfileVelocity && activity_ != Activity::kStopping) return;
  const double start_speed = od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kStartSpeed, 0)), pulses_per_rev());
  run_profile(ramp_profile(velocity, idx::kProfileAcceleration, idx::kProfileDeceleration, start_speed), idx::kProfileDeceleration, std::nullopt);
  activity_ = Activity::kProfileVelocity;
  target_reached_ = false;
  begin_motion(velocity > 0 ? std::numeric_limits<std::int32_t>::max() : std::numeric_limits<std::int32_t>::min());
}

// --- homing (manual §4.2.6) ---

void Uc57DriveSim::start_homing() {
  homed_ = homing_attained_ = homing_finished_ = false;
  homing_legs_.clear();
  const auto* method = od::find_homing_method(static_cast<std::uint8_t>(stored(idx::kHomingMethod, 0)));
  if (method == nullptr) {  // homing error, no motion
    homing_finished_ = true;
    return;
  }
  const auto ppr = pulses_per_rev();
  const double fast = od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kHomingSpeeds, 1)), ppr);
  const double slow = od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kHomingSpeeds, 2)), ppr);
  const double accel = ramp_profile(fast, idx::kHomingAcceleration, idx::kHomingAcceleration, 0).acceleration;
  const auto dir = static_cast<std::int64_t>(method->search_direction);
  const std::int64_t signal = method->home_signal == od::HomeSignal::kOrigin          ? options_.origin_position
                              : method->home_signal == od::HomeSignal::kPositiveLimit ? options_.positive_limit
                                                                                       : options_.negative_limit;
  const std::int64_t limit = dir > 0 ? options_.positive_limit : options_.negative_limit;
  const auto physical = static_cast<std::int64_t>(std::llround(kinematics_.at(now_).position + position_shift_));
  // The switch is met at full speed; the drive then decelerates past it.
  const auto overshoot = static_cast<std::int64_t>(std::ceil(fast * fast / (2 * accel)));
  const bool ahead = (signal - physical) * dir >= 0;
  homing_succeeds_ = true;
  if (!ahead && method->on_limit == od::LimitReaction::kStopFailed) {
    homing_legs_.push_back({limit, fast});
    homing_succeeds_ = false;
  } else if (!ahead) {
    // Limit in the search direction: turn round, pass the switch, come back slowly.
    homing_legs_.push_back({limit, fast});
    homing_legs_.push_back({signal - dir * (overshoot + options_.homing_backoff), fast});
    homing_legs_.push_back({signal, slow});
  } else if (method->backs_off_and_locates_slowly) {
    homing_legs_.push_back({signal + dir * overshoot, fast});
    homing_legs_.push_back({signal - dir * options_.homing_backoff, fast});
    homing_legs_.push_back({signal, slow});
  } else {
    homing_legs_.push_back({signal, fast});  // 41/42: stop at once on the switch
  }
  activity_ = Activity::kHoming;
  target_reached_ = false;
  begin_motion(signal);
  start_homing_leg();
}

void Uc57DriveSim::start_homing_leg() {
  const HomingLeg leg = homing_legs_.front();
  homing_legs_.pop_front();
  const auto target = static_cast<std::int64_t>(std::llround(static_cast<double>(leg.physical_target) - position_shift_));
  run_profile(ramp_profile(leg.speed, idx::kHomingAcceleration, idx::kHomingAcceleration, 0), idx::kHomingAcceleration, target);
}

void Uc57DriveSim::finish_homing(bool succeeded) {
  homing_finished_ = true;
  homing_attained_ = succeeded;
  homed_ = succeeded;
  if (!succeeded) return;
  // 6064h = -607Ch at the mechanical home (CiA 402 style).
  const std::int64_t home_value = -stored(idx::kHomeOffset, 0);
  position_shift_ += static_cast<double>(position(now_) - home_value);
  kinematics_.set_position(now_, home_value);
  motion_.target = home_value;
}

// --- faults (manual §6, §4.2.1) ---

void Uc57DriveSim::fault(const canopen::Emergency& emergency) {
  if (activity_ != Activity::kIdle) {
    homing_legs_.clear();
    kinematics_.halt(now_);
    settle();
  }
  buffered_set_point_.reset();
  set_point_acknowledged_ = false;
  for (const auto event : {cia402::DriveEvent::kFaultDetected, cia402::DriveEvent::kFaultReactionDone}) {
    if (const auto t = cia402::find_event_transition(state_, event)) state_ = t->to;
  }
  send_emcy(emergency);
}

void Uc57DriveSim::try_fault_reset() {
  std::uint16_t latched = 0;
  for (unsigned code = 1; code <= kAlarms.size(); ++code) {
    if (kAlarms[code - 1].needs_power_cycle) latched = static_cast<std::uint16_t>(latched | (1U << (code - 1)));
  }
  fault_bits_ &= latched;  // auto-reset alarms clear; power-off alarms stay (manual §6; the reset rule is assumed)
  if (fault_bits_ != 0) return;
  stalled_ = false;
  if (state_ == State::kFault) {
    if (const auto t = cia402::find_command_transition(State::kFault, 0, cia402::controlword_for(cia402::Command::kFaultReset))) {
      state_ = t->to;
    }
  }
  send_emcy({});  // error reset
}

std::uint8_t Uc57DriveSim::error_register() const {
  std::uint8_t reg = 0;
  for (unsigned code = 1; code <= kAlarms.size(); ++code) {
    if ((fault_bits_ & (1U << (code - 1))) != 0) reg = static_cast<std::uint8_t>(reg | kAlarms[code - 1].error_register);
  }
  if (stalled_) reg = static_cast<std::uint8_t>(reg | kStallErrorRegister);
  return reg;
}

// ------------------------------------------------------------------------------------------------
// Status and I/O

std::int64_t Uc57DriveSim::position(TimePoint now) const { return kinematics_.position_counts(now); }

std::uint16_t Uc57DriveSim::statusword(TimePoint now) const {
  std::uint16_t bits = 0;
  const auto set = [&bits](StatusBit bit, bool on) {
    if (on) bits = static_cast<std::uint16_t>(bits | cia402::mask(bit));
  };
  auto motion = kinematics_.at(now);
  motion.moving = running(now);
  if (!motion.moving) motion.velocity = 0;
  set(StatusBit::kAlarm, fault_bits_ != 0 || stalled_);
  set(StatusBit::kHomingDone, homed_);
  set(StatusBit::kNewSetPointEcho, cia402::is_set(controlword_, ControlBit::kNewSetPoint));
  set(StatusBit::kMotorEnabled, motor_energised(state_) && state_ != State::kFaultReactionActive);
  set(StatusBit::kMotorRunning, motion.moving);
  if (state_ == State::kOperationEnabled) {
    switch (mode()) {
      case static_cast<std::int8_t>(cia402::ModeOfOperation::kProfilePosition):
        set(StatusBit::kTargetReached, target_reached_ && !motion.moving);
        set(StatusBit::kSetPointAcknowledge, set_point_acknowledged_);
        set(StatusBit::kInPosition, in_position_);
        break;
      case static_cast<std::int8_t>(cia402::ModeOfOperation::kProfileVelocity): {
        const double target = od::rpm_to_pulses_per_second(static_cast<double>(stored(idx::kTargetVelocity, 0)), pulses_per_rev());
        const bool halted = cia402::is_set(controlword_, ControlBit::kHalt);
        set(StatusBit::kTargetReached, halted ? !motion.moving : std::abs(motion.velocity - target) < 1e-6);
        set(cia402::kSpeedIsZero, !motion.moving);
        break;
      }
      case static_cast<std::int8_t>(cia402::ModeOfOperation::kHoming):
        set(StatusBit::kTargetReached, homing_finished_ && !motion.moving);
        set(cia402::kHomingAttained, homing_attained_);
        break;
      default: break;
    }
  }
  return cia402::compose_statusword(state_ == State::kStart ? State::kNotReadyToSwitchOn : state_, bits);
}

std::uint8_t Uc57DriveSim::input_levels() const {
  const double physical = kinematics_.at(now_).position + position_shift_;
  const bool positive_limit = forced_inputs_[0] || physical >= static_cast<double>(options_.positive_limit);
  const bool origin = forced_inputs_[1] ||
                      std::abs(physical - static_cast<double>(options_.origin_position)) <= static_cast<double>(options_.origin_half_width);
  const bool negative_limit = forced_inputs_[2] || physical <= static_cast<double>(options_.negative_limit);
  return static_cast<std::uint8_t>((positive_limit ? 1 : 0) | (origin ? 2 : 0) | (negative_limit ? 4 : 0));
}

// 60FDh: bit 0 negative limit (X2 = IN3), bit 1 positive limit (X0 = IN1), bit 2 origin (X1 = IN2),
// after the polarity of 2030h:01.
std::uint32_t Uc57DriveSim::digital_inputs() const {
  const auto active = static_cast<std::uint8_t>(input_levels() ^ (stored(idx::kIoConfiguration, 0x01) & 0x07));
  return ((active & 4U) != 0 ? 1U : 0U) | ((active & 1U) != 0 ? 2U : 0U) | ((active & 2U) != 0 ? 4U : 0U);
}

// 2004h: Y0/Y1 per their function (2030h:0D/0E; 0 = the default function: Y0 alarm, Y1 driver
// status) and polarity (2030h:0C).
std::uint16_t Uc57DriveSim::output_states() const {
  const auto output = [this](std::uint8_t function_sub, std::int64_t default_function) {
    std::int64_t function = stored(idx::kIoConfiguration, function_sub);
    if (function == 0) function = default_function;
    switch (function) {
      case 1: return fault_bits_ != 0 || stalled_ || state_ == State::kFault;
      case 2: return motor_energised(state_);
      case 3: return homed_;
      case 4: return in_position_;
      case 5: return true;
      default: return false;
    }
  };
  const auto levels = static_cast<std::uint16_t>((output(0x0D, 1) ? 1 : 0) | (output(0x0E, 2) ? 2 : 0));
  return static_cast<std::uint16_t>(levels ^ (stored(idx::kIoConfiguration, 0x0C) & 0x03));
}

CanDriveFactory uc57_drive_factory(Uc57SimOptions options) {
  return [options](const config::Drive& drive, SimDriveContext context) -> std::unique_ptr<CanDriveSim> {
    return std::make_unique<Uc57DriveSim>(static_cast<canopen::NodeId>(drive.node_id), std::move(context), options);
  };
}

}  // namespace motion::sim
