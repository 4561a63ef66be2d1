#include "motion/cia402/power_controller.hpp"

#include "motion/cia402/words.hpp"

namespace motion::cia402 {

void PowerController::request(State target, TimePoint /*now*/) {
  cancel();
  target_ = target;
}

void PowerController::cancel() {
  target_.reset();
  awaited_.reset();
  awaited_from_.reset();
  awaited_transition_ = 0;
  deadline_ = kNever;
}

PowerController::Action PowerController::finish(Outcome outcome) {
  cancel();
  Action action;
  action.outcome = outcome;
  action.observed = observed_;
  return action;
}

PowerController::Action PowerController::emit(Action action, std::uint16_t controlword) {
  action.controlword_buffer[action.controlword_count++] = controlword;
  last_controlword_ = controlword;
  return action;
}

PowerController::Action PowerController::on_statusword(std::uint16_t statusword, TimePoint now) {
  observed_ = decode_state(statusword);
  Action action;
  action.observed = observed_;
  if (!target_) return action;

  action.outcome = Outcome::kInProgress;
  if (observed_ == target_) return finish(Outcome::kReached);

  // Still where we were when the awaited transition was started (or an undecodable word): keep
  // waiting, without resending, until the deadline.
  if (!observed_ || (awaited_ && observed_ == awaited_from_)) {
    if (deadline_ == kNever) deadline_ = now + config_.state_switch_timeout;
    if (now >= deadline_) return finish(Outcome::kTimedOut);
    action.deadline = deadline_;
    action.transition = awaited_transition_;
    return action;
  }

  // The drive moved (to the awaited state or elsewhere, e.g. Fault): plan from where it is.
  const PlanStep step = plan_next_command(*observed_, *target_);
  switch (step.kind) {
    case PlanStep::Kind::kAtTarget: return finish(Outcome::kReached);  // covered above; kept for completeness
    case PlanStep::Kind::kUnreachable: return finish(Outcome::kUnreachable);
    case PlanStep::Kind::kWaitForDrive:
    case PlanStep::Kind::kSendCommand: break;
  }
  awaited_from_ = observed_;
  awaited_ = step.next;
  awaited_transition_ = step.transition;
  deadline_ = now + config_.state_switch_timeout;
  action.deadline = deadline_;
  action.transition = step.transition;
  if (step.kind == PlanStep::Kind::kWaitForDrive) return action;

  if (step.command == Command::kFaultReset && is_set(last_controlword_, ControlBit::kFaultReset)) {
    // The drive acts on the 0 -> 1 edge only: take bit 7 low first.
    action = emit(action, controlword_for(Command::kDisableVoltage));
  }
  return emit(action, controlword_for(step.command));
}

PowerController::Action PowerController::on_timer(TimePoint now) {
  Action action;
  action.observed = observed_;
  if (!target_) return action;
  if (deadline_ != kNever && now >= deadline_) return finish(Outcome::kTimedOut);
  action.outcome = Outcome::kInProgress;
  action.deadline = deadline_;
  action.transition = awaited_transition_;
  return action;
}

}  // namespace motion::cia402
