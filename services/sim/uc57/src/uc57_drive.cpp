#include "motion/sim/uc57_drive.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "motion/canopen/cob_id.hpp"
#include "motion/canopen/sync.hpp"
#include "motion/cia402/modes.hpp"
#include "motion/cia402/uc57_homing.hpp"
#include "motion/cia402/words.hpp"
#include "motion/config/sim_variants.hpp"
#include "uc57_drive_detail.hpp"

namespace motion::sim {
namespace {

using namespace uc57_detail;  // NOLINT(google-build-using-namespace): the sources' shared constants

namespace od = cia402::uc57;
namespace idx = cia402::uc57::index;
using canopen::SdoAbortCode;
using cia402::State;

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
      if (nmt_ != canopen::NmtState::kOperational) {
        tpdo_ = {};  // event TPDOs go out once started; synchronous ones count SYNCs from here
        for (auto& tpdo : tpdo_) tpdo.sync_count = -static_cast<long>(options_.tpdo_sync_skew);
      }
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
        const auto cob =
            static_cast<std::uint32_t>(stored(static_cast<std::uint16_t>(idx::kRpdoCommunication + n - 1), 1));
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
      fault({alarm.code,
             alarm.error_register,
             {static_cast<std::uint8_t>(code), static_cast<std::uint8_t>(bit & 0xFF),
              static_cast<std::uint8_t>(bit >> 8), 0, 0}});
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

void Uc57DriveSim::store(std::uint16_t index, std::uint8_t sub, std::int64_t value) {
  objects_[key(index, sub)] = value;
}

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
    for (std::size_t i = 0; i < data.size(); ++i)
      data[i] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(value) >> (8 * i));
  }
  return {std::move(data), std::nullopt};
}

std::optional<SdoAbortCode> Uc57DriveSim::sdo_write(const canopen::SdoWrite& write) {
  const od::OdEntry* entry = od::find_entry(write.object.index, write.object.subindex);
  auto data = write.data;
  // Expedited without size (0x22): the object's type gives the length.
  if (!write.size_indicated && entry != nullptr)
    data = data.first(std::min<std::size_t>(data.size(), od::size_bytes(entry->type)));
  const od::Lookup lookup = od::check_write(write.object.index, write.object.subindex, data, policy_);
  if (lookup.error) return abort_code(*lookup.error);
  std::array<std::uint8_t, 4> raw{};
  std::copy_n(data.begin(), std::min<std::size_t>(data.size(), od::size_bytes(lookup.entry->type)), raw.begin());
  const auto value = od::decode_value(lookup.entry->type,
                                      std::span<const std::uint8_t>(raw).first(od::size_bytes(lookup.entry->type)));
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
    // rpdo_sync: refused — a drive without synchronous RPDOs takes only the manual's FFh (and 254).
    if (rpdo_comm && synchronous && options_.rpdo_sync == RpdoSync::kRefused) return SdoAbortCode::kInvalidValue;
    if (tpdo_comm && value >= 2 && value <= 240 && options_.tpdo_every_sync_only) return SdoAbortCode::kInvalidValue;
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
    // A wide counter: sub00 = 255 would wrap an 8-bit one round forever.
    for (std::int64_t sub = 1; sub <= value; ++sub) {
      const auto mapping = static_cast<std::uint32_t>(stored(entry.index, static_cast<std::uint8_t>(sub)));
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
  const std::int8_t mode_before = mode();
  store(entry.index, entry.subindex, value);
  switch (entry.index) {
    case idx::kControlword: on_controlword(static_cast<std::uint16_t>(value)); break;
    case idx::kModesOfOperation:
      // The UC57 switches at once; the display follows the request (manual §4.2.3).
      store(idx::kModesOfOperationDisplay, 0, value);
      // Statusword bits 12 and 13 belong to the mode in force (§4.2.4-§4.2.6, CiA 402): profile
      // position entered anew has no set-point pending, whatever bit 4 did in another mode (the
      // manual is silent on this; assumed reading). RPDO1 writes 6060h with every frame: only a
      // change of mode resets.
      if (mode() != mode_before) {
        set_point_acknowledged_ = false;
        buffered_set_point_.reset();
      }
      update_profile_velocity();
      break;
    case idx::kTargetVelocity: update_profile_velocity(); break;
    case idx::kProducerHeartbeatTime: restart_heartbeat(); break;
    case idx::kTpdoCommunication:
    case idx::kTpdoCommunication + 1:
    case idx::kTpdoCommunication + 2:
    case idx::kTpdoCommunication + 3:
      // A written transmission type restarts the TPDO's SYNC count (CiA 301 leaves it to the
      // device; CANopenNode does so): type n then sends at the n-th SYNC after the write.
      if (entry.subindex == canopen::kPdoTransmissionTypeSub)
        tpdo_[entry.index - idx::kTpdoCommunication].sync_count = -static_cast<long>(options_.tpdo_sync_skew);
      break;
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
  const auto type =
      stored(static_cast<std::uint16_t>(idx::kRpdoCommunication + number - 1), canopen::kPdoTransmissionTypeSub);
  if (type <= 240 && options_.rpdo_sync == RpdoSync::kHonoured) {
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
    } else if (++tpdo.sync_count >= static_cast<long>(type)) {
      tpdo.sync_count = 0;
      send_tpdo(n, std::move(*payload));
    }
  }
}

std::optional<std::vector<std::uint8_t>> Uc57DriveSim::tpdo_payload(unsigned number) const {
  const auto comm = static_cast<std::uint16_t>(idx::kTpdoCommunication + number - 1);
  if ((static_cast<std::uint32_t>(stored(comm, canopen::kPdoCobIdSub)) & canopen::kPdoCobIdInvalid) != 0)
    return std::nullopt;
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
    const auto type =
        stored(static_cast<std::uint16_t>(idx::kTpdoCommunication + n - 1), canopen::kPdoTransmissionTypeSub);
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

std::optional<RpdoSync> parse_rpdo_sync(std::string_view text) {
  if (text == "honoured") return RpdoSync::kHonoured;
  if (text == "on_reception") return RpdoSync::kOnReception;
  if (text == "refused") return RpdoSync::kRefused;
  return std::nullopt;
}

CanDriveFactory uc57_drive_factory(const config::Config& config, Uc57SimOptions options) {
  std::map<std::string, RpdoSync, std::less<>> rpdo_sync;
  for (const auto& d : config.drives) {
    if (d.family != config::Family::kUc57) continue;
    rpdo_sync[d.name] = parse_rpdo_sync(config::sim_variant(config, d, "rpdo_sync")).value_or(options.rpdo_sync);
  }
  return [options, rpdo_sync](const config::Drive& drive, SimDriveContext context) -> std::unique_ptr<CanDriveSim> {
    Uc57SimOptions o = options;
    if (const auto it = rpdo_sync.find(drive.name); it != rpdo_sync.end()) o.rpdo_sync = it->second;
    return std::make_unique<Uc57DriveSim>(static_cast<canopen::NodeId>(drive.node_id), std::move(context), o);
  };
}

CanDriveFactory uc57_drive_factory(Uc57SimOptions options) {
  return [options](const config::Drive& drive, SimDriveContext context) -> std::unique_ptr<CanDriveSim> {
    return std::make_unique<Uc57DriveSim>(static_cast<canopen::NodeId>(drive.node_id), std::move(context), options);
  };
}

}  // namespace motion::sim
