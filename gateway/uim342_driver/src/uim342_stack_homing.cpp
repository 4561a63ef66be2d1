// Uim342Stack (uim342_stack.hpp): HOME with a switch search (§4.3, §5.13, §5.26; see the header).
#include "uim342_stack_impl.hpp"

namespace motion::gateway {

std::string Uim342Stack::Impl::edge_name(const Node::Homing& h) {
  return fmt::format("IN{} {} edge", static_cast<int>(h.port) + 1, h.rising ? "rising" : "falling");
}

// HOME: OG where the axis stands (method none / current-position), or a switch search.
Uim342Stack::Impl::Problem Uim342Stack::Impl::load_home(Command& c, std::size_t i, const motionlcm::axis_command_t& a) {
  Node& n = nodes[i];
  const auto id = c.command.command_id;
  if (n.cfg.homing.method != config::HomingMethod::kSwitch) {
    enqueue(i, rq::set_origin(), id);
    c.data.notes.push_back(
        fmt::format("{}: origin set at the current position ({} counts); no switch search (homing method {})", n.name(),
                    a.target_counts, n.cfg.homing.method_name.empty() ? "none" : n.cfg.homing.method_name));
    return std::nullopt;
  }
  if (!n.status.enabled) {
    return std::pair{fmt::format("{} is disabled: a switch search needs the driver on (MO=1)", n.name()),
                     error_code(ReplyError::kAxisDisabled)};
  }
  if (!uim342::speed_to_pps(a.velocity) || a.velocity == 0) {
    return std::pair{fmt::format("{}: homing speed {} counts/s is zero or does not fit 32 bits", n.name(), a.velocity),
                     error_code(ReplyError::kOutsideLimits)};
  }
  Node::Homing h;
  h.command = id;
  h.step = Node::Homing::Step::kReading;
  h.port = static_cast<uim342::InputPort>(std::clamp(n.cfg.homing.input, 1, 3) - 1);
  h.rising = n.cfg.homing.edge == config::HomingEdge::kRising;
  h.velocity = a.velocity;
  h.acceleration = a.acceleration;
  h.deceleration = a.deceleration;
  h.offset = a.target_counts;
  n.homing = h;
  n.move = id;
  // The input's present level decides the search (MS[0] d1, §3.7); IL[i] is kept to restore.
  enqueue(i, rq::get(uim342::MotionStatusIndex::kStatus), id);
  enqueue(i, rq::get_input_logic(static_cast<std::uint8_t>(h.port)), id);
  return std::nullopt;
}

// The requests of a homing step were all answered.
void Uim342Stack::Impl::homing_step_loaded(std::size_t i, TimePoint now) {
  Node& n = nodes[i];
  auto& h = n.homing;
  using Step = Node::Homing::Step;
  switch (h.step) {
    case Step::kReading: {
      const bool level = (n.status.inputs >> static_cast<int>(h.port) & 1) != 0;
      if (level == h.rising) {
        // Already on the switch: leave it the other way; its edge out is the same boundary.
        h.velocity = -h.velocity;
        h.rising = !h.rising;
      }
      const double speed = std::abs(h.velocity);
      const double ramps = h.acceleration > 0 ? 2 * speed / h.acceleration : 0.0;
      h.bound = std::chrono::duration_cast<Duration>(
          std::chrono::duration<double>(static_cast<double>(n.cfg.travel_counts) / speed + ramps + 2.0));
      h.deadline = now + h.bound;
      h.step = Step::kSearchingLoad;
      const auto id = h.command;
      const auto edge_group =
          static_cast<uim342::ParameterGroup>(2 + 2 * static_cast<int>(h.port) + (h.rising ? 0 : 1));
      // §5.13: the edge's own group holds the DC of action 0x06; MF applies to the next set only.
      if (h.deceleration > 0) {
        enqueue(i, rq::select_group(edge_group), id);
        if (auto p = ramp(i, h.deceleration, speed, false, id)) return fail(id, p->second, p->first);
      }
      const uim342::EdgeAction origin{uim342::InputAction::kOriginThenDecelerateStop, true};
      const uim342::EdgeAction nothing{uim342::InputAction::kNone, true};
      enqueue(i, rq::set_input_logic(h.port, h.rising ? nothing : origin, h.rising ? origin : nothing), id);
      motionlcm::axis_command_t jog{};
      jog.velocity = h.velocity;
      jog.acceleration = h.acceleration;
      jog.deceleration = h.deceleration;
      auto* c = commands.find(id);
      if (c == nullptr) return;
      if (auto p = load_jog(*c, i, jog)) return fail(id, p->second, p->first);
      pump(i, now);
      return;
    }
    case Step::kSearchingLoad:
      h.step = Step::kSearching;
      h.seen_moving = false;
      return;
    case Step::kReturningLoad:
      h.step = Step::kReturning;
      h.seen_moving = false;
      return;
    case Step::kNone:
    case Step::kSearching:
    case Step::kReturning: return;
  }
}

// A status of a homing axis (MS[0] poll, edge or position notification).
void Uim342Stack::Impl::homing_observe(std::size_t i, TimePoint now) {
  Node& n = nodes[i];
  auto& h = n.homing;
  using Step = Node::Homing::Step;
  if (h.step != Step::kSearching && h.step != Step::kReturning) return;
  const auto id = h.command;
  if (n.status.fault)
    return fail(id, error_code(ReplyError::kAxisFault),
                fmt::format("{} faulted while homing: {}", n.name(), n.status.fault_text));
  if (n.status.moving) {
    h.seen_moving = true;
    return;
  }
  if (h.step == Step::kSearching) {
    const bool on_switch = ((n.status.inputs >> static_cast<int>(h.port) & 1) != 0) == h.rising;
    if (!(h.edge_seen || on_switch)) {
      if (h.seen_moving) {
        fail(id, error_code(ReplyError::kAxisFault),
             fmt::format("{} stopped before the home switch ({}) was reached", n.name(), edge_name(h)));
      }
      return;
    }
    // Stopped by the origin action: IL[i] as it was, then back to the switch edge (PA = 0).
    h.step = Step::kReturningLoad;
    h.deadline = kNever;
    const auto pps = uim342::speed_to_pps(std::abs(h.velocity));
    const std::int32_t speed = pps ? *pps : 1;  // checked at load
    enqueue(i,
            rq::set_input_logic(h.port, h.previous ? h.previous->falling : uim342::EdgeAction{},
                                h.previous ? h.previous->rising : uim342::EdgeAction{}),
            id);
    enqueue(i, rq::set_absolute_position(0), id);  // §5.19: PA before SP
    enqueue(i, rq::set_ptp_speed(speed), id);
    enqueue(i, rq::begin(), id);
    pump(i, now);
    return;
  }
  if (!n.status.in_position) {
    if (h.seen_moving)
      fail(id, error_code(ReplyError::kAxisFault), fmt::format("{} stopped short of the home switch edge", n.name()));
    return;
  }
  const std::int64_t drive_position = n.status.position_counts - n.offset;
  n.offset = h.offset;
  n.status.position_counts = drive_position + n.offset;
  n.status.homed = true;
  n.status.target_counts = h.offset;
  publish(n, now);
  // This axis is homed; the command is DONE when every axis of it is.
  auto* found = commands.find(id);
  if (found == nullptr) return;
  Command& c = *found;
  const auto done_text =
      fmt::format("{}: origin at the {}, axis at {} counts", n.name(), edge_name(h), n.status.position_counts);
  n.homing = {};
  n.move = 0;
  c.data.notes.push_back(done_text);
  c.data.waiting.erase(i);
  if (c.data.waiting.empty()) stage_done(c, now);
}

// The search bound passed without the switch: stop, restore IL (finish()), fail.
void Uim342Stack::Impl::homing_not_found(std::size_t i, TimePoint) {
  Node& n = nodes[i];
  const auto& h = n.homing;
  const auto reason = fmt::format(
      "{}: home switch ({}) not found within {:.1f} s ({} counts of travel at {} counts/s); axis stopped", n.name(),
      edge_name(h), std::chrono::duration<double>(h.bound).count(), n.cfg.travel_counts, std::abs(h.velocity));
  enqueue(i, rq::stop(), 0, /*front=*/true);
  fail(h.command, error_code(ReplyError::kTimeout), reason);
}

}  // namespace motion::gateway
