// A scripted UIM342 for the stack's tests: answers the instructions addressed to its node id, its
// active group id or the global id with codec-encoded replies (manual §5), and can be told to stay
// silent, refuse an instruction with an error report, finish a move (RT 0x29) or raise an alarm.
// It keeps just enough state for the stack's behaviour to be observable; the real simulator is
// services/sim.
#pragma once

#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "motion/can_frame/frame.hpp"
#include "motion/uim342/uim342.hpp"

namespace motion::gateway::test {

class FakeDrive {
 public:
  // Micro-steps as its EEPROM holds them at power-up (MT[0], QE[4] = x 200): the lab's 16.
  explicit FakeDrive(std::uint8_t node, std::uint8_t group, std::uint16_t micro_steps = 16)
      : node_(node), group_(group), pending_group_(group) {
    words_[{uim342::FunctionCode::kMT, 0}] = micro_steps;
    words_[{uim342::FunctionCode::kQE, 4}] = static_cast<std::uint16_t>(micro_steps * 200);
  }
  bool keeps_micro_steps = true;  // false: MT[0] reverts to `micro_steps` at every reboot
  int reboots = 0;

  bool silent = false;
  bool notify_in_position = true;  // send RT 0x29 when a move finishes
  std::map<uim342::FunctionCode, uim342::DriveErrc> refuse;
  bool locked = false;
  bool stalled = false;
  std::uint8_t inputs = 0;

  [[nodiscard]] std::uint8_t node() const { return node_; }
  [[nodiscard]] std::uint8_t group() const { return group_; }
  [[nodiscard]] bool moving() const { return moving_; }
  [[nodiscard]] bool enabled() const { return enabled_; }
  [[nodiscard]] std::int32_t position() const { return position_; }
  [[nodiscard]] std::int32_t target() const { return target_; }
  [[nodiscard]] std::uint16_t word(uim342::FunctionCode f, std::uint8_t index) const {
    const auto it = words_.find({f, index});
    return it == words_.end() ? 0 : it->second;
  }

  // The frames this drive sends in answer to `frame` (none when it is not addressed to it).
  std::vector<can::Frame> handle(const can::Frame& frame) {
    using FC = uim342::FunctionCode;
    const auto decoded = uim342::decode_instruction_frame(frame);
    if (!decoded || silent) return {};
    const auto to = decoded->address.consumer;
    if (to != node_ && to != group_ && to != uim342::kGlobalId) return {};
    const auto& in = decoded->instruction;
    if (const auto it = refuse.find(in.function); it != refuse.end()) {
      return {reply(uim342::error_report(it->second, in.control_word(), in.sub_index().value_or(0)))};
    }
    const bool set = in.operation == uim342::Operation::kSet;
    std::optional<uim342::Reply> answer = set ? uim342::echo_ack(in) : std::nullopt;
    switch (in.function) {
      case FC::kML: answer = uim342::Reply{FC::kML, uim342::ModelInfo{{0x20, 0x0A, 0x11, 0x00}, 0x0102, 0}}; break;
      case FC::kPP:
        if (set) {
          pending_group_ = std::get<uim342::IndexedByte>(in.body).value;
        } else {
          answer = uim342::Reply{FC::kPP, uim342::IndexedByte{std::get<uim342::Index>(in.body).index, group_}};
        }
        break;
      case FC::kSY:  // reboot: never answered
        group_ = pending_group_;
        ++reboots;
        if (!keeps_micro_steps) words_[{FC::kMT, 0}] = 0;
        return {};
      case FC::kMO:
        if (set) enabled_ = std::get<uim342::Byte>(in.body).value != 0;
        answer = uim342::Reply{FC::kMO, uim342::Byte{static_cast<std::uint8_t>(enabled_ ? 1 : 0)}};
        break;
      case FC::kMS: {
        if (set) {
          in_position_ = false;
          stalled = false;
        }
        const auto index = set ? std::uint8_t{0} : std::get<uim342::Index>(in.body).index;
        if (index == 1) {
          answer = uim342::Reply{FC::kMS, uim342::MotionKinematics{moving_ ? 1000 : 0, position_}};
        } else {
          answer = uim342::Reply{FC::kMS, uim342::MotionStatus{io_status(), flags(), 0}};
        }
        break;
      }
      case FC::kPA: target_ = std::get<uim342::Signed>(in.body).value; break;
      case FC::kIL:  // ports 0..2: d1 falling-edge, d2 rising-edge action byte (§5.26)
        if (const auto* a = std::get_if<uim342::InputActions>(&in.body)) {
          words_[{in.function, a->index}] = static_cast<std::uint16_t>(a->falling.byte() | (a->rising.byte() << 8));
        } else if (const auto* i = std::get_if<uim342::Index>(&in.body); i && i->index <= 2) {
          const auto w = word(FC::kIL, i->index);
          answer = uim342::Reply{
              FC::kIL,
              uim342::InputActions{i->index, uim342::EdgeAction::from_byte(static_cast<std::uint8_t>(w & 0xFF)),
                                   uim342::EdgeAction::from_byte(static_cast<std::uint8_t>(w >> 8))}};
        }
        break;
      case FC::kBG:
        if (!enabled_) return {reply(uim342::error_report(uim342::DriveErrc::kBgWhileDriverOff, in.control_word(), 0))};
        moving_ = true;
        in_position_ = false;
        break;
      case FC::kST: moving_ = false; break;
      case FC::kOG: position_ = 0; break;
      case FC::kDI:
        if (set) outputs_ = std::get<uim342::DigitalOutput>(in.body).outputs & 1U;
        answer = uim342::Reply{FC::kDI, uim342::DigitalIo{inputs, outputs_}};
        break;
      default:
        if (const auto* w = std::get_if<uim342::IndexedWord>(&in.body)) words_[{in.function, w->index}] = w->value;
        if (const auto* i = std::get_if<uim342::Index>(&in.body); i && !set) {
          answer = uim342::Reply{in.function, uim342::IndexedWord{i->index, word(in.function, i->index)}};
        }
        break;
    }
    if (!answer || !in.ack_requested) return {};
    return {reply(*answer)};
  }

