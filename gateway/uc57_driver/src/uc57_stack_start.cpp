// Uc57Stack (uc57_stack.hpp): arming a move (its start image, preloaded where the drive applies
// RPDO1 at the SYNC), disarming (the drive left holding its own position), and firing the armed
// moves.
#include "uc57_stack_impl.hpp"

namespace motion::uc57_driver {

void Uc57Stack::start_arm(std::size_t n, Job& job, const motionlcm::axis_command_t& axis, TimePoint /*now*/) {
  Node& node = *nodes_[n];
  const std::int64_t id = job.command.command_id;
  const std::string label = node.settings.label();
  const auto* target_entry = cia402::uc57::find_entry(od::kTargetPosition, 0);
  const auto target = cia402::uc57::quantize_position(*target_entry, static_cast<double>(axis.target_counts));
  if (target.clamped) {
    return part_failed(id, n, error_code(ReplyError::kOutsideLimits),
                       label + ": target " + std::to_string(axis.target_counts) + " counts is outside 607Ah's range " +
                           std::to_string(target_entry->min) + ".." + std::to_string(target_entry->max));
  }
  if (axis.velocity <= 0 || axis.acceleration <= 0 || axis.deceleration <= 0) {
    return part_failed(id, n, error_code(ReplyError::kMalformedRequest),
                       label + ": ARM_MOVE needs a positive velocity, acceleration and deceleration");
  }
  const auto speed = cia402::uc57::quantize_speed(*cia402::uc57::find_entry(od::kProfileVelocity, 0), axis.velocity,
                                                  node.pulses_per_rev);
  const double speed_change = std::max(0.0, speed.realized - node.start_speed);
  const auto accel = cia402::uc57::quantize_ramp(*cia402::uc57::find_entry(od::kProfileAcceleration, 0),
                                                 axis.acceleration, speed_change, node.pulses_per_rev);
  const auto decel = cia402::uc57::quantize_ramp(*cia402::uc57::find_entry(od::kProfileDeceleration, 0),
                                                 axis.deceleration, speed_change, node.pulses_per_rev);
  std::vector<std::pair<ObjectAddress, std::vector<std::uint8_t>>> writes = {
      {{od::kProfileVelocity, 0}, le<std::uint32_t>(static_cast<std::uint32_t>(speed.native))},
      {{od::kProfileAcceleration, 0}, le<std::uint32_t>(static_cast<std::uint32_t>(accel.native))},
      {{od::kProfileDeceleration, 0}, le<std::uint32_t>(static_cast<std::uint32_t>(decel.native))},
  };
  const auto target_counts = static_cast<std::int32_t>(target.native);
  if (node.layout == RpdoLayout::kManualDefault) {
    // No room for 607Ah in the default RPDO1: it goes by SDO now, the edge alone at the SYNC.
    writes.push_back({{od::kTargetPosition, 0}, le<std::int32_t>(target_counts)});
  }
  start_task(n, TaskKind::kArming, id, kNever);
  const unsigned session = node.session;
  set_mode(
      n, kModeProfilePosition,
      [this, n, id, session, target_counts, writes = std::move(writes)](std::optional<std::string> failure) mutable {
        if (failure) return part_failed(id, n, error_code(ReplyError::kArmFailed), *failure);
        sdo_write_all(
            n, std::move(writes), [this, n, id, session, target_counts](std::optional<std::string> write_failure) {
              Node& nd = *nodes_[n];
              if (write_failure) return part_failed(id, n, error_code(ReplyError::kArmFailed), *write_failure);
              if (nd.session != session || nd.task_command != id || nd.task != TaskKind::kArming) return;
              RpdoImage image = latest_image(n);
              image.controlword = cia402::profile_position_controlword({}, false, false);  // 0x0F: bit 4 = 0, halt off
              image.target_position = target_counts;
              image.target_velocity = 0;  // PP frames of the default RPDO1 (manual §5 comm. table) carry 60FFh = 0
              image.mode = kModeProfilePosition;
              queue_image(n, image);
              nd.task_watching = true;
              // A TPDO after the image's SYNC decides; set_point_timeout covers a drive stuck with bit 12.
              nd.task_deadline = now_ + options_.set_point_timeout + 3 * cycle();
            });
      });
}

void Uc57Stack::preload(const Job& job) {
  for (const std::size_t n : job.nodes) {
    // A node applying RPDO1 on reception would start now: its start image waits for fire().
    if (nodes_[n]->phase == Node::Phase::kOperational && nodes_[n]->task == TaskKind::kArmed && nodes_[n]->rpdo_at_sync)
      send_preload(n);
  }
}

void Uc57Stack::send_preload(std::size_t n) {
  Node& node = *nodes_[n];
  RpdoImage image = node.image;  // the armed image as sent: target, mode, bit 4 = 0
  image.controlword = cia402::profile_position_controlword({}, true, false);  // 0x1F: absolute, new set-point
  // A SYNC applies it: the kernel's periodic SYNC (kernel_sync) stops before it goes out; the
  // loop's SYNCs are masked (masked_sync) until the trigger.
  master_.sync()->hold_cyclic(true, now_);
  if (!context_.send || !context_.send(encode_rpdo1(node.settings.node, node.layout, image))) {
    ++counters_.protocol_errors;
    return;  // not in the drive: fire() sends it before the SYNC
  }
  node.preloaded = true;
}

void Uc57Stack::disarm(const Job& disarm_job) {
  std::vector<std::int64_t> victims;
  for (const auto& [id, job] : jobs_.entries()) {
    if (job.command.kind != Command::ARM_MOVE || job.data.started) continue;
    if (disarm_job.command.trigger_id != 0 && job.command.trigger_id != disarm_job.command.trigger_id) continue;
    const bool shares_axis = std::any_of(job.nodes.begin(), job.nodes.end(), [&](std::size_t n) {
      return std::find(disarm_job.nodes.begin(), disarm_job.nodes.end(), n) != disarm_job.nodes.end();
    });
    if (shares_axis) victims.push_back(id);
  }
  for (const auto id : victims) {
    const Job* job = jobs_.find(id);
    if (job == nullptr) continue;
    for (const std::size_t n : job->nodes) neutralize(n);
    part_failed(id, job->nodes.front(), error_code(ReplyError::kStopped),
                "disarmed by command " + std::to_string(disarm_job.command.command_id));
  }
}

// A released move leaves the drive nothing a SYNC or a new-set-point edge could start. An armed
// drive holds the move's target in 607Ah, and where it applies RPDO1 at the SYNC its start image
// (0x1F: new set-point, manual §4.2.4 "0x0F -> 0x1F") may wait in the drive for the next SYNC,
// whoever sends it (manual §4.1.2 SYNC: "simultaneous actions of multiple devices"; CiA 301: a
// synchronous RPDO applies the last one received before the SYNC). The armed image, with 607Ah =
// the position the drive reported (6064h) and bit 4 = 0, goes out at once and replaces it; with
// the manual's default RPDO1 (607Ah not mapped) 607Ah is also written by SDO. A SYNC then applies
// "stay where you are", and even a later edge starts a move of zero pulses.
void Uc57Stack::neutralize(std::size_t n) {
  Node& node = *nodes_[n];
  if (node.phase != Node::Phase::kOperational || !node.status.position_read) return;
  const auto here = static_cast<std::int32_t>(node.status.position_counts);
  RpdoImage image = latest_image(n);
  image.controlword = cia402::profile_position_controlword({}, false, false);  // 0x0F: bit 4 = 0
  image.target_position = here;
  node.rpdo_queue.clear();
  node.power.note_controlword_sent(image.controlword);
  send_image(n, image);
  node.preloaded = false;
  if (node.layout == RpdoLayout::kManualDefault)
    sdo_write_all(n, {{{od::kTargetPosition, 0}, le<std::int32_t>(here)}}, [](std::optional<std::string>) {});
}

// A node that does not answer (heartbeat lost, SDOs unanswered) may still hear: a STOP or ESTOP
// naming it sends its halt (6040h bit 8, manual §4.2.4, 60FFh = 0) or quick stop in RPDO1 all the
// same, applied by the next SYNC like any image. Only for a node that was operational (its RPDO1
// layout is known). Nothing confirms it: the command's reply says so.
bool Uc57Stack::send_blind_stop(std::size_t n, bool quick) {
  Node& node = *nodes_[n];
  if (!node.ever_operational) return false;
  RpdoImage image = latest_image(n);
  const std::uint16_t word = quick ? cia402::apply_command(image.controlword, cia402::Command::kQuickStop)
                                   : cia402::with(image.controlword, ControlBit::kHalt, true);
  image.controlword = cia402::with(word, ControlBit::kNewSetPoint, false);
  image.target_velocity = 0;
  node.rpdo_queue.clear();
  node.preloaded = false;
  send_image(n, image);
  return true;
}

void Uc57Stack::prepare_fire(TimePoint at, TimePoint now) {
  now_ = now;
  start_at_ = at;
  keep_sync_off_start(now);
}

void Uc57Stack::keep_sync_off_start(TimePoint now) {
  if (start_at_ == kNever) return;
  if (now >= start_at_ + kStartGrace) {  // the start never came
    start_at_ = kNever;
    release_held_frames();
    return;
  }
  const auto in_quiet = [this](TimePoint t) {
    return t != kNever && t >= start_at_ - kQuietBeforeStart && t <= start_at_;
  };
  if (stagger_g_ > 0) {  // the stack paces the SYNC itself
    if (in_quiet(next_sync_at_)) next_sync_at_ = start_at_ + sync_period_;
    return;
  }
  auto* sync = master_.sync();
  if (sync != nullptr && in_quiet(sync->next_deadline())) sync->start(start_at_);  // one period after the start
}

void Uc57Stack::fire(std::int64_t trigger_id, TimePoint now) {
  now_ = now;
  start_at_ = kNever;
  std::vector<std::int64_t> ready_jobs;
  std::vector<std::int64_t> early_jobs;
  for (const auto& [id, job] : jobs_.entries()) {
    if (job.command.kind != Command::ARM_MOVE || job.data.started || job.command.trigger_id != trigger_id ||
        trigger_id == 0)
      continue;
    (job.all(Lifecycle::kArmed) ? ready_jobs : early_jobs).push_back(id);
  }
  for (const auto id : early_jobs) {
    const Job* job = jobs_.find(id);
    if (job == nullptr) continue;
    part_failed(id, job->nodes.front(), error_code(ReplyError::kArmFailed),
                "trigger " + std::to_string(trigger_id) + " arrived before every axis of command " +
                    std::to_string(id) + " was armed");
  }
  if (!ready_jobs.empty()) fire_jobs(ready_jobs, now);
  release_held_frames();  // behind the start frames
}

Duration Uc57Stack::start_sync_gap() const {
  return polls_eased_ ? period_within(kConfiguringPollBusShare) : budget_gap_;
}

void Uc57Stack::fire_at_once(std::int64_t command_id, TimePoint now) {
  at_once_.push_back(command_id);
  fire_deferred_at_once(now, false);
}

void Uc57Stack::fire_deferred_at_once(TimePoint now, bool periodic_due) {
  if (!periodic_due && last_sync_at_ != kNever && now < last_sync_at_ + start_sync_gap()) {
    at_once_due_ = last_sync_at_ + start_sync_gap();
    return;
  }
  std::vector<std::int64_t> ready;
  for (const auto id : at_once_) {
    // Stopped, disarmed or failed meanwhile: its terminal reply went out, nothing to start.
    const Job* job = jobs_.find(id);
    if (job != nullptr && !job->data.started && job->all(Lifecycle::kArmed)) ready.push_back(id);
  }
  at_once_.clear();
  at_once_due_ = kNever;
  if (ready.empty()) return;
  fire_jobs(ready, now);  // its SYNC restarts the period; what waited for the periodic one runs
  run_sync_waiters();
  run_slot_waiters();
}

// The synchronized start: every armed node's RPDO1 with bit 4 = 1, then ONE SYNC applies them all.
void Uc57Stack::fire_jobs(const std::vector<std::int64_t>& command_ids, TimePoint now) {
  std::vector<bool> armed(nodes_.size(), false);
  for (const auto id : command_ids) {
    for (const std::size_t n : jobs_.find(id)->nodes) armed[n] = true;
  }
  const std::uint64_t applying_sync = master_.sync()->sent() + 1;
  std::vector<std::size_t> started;  // preloaded start images: only the SYNC goes out for them
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    Node& node = *nodes_[n];
    if (node.phase != Node::Phase::kOperational) continue;
    if (armed[n]) {
      RpdoImage image = latest_image(n);
      image.controlword = cia402::profile_position_controlword({}, true, false);  // 0x1F: absolute, new set-point
      node.rpdo_queue.clear();
      node.power.note_controlword_sent(image.controlword);
      if (node.preloaded) {
        node.image = image;  // already in the drive since arming
        started.push_back(n);
      } else {
        send_image(n, image);
      }
      node.task = TaskKind::kTriggered;
      node.task_deadline = now + options_.set_point_timeout + 2 * cycle();
    } else if (!node.rpdo_queue.empty()) {
      // This SYNC applies whatever else is pending, as a periodic one would.
      send_image(n, node.rpdo_queue.front());
      node.rpdo_queue.pop_front();
      node.preloaded = false;
    } else {
      continue;
    }
    node.image_sync = applying_sync;
  }
  for (const std::size_t n : started) nodes_[n]->preloaded = false;  // this SYNC applies them
  // Any other node's start image waiting for its own trigger must not be applied by this SYNC.
  masked_sync(now, [this, now] { master_.sync()->trigger_now(now); });
  const std::int64_t trigger_utime = options_.wall_clock_us(now);  // the driver replaces it by the start frame's echo
  for (const auto id : command_ids) {
    Job* job = jobs_.find(id);
    if (job == nullptr) continue;
    const StartFacts how = start_facts(*job);  // SYNC, or RPDO1s back to back (uc57_stack_rpdo.cpp)
    if (context_.start_frame) context_.start_frame(id, how.frame);
    job->data.started = true;
    // 0 skew for one SYNC: the nodes' SYNC latency is undocumented.
    job->reply.started(trigger_utime, how.mechanism, how.skew_us);
    jobs_.advance_all(id, Lifecycle::kStarted);  // the ledger replies STARTED
  }
}

}  // namespace motion::uc57_driver
