// Uc57Stack (uc57_stack.hpp): construction, accessors, frames in and the SYNC cycle, process data.
#include "uc57_stack_impl.hpp"

#include "motion/can_frame/bit_timing.hpp"
#include "motion/canopen/nmt.hpp"
#include "motion/canopen/sync.hpp"

namespace motion::uc57_driver {

// ---------------------------------------------------------------------------------------------
// Construction
// ---------------------------------------------------------------------------------------------

Uc57Stack::Uc57Stack(const config::Config& config, const config::Bus& bus, gateway::CanStackContext context)
    : Uc57Stack(config, bus, std::move(context), Options{}) {}

Uc57Stack::Uc57Stack(const config::Config& config, const config::Bus& bus, gateway::CanStackContext context,
                     Options options)
    : context_(std::move(context)),
      options_(std::move(options)),
      bus_(bus.name),
      sync_period_(
          std::chrono::duration_cast<Duration>(std::chrono::duration<double>(1.0 / std::max(bus.poll_hz, 0.1)))),
      master_([this](const can::Frame& frame) { send_master_frame(frame); }) {
  bitrate_ = static_cast<std::uint32_t>(std::max(bus.bitrate, 1));
  options_.wall_clock_us = gateway::or_system_clock(std::move(options_.wall_clock_us));
  for (const auto& drive : config.drives) {
    if (drive.family != config::Family::kUc57 || drive.bus != bus.name) continue;
    auto node = std::make_unique<Node>();
    node->settings = make_node_settings(config, bus, drive, options_.default_heartbeat_ms);
    node->power = cia402::PowerController({options_.state_switch_timeout});
    node_index_[node->settings.node] = nodes_.size();
    nodes_.push_back(std::move(node));
  }
  master_.nmt().on_event([this](const canopen::NodeEvent& e) { on_node_event(e); });
  master_.emcy().on_event([this](const canopen::EmcyEvent& e) { on_emcy(e); });
  asked_period_ = sync_period_;
  plan_stagger();
  fit_sync_period();
  for (const auto& node : nodes_) {
    // Retries are ours (sdo_read/sdo_write) so that they can be counted.
    master_.sdo().configure_node(node->settings.node, {sdo_timeout(*node), 0, std::size_t{64} * 1024});
  }
  // Staggered: the stack paces each SYNC itself (sync_due); the producer only sends on demand,
  // and the kernel's periodic job (kernel_sync), which cannot wait for the wire, is not used.
  master_.configure_sync({stagger_g_ > 0 ? Duration::zero() : sync_period_, 0, canopen::kSyncCobId});
  if (context_.start_cyclic && context_.stop_cyclic && stagger_g_ == 0) {
    // kernel_sync: the kernel sends the periodic SYNC; the producer keeps its schedule and
    // counts the SYNCs seen on the wire (on_cyclic_sent).
    master_.sync()->use_cyclic_sender(
        {[this](const can::Frame& frame, Duration period) {
           if (!context_.start_cyclic(frame, period)) return false;
           wire_sent_ += can::frame_duration(frame, bitrate_);  // its first SYNC goes out now
           last_sync_end_ = wire_sent_;
           return true;
         },
         [this] { context_.stop_cyclic(canopen::encode_sync({}, canopen::kSyncCobId)); },
         [this](Duration interval) {
           return context_.retime_cyclic &&
                  context_.retime_cyclic(canopen::encode_sync({}, canopen::kSyncCobId), interval);
         }});
  }
}

Uc57Stack::~Uc57Stack() = default;

void Uc57Stack::send_master_frame(const can::Frame& frame) {
  const bool sync = frame.id == canopen::kSyncCobId && !frame.extended;
  if (!sync && holding_for_start()) {
    held_for_start_.push_back(frame);
    return;
  }
  if (sync) {
    ++syncs_handed_;
    last_sync_at_ = now_;
    // Staggered pacing: the next one a period on, whether or not the transport took this one.
    if (stagger_g_ > 0) next_sync_at_ = now_ + sync_period_;
  }
  if (!context_.send || !context_.send(frame)) {
    ++counters_.protocol_errors;
    return;
  }
  wire_sent_ += can::frame_duration(frame, bitrate_);
  if (sync) {
    last_sync_end_ = wire_sent_;
    on_sync_handed();
  }
}

bool Uc57Stack::holding_for_start() const {
  return start_at_ != kNever && now_ >= start_at_ - kQuietBeforeStart && now_ < start_at_ + kStartGrace;
}

void Uc57Stack::release_held_frames() {
  for (const can::Frame& frame : std::exchange(held_for_start_, {})) send_master_frame(frame);
}

std::vector<std::string> Uc57Stack::axes() const {
  std::vector<std::string> out;
  for (const auto& node : nodes_) {
    if (!node->settings.axis.empty()) out.push_back(node->settings.axis);
  }
  return out;
}

std::string Uc57Stack::rpdo_sync_finding(std::string_view drive) const {
  for (const auto& node : nodes_) {
    if (node->settings.drive == drive && node->phase == Node::Phase::kOperational) return node->rpdo_finding;
  }
  return {};
}

std::optional<RpdoLayout> Uc57Stack::rpdo_layout(std::string_view drive) const {
  for (const auto& node : nodes_) {
    if (node->settings.drive == drive && node->phase == Node::Phase::kOperational) return node->layout;
  }
  return std::nullopt;
}

bool Uc57Stack::ready() const {
  return std::all_of(nodes_.begin(), nodes_.end(),
                     [](const auto& node) { return node->phase == Node::Phase::kOperational; });
}

void Uc57Stack::add_statistics(motionlcm::bus_stats_t& stats) const {
  stats.timeouts += counters_.sdo_timeouts;
  stats.retries += counters_.sdo_retries;
  // bus_stats_t has no protocol-level fields: drive-reported errors count as bus errors.
  stats.errors += counters_.sdo_aborts + counters_.emcy + counters_.protocol_errors;
  stats.drives_total += static_cast<std::int32_t>(nodes_.size());
  stats.drives_online += static_cast<std::int32_t>(
      std::count_if(nodes_.begin(), nodes_.end(), [](const auto& node) { return node->status.online; }));
}

std::string Uc57Stack::offline_text(std::size_t n) const {
  const Node& node = *nodes_[n];
  return node.settings.label() + " is offline" + (node.offline_reason.empty() ? "" : ": " + node.offline_reason);
}

void Uc57Stack::event(std::size_t n, std::int16_t kind, std::int8_t severity, std::int32_t code,
                      const std::string& text) {
  if (context_.out == nullptr) return;
  gateway::DriveEvent e;
  e.kind = kind;
  e.severity = severity;
  e.code = code;
  e.text = text;
  context_.out->axis_event(nodes_[n]->settings.axis, e);
}

// ---------------------------------------------------------------------------------------------
// Frames in, deadlines
// ---------------------------------------------------------------------------------------------

bool Uc57Stack::on_frame(const can::Frame& frame, TimePoint now) {
  now_ = now;
  spend_wire(frame, now);  // staggered pacing: what the wire carried
  // 29-bit frames belong to the UIM342 stack; RTR frames are nothing this master consumes.
  if (frame.extended || frame.rtr) return false;
  const auto info = canopen::classify_cob_id(frame.id);
  std::optional<std::size_t> n;
  if (info) {
    const auto it = node_index_.find(info->node);
    if (it != node_index_.end()) n = it->second;
  }
  if (!n) {
    // A relocated EMCY COB-ID (1014h) of one of our nodes; anything else belongs to someone else.
    if (relocated_emcy_ids_.count(frame.id) == 0) return false;
    master_.emcy().on_frame(frame, now);
    return true;
  }
  switch (info->kind) {
    case canopen::MessageKind::kSdoResponse:
    case canopen::MessageKind::kHeartbeat:
    case canopen::MessageKind::kEmcy: master_.on_frame(frame, now); return true;
    case canopen::MessageKind::kTpdo:
      on_tpdo_seen(*n, info->pdo_number);
      on_pdo(*n, frame, now);
      return true;
    default:
      // Requests and RPDOs *to* our nodes come from another master: not ours.
      return false;
  }
}

void Uc57Stack::on_cyclic_sent(const can::Frame& frame, TimePoint now) {
  now_ = now;
  if (frame.extended || frame.id != canopen::kSyncCobId) return;
  master_.sync()->on_cyclic_sync(now);
  last_sync_at_ = now;
}

TimePoint Uc57Stack::process(TimePoint now) {
  now_ = now;
  if (!started_) return kNever;
  TimePoint next = kNever;
  std::size_t busy = configuring();
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    Node& node = *nodes_[n];
    if (node.awaiting_slot && busy < configuration_window_) {
      probe_now(n);
      ++busy;
    }
    if (node.phase == Node::Phase::kOffline && now >= node.retry_at) {
      begin_probe(n, now);
      if (node.phase == Node::Phase::kConfiguring) ++busy;
    }
    if (node.phase == Node::Phase::kStarting && now >= node.starting_deadline) {
      node.starting_deadline = kNever;
      configuration_failed(n, node.settings.label() + ": no Operational heartbeat after NMT start", true);
    }
    if (node.phase == Node::Phase::kOperational && !node.tpdo2_active && now >= node.next_position_poll &&
        !node.position_poll_in_flight) {
      node.position_poll_in_flight = true;
      node.next_position_poll = now + cycle();
      sdo_read(n, {od::kPositionActual, 0}, [this, n](std::error_code ec, std::span<const std::uint8_t> data) {
        nodes_[n]->position_poll_in_flight = false;
        if (ec) return;
        nodes_[n]->status.position_counts = read_signed(data);
        nodes_[n]->status.position_read = true;
        publish_status(n);
      });
    }
  }
  check_task_timeouts(now);
  keep_sync_off_start(now);  // before any SYNC below comes due
  if (!at_once_.empty()) {
    const bool periodic_due = stagger_g_ > 0 ? next_sync_check() <= now : master_.sync()->next_deadline() <= now;
    if (periodic_due || now >= at_once_due_) fire_deferred_at_once(now, periodic_due);
  }
  ease_polls_while_configuring(now);
  if (stagger_g_ > 0) {
    if (sync_due(now)) run_sync_cycle(now);
    next = std::min(next, next_sync_check());
  } else if (master_.sync()->next_deadline() <= now) {
    run_sync_cycle(now);
  }
  next = std::min(next, master_.process(now));
  if (!at_once_.empty()) next = std::min(next, at_once_due_);
  // A kernel's cyclic SYNC goes out without the loop: judged before the quiet time begins.
  if (start_at_ != kNever)
    next =
        std::min(next, now < start_at_ - kQuietBeforeStart ? start_at_ - kQuietBeforeStart : start_at_ + kStartGrace);
  for (const auto& node : nodes_) {
    next = std::min({next, node->retry_at, node->starting_deadline, node->task_deadline});
    if (node->task == TaskKind::kPower) next = std::min(next, node->power.deadline());  // as check_task_timeouts
    if (node->phase == Node::Phase::kOperational && !node->tpdo2_active)
      next = std::min(next, node->next_position_poll);
  }
  return std::max(next, now);
}