  // The move ends on target: position, flags, and the RT 0x29 notification when enabled.
  std::vector<can::Frame> finish_move() {
    position_ = target_;
    moving_ = false;
    in_position_ = true;
    if (!notify_in_position) return {};
    return {*uim342::notification_frame(node_, uim342::PositionReachedNotification{position_})};
  }
  // The armed input-logic origin action fired (§5.26): IN(port+1) changed to `level`, the
  // counter was zeroed at the edge and the motor stopped `overshoot` counts beyond it.
  std::vector<can::Frame> origin_action(uim342::InputPort port, bool level, std::int32_t overshoot) {
    const auto bit = static_cast<std::uint8_t>(1U << static_cast<unsigned>(port));
    inputs = static_cast<std::uint8_t>(level ? (inputs | bit) : (inputs & ~bit));
    position_ = overshoot;
    moving_ = false;
    return {*uim342::notification_frame(
        node_, uim342::InputEdgeNotification{port, level ? uim342::Edge::kRising : uim342::Edge::kFalling})};
  }
  std::vector<can::Frame> alarm(uim342::AlarmCode code) {
    moving_ = false;
    if (code == uim342::AlarmCode::kStall) stalled = true;
    return {*uim342::notification_frame(node_, uim342::AlarmNotification{code})};
  }

 private:
  can::Frame reply(const uim342::Reply& r) const { return *uim342::reply_frame(node_, r); }
  [[nodiscard]] std::uint8_t io_status() const {
    return static_cast<std::uint8_t>(1U | (enabled_ ? 0x04U : 0U) | ((inputs & 7U) << 3) |
                                     (outputs_ != 0 ? 0x40U : 0U));
  }
  [[nodiscard]] std::uint8_t flags() const {
    return static_cast<std::uint8_t>((moving_ ? 0U : 0x01U) | (in_position_ ? 0x02U : 0U) | (stalled ? 0x08U : 0U) |
                                     (locked ? 0x20U : 0U));
  }

  std::uint8_t node_;
  std::uint8_t group_;
  std::uint8_t pending_group_;
  bool enabled_ = false;
  bool moving_ = false;
  bool in_position_ = false;
  std::int32_t position_ = 0;
  std::int32_t target_ = 0;
  std::uint8_t outputs_ = 0;
  std::map<std::pair<uim342::FunctionCode, std::uint8_t>, std::uint16_t> words_;
};

}  // namespace motion::gateway::test
