#include "fake_uc57.hpp"

#include <chrono>
#include <variant>

#include "motion/canopen/sync.hpp"

namespace motion::uc57_driver::testing {
namespace {

using cia402::ControlBit;
using cia402::State;
using cia402::StatusBit;

constexpr std::uint32_t kRemapRefused = 0x06010002;  // write of a read-only entry (the manual's RO)

// The I8/I32 objects among those the fake holds (manual §5.2); everything else is unsigned.
bool is_signed(std::uint16_t index) {
  return index == 0x6060 || index == 0x6061 || index == 0x6064 || index == 0x606C || index == 0x607A ||
         index == 0x607C || index == 0x60FF;
}

}  // namespace

void FakeUc57::reset_dictionary() {
  od_.clear();
  const auto add = [this](std::uint16_t index, std::uint8_t sub, std::int64_t value, std::uint8_t size,
                          bool writable = true) {
    od_[key(index, sub)] = Entry{value, size, writable};
  };
  add(0x1000, 0, 0x00040192, 4, false);
  add(0x1014, 0, 0x80 + id_, 4);
  add(0x1017, 0, 0, 2);
  add(0x1018, 1, 0x322, 4, false);
  // PDO parameters (manual §5 comm. table defaults).
  add(0x1400, 1, 0x200 + id_, 4);
  add(0x1400, 2, 255, 1);
  add(0x1600, 0, 3, 1);
  add(0x1600, 1, 0x60400010, 4);
  add(0x1600, 2, 0x60FF0020, 4);
  add(0x1600, 3, 0x60600008, 4);
  add(0x1600, 4, 0, 4);
  add(0x1800, 1, 0x180 + id_, 4);
  add(0x1800, 2, 255, 1);
  add(0x1801, 1, 0x280 + id_, 4);
  add(0x1801, 2, 255, 1);
  add(0x1A00, 0, 3, 1, false);
  add(0x1A00, 1, 0x60410010, 4);
  add(0x1A00, 2, 0x60FD0020, 4);
  add(0x1A00, 3, 0x60610008, 4);
  add(0x1A01, 0, 2, 1, false);
  add(0x1A01, 1, 0x60640020, 4);
  add(0x1A01, 2, 0x606C0020, 4);
  // Manufacturer and CiA 402 objects used by the driver.
  add(0x2005, 0, 15, 2);
  add(0x2006, 0, 13, 2);
  add(0x200E, 0, 10, 2);
  add(0x2012, 0, 0, 2);
  add(0x2030, 0x0D, 0, 2);
  add(0x2030, 0x0E, 0, 2);
  add(0x603F, 0, 0, 2, false);
  add(0x6040, 0, 0, 2);
  add(0x6041, 0, 0, 2, false);
  add(0x6060, 0, 0, 1);
  add(0x6061, 0, 0, 1, false);
  add(0x6064, 0, 0, 4, false);
  add(0x606C, 0, 0, 4, false);
  add(0x607A, 0, 5000, 4);
  add(0x607C, 0, 0, 4);
  add(0x6081, 0, 60, 4);
  add(0x6083, 0, 50, 4);
  add(0x6084, 0, 50, 4);
  add(0x6098, 0, 0, 1);
  add(0x6099, 1, 120, 4);
  add(0x6099, 2, 60, 4);
  add(0x609A, 0, 50, 4);
  add(0x60FD, 0, 0, 4, false);
  add(0x60FF, 0, 120, 4);
}

std::vector<can::Frame> FakeUc57::power_on(TimePoint now) {
  reset_dictionary();
  nmt_ = canopen::NmtState::kPreOperational;
  state_ = State::kSwitchOnDisabled;
  controlword_ = 0;
  rpdo_buffer_.reset();
  set_point_ack_ = running_ = in_position_ = homed_ = alarm_ = false;
  target_reached_ = true;
  next_heartbeat_ = kNever;
  (void)now;
  if (silent) return {};
  return {canopen::encode_heartbeat(id_, canopen::NmtState::kBootUp)};
}

canopen::PdoMapping FakeUc57::mapping(std::uint16_t index) const {
  canopen::PdoMapping out;
  const auto count = od_.at(key(index, 0)).value;
  for (std::uint8_t sub = 1; sub <= count; ++sub) {
    out.push_back(canopen::decode_mapping_entry(static_cast<std::uint32_t>(od_.at(key(index, sub)).value)));
  }
  return out;
}

std::uint16_t FakeUc57::statusword() const {
  std::uint16_t other = 0;
  const auto set = [&other](StatusBit bit, bool on) {
    if (on) other = static_cast<std::uint16_t>(other | cia402::mask(bit));
  };
  const bool energised =
      state_ == State::kSwitchedOn || state_ == State::kOperationEnabled || state_ == State::kQuickStopActive;
  set(StatusBit::kAlarm, alarm_);
  set(StatusBit::kHomingDone, homed_);
  set(StatusBit::kTargetReached, target_reached_);
  set(StatusBit::kNewSetPointEcho, cia402::is_set(controlword_, ControlBit::kNewSetPoint));
  set(StatusBit::kSetPointAcknowledge, set_point_ack_);
  set(StatusBit::kMotorEnabled, energised);
  set(StatusBit::kMotorRunning, running_);
  set(StatusBit::kInPosition, in_position_);
  return cia402::compose_statusword(state_, other);
}

std::vector<can::Frame> FakeUc57::on_frame(const can::Frame& frame, TimePoint now) {
  std::vector<can::Frame> out;
  if (silent || frame.extended) return out;
  if (frame.id == canopen::kNmtCobId) {
    on_nmt(frame, now, out);
    return out;
  }
  if (frame.id == canopen::kSyncCobId) {
    ++syncs;
    if (nmt_ != canopen::NmtState::kOperational) return out;
    if (rpdo_buffer_) {
      const auto payload = *rpdo_buffer_;
      rpdo_buffer_.reset();
      apply_rpdo(payload);
    }
    step_motion();
    transmit_tpdos(out, true);
    return out;
  }
  if (frame.id == canopen::sdo_request_cob_id(id_)) return on_sdo(frame);
  const bool rpdo1_valid = (od_.at(key(0x1400, 1)).value & 0x80000000) == 0;
  if (frame.id == canopen::rpdo_cob_id(1, id_) && nmt_ == canopen::NmtState::kOperational && rpdo1_valid) {
    const std::vector<std::uint8_t> payload(frame.payload().begin(), frame.payload().end());
    if (od_.at(key(0x1400, 2)).value <= 240) {
      rpdo_buffer_ = payload;  // synchronous: applied at the next SYNC
    } else {
      apply_rpdo(payload);
      transmit_tpdos(out, false);
    }
  }
  return out;
}

void FakeUc57::on_nmt(const can::Frame& frame, TimePoint now, std::vector<can::Frame>& out) {
  const auto request = canopen::decode_nmt(frame.payload());
  if (!request || (request->node != 0 && request->node != id_)) return;
  switch (request->command) {
    case canopen::NmtCommand::kStart: nmt_ = canopen::NmtState::kOperational; break;
    case canopen::NmtCommand::kStop: nmt_ = canopen::NmtState::kStopped; break;
    case canopen::NmtCommand::kEnterPreOperational: nmt_ = canopen::NmtState::kPreOperational; break;
    case canopen::NmtCommand::kResetNode:
    case canopen::NmtCommand::kResetCommunication: {
      auto boot = power_on(now);
      out.insert(out.end(), boot.begin(), boot.end());
      return;
    }
  }
  const auto heartbeat = od_.at(key(0x1017, 0)).value;
  if (heartbeat > 0) next_heartbeat_ = now;  // report the new state at once
}

std::vector<can::Frame> FakeUc57::tick(TimePoint now) {
  std::vector<can::Frame> out;
  const auto heartbeat = od_.at(key(0x1017, 0)).value;
  if (silent || heartbeat <= 0) return out;
  if (next_heartbeat_ == kNever) next_heartbeat_ = now + std::chrono::milliseconds(heartbeat);
  if (now < next_heartbeat_) return out;
  next_heartbeat_ = now + std::chrono::milliseconds(heartbeat);
  out.push_back(canopen::encode_heartbeat(id_, nmt_));
  return out;
}

TimePoint FakeUc57::next_tick() const {
  if (silent || od_.at(key(0x1017, 0)).value <= 0) return kNever;
  return next_heartbeat_;
}

std::vector<can::Frame> FakeUc57::on_sdo(const can::Frame& frame) {
  const auto request = canopen::decode_sdo_request(frame.payload());
  if (!request) return {};
  const auto abort = [this](canopen::ObjectAddress object, std::uint32_t code) {
    return std::vector<can::Frame>{canopen::sdo_response_frame(id_, canopen::SdoAbort{object, code})};
  };
  const auto lookup = [this](canopen::ObjectAddress object) -> std::optional<std::uint32_t> {
    if (od_.count(key(object.index, object.subindex)) != 0) return std::nullopt;
    for (const auto& [k, entry] : od_) {
      if ((k >> 8) == object.index) return 0x06090011;  // the index exists, not this sub-index
    }
    return 0x06020000;
  };
  if (const auto* upload = std::get_if<canopen::SdoInitiateUploadRequest>(&*request)) {
    const auto object = upload->object;
    if (const auto it = forced_aborts.find(key(object.index, object.subindex)); it != forced_aborts.end())
      return abort(object, it->second);
    if (const auto missing = lookup(object)) return abort(object, *missing);
    if (object.index == 0x6041) set_value(0x6041, 0, statusword());
    const Entry& entry = od_.at(key(object.index, object.subindex));
    std::vector<std::uint8_t> bytes(entry.size);
    for (std::size_t i = 0; i < entry.size; ++i)
      bytes[i] = static_cast<std::uint8_t>(static_cast<std::uint64_t>(entry.value) >> (8 * i));
    const auto data = canopen::InlineBytes<4>::from(bytes);
    canopen::SdoInitiateUploadResponse response;
    static_cast<canopen::SdoInitiateData&>(response) = canopen::SdoInitiateData::expedited_data(object, *data);
    return {canopen::sdo_response_frame(id_, response)};
  }
  if (const auto* download = std::get_if<canopen::SdoInitiateDownloadRequest>(&*request)) {
    const auto object = download->object;
    if (const auto it = forced_aborts.find(key(object.index, object.subindex)); it != forced_aborts.end())
      return abort(object, it->second);
    if (const auto missing = lookup(object)) return abort(object, *missing);
    Entry& entry = od_.at(key(object.index, object.subindex));
    const bool remap_object =
        (object.index == 0x1400 && object.subindex == 1) || (object.index == 0x1600 && object.subindex == 0);
    if (!entry.writable || (remap_object && !pdo_remap_writable)) return abort(object, kRemapRefused);
    if (download->data.size() != entry.size) return abort(object, 0x06070010);
    std::uint64_t raw = 0;
    for (std::size_t i = 0; i < download->data.size(); ++i) raw |= std::uint64_t{download->data.view()[i]} << (8 * i);
    write_object(object.index, object.subindex,
                 is_signed(object.index) ? canopen::sign_extend(raw, entry.size * 8U) : static_cast<std::int64_t>(raw));
    if (unanswered_once.erase(key(object.index, object.subindex)) != 0) return {};
    return {canopen::sdo_response_frame(id_, canopen::SdoInitiateDownloadResponse{object})};
  }
  return {};
}

void FakeUc57::write_object(std::uint16_t index, std::uint8_t sub, std::int64_t value) {
  set_value(index, sub, value);
  if (index == 0x6040) apply_controlword(static_cast<std::uint16_t>(value));
  if (index == 0x6060) set_value(0x6061, 0, value);
  if (index == 0x2012 && value == 1) set_value(0x6064, 0, 0);
}

void FakeUc57::apply_rpdo(std::span<const std::uint8_t> payload) {
  const auto map = mapping(0x1600);
  const auto values = canopen::unpack_pdo(map, payload);
  if (!values) return;
  // Objects first, the controlword last: its edge must see the target of the same frame.
  std::optional<std::uint16_t> controlword;
  for (std::size_t i = 0; i < map.size(); ++i) {
    const auto value = is_signed(map[i].index) ? canopen::sign_extend((*values)[i], map[i].bit_length)
                                               : static_cast<std::int64_t>((*values)[i]);
    if (map[i].index == 0x6040) {
      controlword = static_cast<std::uint16_t>((*values)[i]);
      set_value(0x6040, 0, value);
    } else {
      write_object(map[i].index, map[i].subindex, value);
    }
  }
  if (controlword) apply_controlword(*controlword);
}

void FakeUc57::apply_controlword(std::uint16_t controlword) {
  const std::uint16_t previous = controlword_;
  controlwords.push_back(controlword);
  // Device control: the table, applied again for "3+4" (0x0F in Ready to switch on).
  for (int round = 0; round < 2; ++round) {
    const auto transition = cia402::find_command_transition(state_, previous, controlword);
    if (!transition) break;
    if (refuse_enable && transition->to == State::kSwitchedOn) break;
    state_ = transition->to;
    if (transition->to == State::kSwitchOnDisabled && transition->number == 15) {
      alarm_ = false;
      set_value(0x603F, 0, 0);
    }
  }
  controlword_ = controlword;
  if (state_ != State::kOperationEnabled) running_ = false;
  const auto mode = value(0x6061);
  const bool enabled = state_ == State::kOperationEnabled;
  if (cia402::is_set(controlword, ControlBit::kHalt)) {
    running_ = false;
    target_reached_ = true;
    motion_left_ = 0;
  }
  if (enabled && cia402::rising_edge(previous, controlword, ControlBit::kNewSetPoint) &&
      !cia402::is_set(controlword, ControlBit::kHalt)) {
    if (mode == 1) {
      set_point_ack_ = true;
      motion_target_ = value(0x607A);
      move_started_at_sync = syncs;
    } else if (mode == 6) {
      homed_ = false;
      motion_target_ = 0;
    }
    running_ = true;
    target_reached_ = false;
    in_position_ = false;
    motion_left_ = motion_syncs;
  }
  if (!cia402::is_set(controlword, ControlBit::kNewSetPoint)) set_point_ack_ = false;
  if (enabled && mode == 3) {
    running_ = !cia402::is_set(controlword, ControlBit::kHalt) && value(0x60FF) != 0;
    target_reached_ = true;
  }
}

void FakeUc57::step_motion() {
  if (motion_left_ <= 0) return;
  if (--motion_left_ > 0) return;
  running_ = false;
  target_reached_ = true;
  set_value(0x6064, 0, motion_target_);
  if (value(0x6061) == 6) {
    homed_ = true;
    set_point_ack_ = true;  // C-08: bit 12 "homing attained" as well
  } else {
    in_position_ = true;
  }
}

void FakeUc57::transmit_tpdos(std::vector<can::Frame>& out, bool sync_event) {
  const auto emit = [&](std::uint16_t comm, std::uint16_t map_index, std::uint8_t number,
                        std::optional<std::vector<std::uint8_t>>& last) {
    const auto type = value(comm, 2);
    const auto map = mapping(map_index);
    if (map.empty()) return;
    std::vector<std::uint64_t> values;
    for (const auto& entry : map) {
      std::int64_t v = entry.index == 0x6041 ? statusword() : value(entry.index, entry.subindex);
      values.push_back(static_cast<std::uint64_t>(v));
    }
    const auto payload = canopen::pack_pdo(map, values);
    if (!payload) return;
    const std::vector<std::uint8_t> bytes(payload->view().begin(), payload->view().end());
    const bool cyclic = type >= 1 && type <= 240;
    const bool changed = !last || *last != bytes;
    if ((cyclic && sync_event) || (type >= 254 && changed)) {
      last = bytes;
      out.push_back(*can::Frame::make(canopen::tpdo_cob_id(number, id_), false, bytes));
    }
  };
  emit(0x1800, 0x1A00, 1, last_tpdo1_);
  emit(0x1801, 0x1A01, 2, last_tpdo2_);
}

std::vector<can::Frame> FakeUc57::inject_fault(std::uint16_t emcy_code, std::uint16_t fault_bits) {
  alarm_ = true;
  running_ = false;
  motion_left_ = 0;
  set_value(0x603F, 0, fault_bits);
  state_ = State::kFault;  // transitions 13 + 14
  canopen::Emergency emergency;
  emergency.error_code = emcy_code;
  emergency.error_register = 0x03;
  emergency.manufacturer = {0x01, static_cast<std::uint8_t>(fault_bits), 0, 0, 0};
  std::vector<can::Frame> out{canopen::encode_emcy(id_, emergency)};
  if (nmt_ == canopen::NmtState::kOperational) transmit_tpdos(out, false);
  return out;
}

}  // namespace motion::uc57_driver::testing