// One SYNC cycle: each node's next queued image goes out, then the SYNC that applies them all.
void Uc57Stack::run_sync_cycle(TimePoint now) {
  const std::uint64_t applying_sync = master_.sync()->sent() + 1;
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    Node& node = *nodes_[n];
    if (node.phase != Node::Phase::kOperational || node.rpdo_queue.empty()) continue;
    send_image(n, node.rpdo_queue.front());
    node.rpdo_queue.pop_front();
    node.image_sync = applying_sync;
    node.preloaded = false;  // the queued image replaced the start image in the drive
  }
  masked_sync(now, [this, now] {
    if (stagger_g_ > 0) {
      master_.sync()->trigger_now(now);
    } else {
      master_.sync()->process(now);
    }
  });
  run_sync_waiters();
  run_slot_waiters();
}

void Uc57Stack::masked_sync(TimePoint now, const std::function<void()>& sync) {
  now_ = now;
  std::vector<std::size_t> keep;
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    Node& node = *nodes_[n];
    if (!node.preloaded) continue;
    // The armed image (bit 4 = 0) replaces the start image for this SYNC (the drive applies the
    // last RPDO received before it).
    if (node.phase == Node::Phase::kOperational) send_image(n, node.image);
    node.preloaded = false;
    if (node.phase == Node::Phase::kOperational && node.task == TaskKind::kArmed) keep.push_back(n);
  }
  // Start images going back into drives after this SYNC: the loop sends the periodic SYNCs (each
  // masked like this one) until none waits; otherwise the kernel's job may send them.
  master_.sync()->hold_cyclic(!keep.empty(), now);
  sync();
  for (const std::size_t n : keep) send_preload(n);
}

