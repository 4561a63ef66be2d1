// AdamStack (adam_stack.hpp): arming a move (its table entry 0 loaded and saved, every other drive
// of the line made neutral), neutralizing a drive's table entry, and firing the armed moves with
// the broadcast "execute table data".
#include "adam_stack_impl.hpp"

namespace motion::adam_driver {

void AdamStack::arm_move(Operation& op, TimePoint now) {
  (void)now;
  const std::int64_t id = op.command.command_id;
  op.goal = Operation::Goal::kReachTarget;
  // Other drives of the line are made neutral (table entry 0 = where they stand), so that the
  // broadcast "execute table entry" moves only the armed ones. Queued first: done by ARMED.
  for (auto& other : drives_) {
    Drive* d = other.get();
    if (std::find(op.drives.begin(), op.drives.end(), d) != op.drives.end()) continue;
    if (d->table_entry != d->position) neutralize(*d);
  }
  for (std::size_t i = 0; i < op.drives.size(); ++i) {
    Drive& d = *op.drives[i];
    const auto& a = op.command.axes[i];
    const auto fail = [&](const std::string& why) {
      finish(id, Reply::FAILED, "axis " + a.axis + ": " + why, error_code(ReplyError::kArmFailed));
    };
    if (a.target_counts < std::numeric_limits<std::int32_t>::min() ||
        a.target_counts > std::numeric_limits<std::int32_t>::max())
      return fail("target " + std::to_string(a.target_counts) + " outside INT32 pulses");
    if (!(a.velocity > 0) || !(a.acceleration > 0) || !(a.deceleration > 0))
      return fail("velocity, acceleration and deceleration must be positive");
    // Whole rpm, written to 0x009A (§8.44, what §8.65's motion commands read) and 0x00D8 (§8.64):
    // which of them a table entry runs at is not said, so both hold the planned speed.
    const long rpm_whole = std::lround(rpm_of(d, a.velocity));
    if (rpm_whole < 1 || rpm_whole > kMaxWorkingSpeedRpm)
      return fail("speed " + std::to_string(a.velocity) + " counts/s is outside 1…1000 whole rpm (0x009A, 0x00D8)");
    const double rpm = static_cast<double>(rpm_whole);
    const auto speed_centi = static_cast<std::int32_t>(rpm_whole * 100);
    // Start and stop speed 0 (§8.40, §8.41; ramp times per §8.42, §8.43): the ramps are then
    // exactly v/a, the planned trapezoid.
    const auto accel = adam::ramp_time_ms(0, rpm, std::abs(rpm_of(d, a.acceleration)));
    const auto decel = adam::ramp_time_ms(0, rpm, std::abs(rpm_of(d, a.deceleration)));
    if (!accel || !decel) return fail("ramp time outside 0…65535 ms (0x0098/0x0099)");
    adam::SyncMovePreload preload;
    preload.profile = {0, 0, accel.value().value, decel.value().value, speed_centi};
    preload.target_pulses = static_cast<std::int32_t>(a.target_counts);
    preload.start_offset = kTableStartOffset;
    auto writes = adam::sync_move_preload(d.cfg.unit, preload);
    if (!writes) return fail("cannot preload: " + writes.error().message());
    writes.value().insert(writes.value().begin(),
                          adam::write16(d.cfg.unit, Reg::kWorkingSpeed, static_cast<std::uint16_t>(rpm_whole)));
    // §8.54: the table data is saved before it is executed (setup table_save); a Save erases
    // flash for 0.1 s (§8.69) and is never retried (see is_save()).
    if (d.cfg.table_save) writes.value().push_back(adam::command(d.cfg.unit, adam::SaveCommand::kSave));
    d.motion_owner = id;
    for (std::size_t w = 0; w < writes.value().size(); ++w) {
      std::function<void(TimePoint)> after;
      if (w + 1 == writes.value().size())
        after = [&d, target = preload.target_pulses](TimePoint) { d.table_entry = target; };
      add_write(op, d, writes.value()[w], std::move(after));
    }
  }
  when_transferred(op, [this, id](TimePoint at) {
    Operation* armed = operation(id);
    if (armed == nullptr) return;
    operations_.advance_all(id, gateway::Lifecycle::kArmed);  // the ledger replies ARMED
    if (armed->command.trigger_id == 0) start_armed(*armed, at);
  });
}

bool AdamStack::neutralize(Drive& d) {
  if (!d.online || !d.position || d.motion_owner != 0 || (d.status && d.status->moving())) return false;
  Drive* drive = &d;
  const std::int32_t here = *d.position;
  auto writes = adam::single_entry_writes(d.cfg.unit, kTableStartOffset, here);
  if (!writes) return false;
  if (d.cfg.table_save) writes.value().push_back(adam::command(d.cfg.unit, adam::SaveCommand::kSave));
  d.table_entry.reset();  // unknown until the last write is answered
  for (std::size_t i = 0; i < writes.value().size(); ++i) {
    Transaction t{writes.value()[i], drive};
    if (i + 1 == writes.value().size())
      t.on_reply = [drive, here](const rtu::Response&, TimePoint, TimePoint) { drive->table_entry = here; };
    t.on_fail = [this, drive](const std::string& reason, std::int32_t) {
      event(drive, Event::ERROR_REPORT, Event::WARNING, 0,
            "could not neutralize the table of " + drive->cfg.drive + ": " + reason);
    };
    enqueue(std::move(t));
  }
  return true;
}

bool AdamStack::neutral_for(const Drive& d, const Operation& firing) const {
  if (std::find(firing.drives.begin(), firing.drives.end(), &d) != firing.drives.end()) return true;
  // Executing its table entry must move nothing: idle, entry = position, and no command of ours
  // pending on it. A drive that never answered cannot be vouched for.
  return d.motion_owner == 0 && d.status && !d.status->moving() && d.position && d.table_entry == d.position;
}

bool AdamStack::awaiting_trigger() const {
  return std::any_of(operations_.entries().begin(), operations_.entries().end(), [](const auto& e) {
    const auto& [id, entry] = e;
    return !entry.data->watching && entry.all(gateway::Lifecycle::kArmed) && entry.data->command.trigger_id != 0;
  });
}

void AdamStack::fire(std::int64_t trigger_id, TimePoint now) {
  reserved_at_ = kNever;
  std::vector<std::int64_t> ids;
  for (const auto& [id, entry] : operations_.entries()) {
    if (!entry.data->watching && entry.all(gateway::Lifecycle::kArmed) && entry.data->command.trigger_id == trigger_id)
      ids.push_back(id);
  }
  for (const auto id : ids) {
    if (Operation* op = operation(id)) start_armed(*op, now);
  }
  send_next(now);
}

void AdamStack::start_armed(Operation& op, TimePoint now) {
  const std::int64_t id = op.command.command_id;
  op.watching = true;  // no second fire
  for (Drive* d : op.drives) {
    d->target = d->table_entry.value_or(0);
    // Polled slowly (a long line), the whole move may run between two samples: arriving at 0 is
    // not a power-up (PowerUpWatch).
    d->power.travel_started(d->target);
  }
  const bool broadcast =
      std::all_of(drives_.begin(), drives_.end(), [&](const auto& d) { return neutral_for(*d, op); });
  if (broadcast) {
    Transaction start{adam::table_execute_broadcast().value(), nullptr, id};
    start.on_reply = [this, id](const rtu::Response&, TimePoint at, TimePoint frame_end) {
      auto* entry = operations_.find(id);
      if (entry == nullptr) return;
      (void)at;
      entry->data->trigger_utime = wall_clock_(frame_end);
      entry->reply.started(entry->data->trigger_utime, "broadcast", 0.0);
      operations_.advance_all(id, gateway::Lifecycle::kStarted);  // the ledger replies STARTED
    };
    enqueue(std::move(start), /*urgent=*/true);
  } else {
    // One absolute move per axis (0x00D0, §8.65⑥), in order, each acknowledged.
    const Duration per_axis = rtu::transmission_time(settings_.format, 13) +
                              rtu::transmission_time(settings_.format, 8) + 2 * timing_.t3_5 +
                              adam::kAssumedReplyLatency;
    const double skew_us =
        std::chrono::duration<double, std::micro>(per_axis).count() * static_cast<double>(op.drives.size() - 1);
    op.outstanding = 0;
    std::vector<Transaction> starts;
    for (Drive* d : op.drives) {
      ++op.outstanding;
      Transaction t{
          adam::move(d->cfg.unit, adam::MoveCommand::kAbsoluteAtStandstill, static_cast<std::int32_t>(d->target)), d,
          id};
      t.max_retries = d->cfg.retries;
      t.on_reply = [this, id, skew_us](const rtu::Response&, TimePoint at, TimePoint frame_end) {
        auto* entry = operations_.find(id);
        if (entry == nullptr) return;
        Operation& o = *entry->data;
        (void)at;
        if (o.trigger_utime == 0) o.trigger_utime = wall_clock_(frame_end);
        if (--o.outstanding == 0) {
          entry->reply.started(o.trigger_utime, "sequential", skew_us);
          operations_.advance_all(id, gateway::Lifecycle::kStarted);  // the ledger replies STARTED
        }
      };
      t.on_fail = [this, id](const std::string& reason, std::int32_t code) { finish(id, Reply::FAILED, reason, code); };
      starts.push_back(std::move(t));
    }
    for (auto it = starts.rbegin(); it != starts.rend(); ++it) enqueue(std::move(*it), /*urgent=*/true);
  }
  send_next(now);
}

}  // namespace motion::adam_driver
