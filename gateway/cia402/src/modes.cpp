#include "motion/cia402/modes.hpp"

#include "motion/cia402/state_machine.hpp"
#include "motion/cia402/words.hpp"

namespace motion::cia402 {

std::string_view to_string(ModeOfOperation mode) {
  switch (mode) {
    case ModeOfOperation::kNoMode: return "no mode";
    case ModeOfOperation::kProfilePosition: return "profile position";
    case ModeOfOperation::kVelocity: return "velocity";
    case ModeOfOperation::kProfileVelocity: return "profile velocity";
    case ModeOfOperation::kProfileTorque: return "profile torque";
    case ModeOfOperation::kHoming: return "homing";
    case ModeOfOperation::kInterpolatedPosition: return "interpolated position";
    case ModeOfOperation::kCyclicSynchronousPosition: return "cyclic synchronous position";
    case ModeOfOperation::kCyclicSynchronousVelocity: return "cyclic synchronous velocity";
    case ModeOfOperation::kCyclicSynchronousTorque: return "cyclic synchronous torque";
  }
  return "?";
}

std::optional<ModeOfOperation> decode_mode(std::int8_t value) {
  const auto mode = static_cast<ModeOfOperation>(value);
  if (value == 5 || value < 0 || value > 10) return std::nullopt;  // 5 reserved; negatives manufacturer-specific
  return mode;
}

bool uc57_supports(ModeOfOperation mode) {
  return mode == ModeOfOperation::kNoMode || mode == ModeOfOperation::kProfilePosition ||
         mode == ModeOfOperation::kProfileVelocity || mode == ModeOfOperation::kHoming;
}

std::uint16_t profile_position_controlword(SetPointOptions options, bool new_set_point, bool halt) {
  std::uint16_t word = controlword_for(Command::kEnableOperation);
  word = with(word, ControlBit::kNewSetPoint, new_set_point);
  word = with(word, ControlBit::kChangeSetImmediately, options.change_immediately);
  word = with(word, ControlBit::kRelative, options.relative);
  return with(word, ControlBit::kHalt, halt);
}

std::uint16_t NewSetPointHandshake::controlword() const {
  return profile_position_controlword(options_, new_set_point_, halt_);
}

NewSetPointHandshake::Output NewSetPointHandshake::current(std::optional<std::uint16_t> controlword) const {
  return {phase_, controlword, deadline_};
}

NewSetPointHandshake::Output NewSetPointHandshake::advance(Phase next, bool new_set_point, TimePoint now) {
  const bool waits_for_ack = next == Phase::kArming || next == Phase::kTriggered || next == Phase::kReleasing;
  phase_ = next;
  deadline_ = waits_for_ack ? now + ack_timeout_ : kNever;
  const bool bit_changes = new_set_point != new_set_point_;
  new_set_point_ = new_set_point;
  return current(bit_changes || next == Phase::kArming ? std::optional{controlword()} : std::nullopt);
}

NewSetPointHandshake::Output NewSetPointHandshake::start(SetPointOptions options, TimePoint now) {
  options_ = options;
  return advance(Phase::kArming, false, now);
}

NewSetPointHandshake::Output NewSetPointHandshake::on_statusword(std::uint16_t statusword, TimePoint now) {
  const bool acknowledged = is_set(statusword, StatusBit::kSetPointAcknowledge);
  // UC57 §7 MC_MOVABS step 9: bit 10 = 1 with bit 12 = 0, or bit 15 ("in position") = 1.
  const bool reached = is_set(statusword, StatusBit::kTargetReached) || is_set(statusword, StatusBit::kInPosition);
  switch (phase_) {
    case Phase::kArming:
      if (!acknowledged) return advance(Phase::kTriggered, true, now);
      break;
    case Phase::kTriggered:
      if (acknowledged) return advance(Phase::kReleasing, false, now);
      break;
    case Phase::kReleasing:
      if (!acknowledged) return advance(reached ? Phase::kTargetReached : Phase::kMoving, false, now);
      break;
    case Phase::kMoving:
      if (reached) return advance(Phase::kTargetReached, false, now);
      return current();
    case Phase::kIdle:
    case Phase::kTargetReached:
    case Phase::kTimedOut: return current();
  }
  return on_timer(now);
}

NewSetPointHandshake::Output NewSetPointHandshake::on_timer(TimePoint now) {
  if (deadline_ != kNever && now >= deadline_) {
    phase_ = Phase::kTimedOut;
    deadline_ = kNever;
  }
  return current();
}

std::uint16_t NewSetPointHandshake::set_halt(bool halt) {
  halt_ = halt;
  return controlword();
}

}  // namespace motion::cia402