void Uc57Stack::send_image(std::size_t n, const RpdoImage& image) {
  Node& node = *nodes_[n];
  node.image = image;
  const can::Frame frame = encode_rpdo1(node.settings.node, node.layout, image);
  if (!context_.send || !context_.send(frame)) {
    ++counters_.protocol_errors;
    return;
  }
  wire_sent_ += can::frame_duration(frame, bitrate_);
  node.rpdo_end = wire_sent_;
  node.last_rpdo = frame;
}

RpdoImage Uc57Stack::latest_image(std::size_t n) const {
  const Node& node = *nodes_[n];
  return node.rpdo_queue.empty() ? node.image : node.rpdo_queue.back();
}

void Uc57Stack::queue_image(std::size_t n, const RpdoImage& image) {
  Node& node = *nodes_[n];
  node.rpdo_queue.push_back(image);
  node.power.note_controlword_sent(image.controlword);
}

bool Uc57Stack::image_applied(std::size_t n) {
  // The SYNC that applied the image has gone, and one more: a TPDO now shows its effect whatever
  // order the drive uses between applying RPDOs and sampling TPDOs at one SYNC.
  // Staggered: the node's last sample answered a later SYNC than the image's (its next sample may
  // be G SYNCs away).
  const Node& node = *nodes_[n];
  if (!node.rpdo_queue.empty()) return false;
  return staggered(n) ? node.sample_sync > node.image_sync : master_.sync()->sent() > node.image_sync;
}

std::optional<State> Uc57Stack::drive_state(std::size_t n) const {
  const auto& sw = nodes_[n]->statusword;
  return sw ? cia402::decode_state(*sw) : std::nullopt;
}

void Uc57Stack::on_pdo(std::size_t n, const can::Frame& frame, TimePoint now) {
  Node& node = *nodes_[n];
  if (node.phase != Node::Phase::kOperational) return;  // late TPDOs of a node being (re)configured
  const auto info = canopen::classify_cob_id(frame.id);
  if (info->pdo_number == 1) {
    const auto tpdo = decode_tpdo1(frame.payload());
    if (!tpdo) {
      ++counters_.protocol_errors;
      return;
    }
    if (node.settings.tpdo_mode != TpdoMode::kEvent && node.tpdo2_active) {
      // Both TPDOs sample one SYNC instant: the statusword waits for its position (TPDO2, next on
      // the bus; staggered: at the next SYNC), or a "homed" / "stopped" would go out next to an
      // older position.
      if (node.held_tpdo1) take_tpdo1(n, *std::exchange(node.held_tpdo1, std::nullopt), now, node.held_sample);
      node.held_tpdo1 = *tpdo;
      node.held_sample = sync_index();
      return;
    }
    // TPDO2 (position) publishes every sample; TPDO1 only when what it reports changed, so a
    // state change shows at once also with event-driven TPDOs, where TPDO2 may stay silent.
    node.status.sample_utime = frame.timestamp_us;
    if (take_tpdo1(n, *tpdo, now, sync_index()) || !node.tpdo2_active) publish_status(n);
  } else if (info->pdo_number == 2 && node.tpdo2_active) {
    const auto tpdo = decode_tpdo2(frame.payload());
    if (!tpdo) {
      ++counters_.protocol_errors;
      return;
    }
    node.status.position_counts = tpdo->position;
    node.status.position_read = true;
    node.status.velocity_counts = cia402::uc57::rpm_to_pulses_per_second(tpdo->velocity_rpm, node.pulses_per_rev);
    node.status.sample_utime = frame.timestamp_us;
    // The task sees the statusword with this position (a DONE is followed by the state it reached).
    if (node.held_tpdo1) take_tpdo1(n, *std::exchange(node.held_tpdo1, std::nullopt), now, node.held_sample);
    publish_status(n);
  }
}

bool Uc57Stack::take_tpdo1(std::size_t n, const Tpdo1& tpdo, TimePoint now, std::uint64_t sample) {
  Node& node = *nodes_[n];
  node.sample_sync = sample;
  const std::int32_t inputs = inputs_from_60fd(tpdo.digital_inputs);
  const bool changed = node.statusword != tpdo.statusword || node.status.inputs != inputs;
  node.statusword = tpdo.statusword;
  node.mode_display = tpdo.mode_display;
  node.status.inputs = inputs;
  on_statusword(n, now);
  return changed;
}

void Uc57Stack::publish_status(std::size_t n) {
  Node& node = *nodes_[n];
  if (context_.out == nullptr || node.settings.axis.empty()) return;
  if (node.statusword) {
    const std::uint16_t sw = *node.statusword;
    const auto state = cia402::decode_state(sw);
    node.status.enabled = state == State::kOperationEnabled;
    node.status.moving = cia402::is_set(sw, StatusBit::kMotorRunning);
    node.status.in_position = cia402::is_set(sw, StatusBit::kInPosition);
    node.status.homed = cia402::is_set(sw, StatusBit::kHomingDone);
    node.status.fault = is_fault_state(state) || cia402::is_set(sw, StatusBit::kAlarm);
  }
  node.status.target_counts = node.image.target_position;
  context_.out->axis_status(node.settings.axis, node.status);
}

// Every statusword: faults first, then whatever the running task waits for.
void Uc57Stack::on_statusword(std::size_t n, TimePoint now) {
  Node& node = *nodes_[n];
  const std::uint16_t sw = *node.statusword;
  const auto state = cia402::decode_state(sw);
  const bool fault = is_fault_state(state) || cia402::is_set(sw, StatusBit::kAlarm);
  if (fault && !node.fault_seen) {
    node.fault_seen = true;
    const std::string text = node.settings.label() + ": drive fault (statusword " + hex(sw, 4) + ", " +
                             (state ? std::string(cia402::to_string(*state)) : "unknown state") + ")";
    if (node.status.fault_text.empty()) node.status.fault_text = text;
    event(n, Event::ALARM, Event::ERROR, sw, text);
    if (!(node.task == TaskKind::kPower && node.power.target() == State::kSwitchOnDisabled))
      end_task(n, error_code(ReplyError::kAxisFaulted), text);
    // 603Fh names the alarm (manual §5.2 bit field).
    sdo_read(n, {od::kFaultBits, 0}, [this, n](std::error_code ec, std::span<const std::uint8_t> data) {
      if (ec) return;
      Node& nd = *nodes_[n];
      const auto bits = static_cast<std::uint16_t>(read_unsigned(data));
      nd.status.fault_code = bits;
      nd.status.fault_text =
          nd.settings.label() + ": alarm " + fault_bits_text(bits) + " (603Fh = " + hex(bits, 4) + ")";
      event(n, Event::ALARM, Event::ERROR, bits, nd.status.fault_text);
      publish_status(n);
    });
  } else if (!fault && node.fault_seen) {
    node.fault_seen = false;
    node.status.fault_code = 0;
    node.status.fault_text.clear();
  }

  const bool acknowledged = cia402::is_set(sw, StatusBit::kSetPointAcknowledge);
  switch (node.task) {
    case TaskKind::kPower: apply_power_action(n, node.power.on_statusword(sw, now)); break;
    case TaskKind::kQuickStop:
      if (image_applied(n) && state != State::kOperationEnabled) part_done(node.task_command, n);
      break;
    case TaskKind::kHalt:
      if (image_applied(n) && !cia402::is_set(sw, StatusBit::kMotorRunning)) part_done(node.task_command, n);
      break;
    case TaskKind::kArming:
      if (node.task_watching && image_applied(n) && !acknowledged && node.mode_display == kModeProfilePosition) {
        part_armed(node.task_command, n, now);
      }
      break;
    case TaskKind::kTriggered:
      if (acknowledged) {
        // Set-point taken: clear bit 4 so the next set-point can have its edge (manual §7 step 8).
        RpdoImage image = latest_image(n);
        image.controlword = cia402::profile_position_controlword({}, false, false);
        queue_image(n, image);
        node.task = TaskKind::kReleasing;
        node.task_deadline = now + options_.set_point_timeout + 2 * cycle();
      }
      break;
    case TaskKind::kReleasing:
    case TaskKind::kMoving:
      if (!image_applied(n) || acknowledged) break;
      node.task = TaskKind::kMoving;
      node.task_deadline = kNever;  // a move's duration is the coordinator's to supervise
      if (cia402::is_set(sw, StatusBit::kTargetReached) || cia402::is_set(sw, StatusBit::kInPosition)) {
        part_done(node.task_command, n);
      }
      break;
    case TaskKind::kJog:
      if (node.task_watching && image_applied(n) && node.mode_display == kModeProfileVelocity)
        part_done(node.task_command, n);
      break;
    case TaskKind::kHoming:
      if (!node.task_watching || !image_applied(n)) break;
      switch (cia402::uc57::homing_result(sw)) {
        case cia402::uc57::HomingResult::kInProgress: break;
        case cia402::uc57::HomingResult::kSucceeded: {
          RpdoImage image = latest_image(n);
          image.controlword = cia402::with(image.controlword, ControlBit::kNewSetPoint, false);
          queue_image(n, image);
          part_done(node.task_command, n);
          break;
        }
        case cia402::uc57::HomingResult::kStoppedWithoutHome:
          part_failed(node.task_command, n, error_code(ReplyError::kDriveError),
                      node.settings.label() + ": homing stopped without finding home (statusword " + hex(sw, 4) + ")");
          break;
      }
      break;
    case TaskKind::kNone:
    case TaskKind::kSdoOnly:
    case TaskKind::kArmed: break;
  }
}

}  // namespace motion::uc57_driver
