// Uc57Stack (uc57_stack.hpp): start-up of each node (probe, configuration, start), reboots,
// heartbeats and EMCY, and the stack's SDO helpers.
#include "uc57_stack_impl.hpp"

#include <array>

#include "motion/can_frame/bit_timing.hpp"

namespace motion::uc57_driver {

// ---------------------------------------------------------------------------------------------
// Start-up: probe, configure, start
// ---------------------------------------------------------------------------------------------

void Uc57Stack::start(TimePoint now) {
  now_ = now;
  started_ = true;
  set_configuration_window();
  warn_bus(poll_warning_);
  next_sync_at_ = stagger_g_ > 0 ? now + sync_period_ : kNever;
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    Node& node = *nodes_[n];
    for (const auto& warning : node.settings.warnings) {
      event(n, Event::CONFIG_MISMATCH, Event::WARNING, 0, node.settings.label() + ": " + warning);
    }
    if (!node.settings.errors.empty()) {
      std::string text;
      for (const auto& error : node.settings.errors) text += (text.empty() ? "" : "; ") + error;
      node.phase = Node::Phase::kConfigError;
      node.offline_reason = text;
      event(n, Event::CONFIG_MISMATCH, Event::ERROR, 0, node.settings.label() + ": cannot be set up: " + text);
      continue;
    }
    begin_probe(n, now);
  }
  // SYNC is harmless in pre-operational and doubles as the cycle of the RPDO queue.
  master_.sync()->start(now);
}

// A node's configuration is a chain of SDO exchanges, one at a time. Configuring every node at
// once puts one exchange per node on the bus together: with 127 nodes the last answers of each
// round came after the 50 ms SDO timeout behind a loaded host (lab bench), and a remap step that
// times out resets the node (boot-up, a heartbeat gap, its configuration again), which fed the
// burst. So at most as many nodes are configured at once as their exchanges (request + response,
// 8 data bytes each) fill an eighth of the shortest SDO timeout on the wire, at least one: 25 at
// 1 Mbit/s and 50 ms, 3 at 125 kbit/s.
void Uc57Stack::set_configuration_window() {
  Duration timeout = std::chrono::hours(1);
  for (const auto& node : nodes_) timeout = std::min(timeout, node->settings.sdo_timeout);
  const std::array<std::uint8_t, 8> data{};
  const auto sdo = can::Frame::make(canopen::sdo_request_cob_id(1), false, data);
  const Duration exchange = sdo ? 2 * can::frame_duration(*sdo, bitrate_) : timeout;
  configuration_window_ = std::max<std::size_t>(1, static_cast<std::size_t>((timeout / 8) / exchange));
}

std::size_t Uc57Stack::configuring() const {
  return static_cast<std::size_t>(std::count_if(
      nodes_.begin(), nodes_.end(), [](const auto& node) { return node->phase == Node::Phase::kConfiguring; }));
}

void Uc57Stack::begin_probe(std::size_t n, TimePoint /*now*/) {
  Node& node = *nodes_[n];
  const bool self = node.phase == Node::Phase::kConfiguring;
  if (configuring() - (self ? 1 : 0) >= configuration_window_) {
    ++node.session;  // a configuration under way stops
    master_.sdo().cancel(node.settings.node);
    node.phase = Node::Phase::kOffline;
    node.retry_at = kNever;
    node.awaiting_slot = true;  // process() starts it when the window has room
    return;
  }
  probe_now(n);
}

void Uc57Stack::probe_now(std::size_t n) {
  Node& node = *nodes_[n];
  node.awaiting_slot = false;
  node.retry_at = kNever;
  node.phase = Node::Phase::kConfiguring;
  ++node.session;
  master_.sdo().cancel(node.settings.node);
  node.rpdo_queue.clear();
  node.held_tpdo1.reset();
  node.slot = {};  // pre-operational from step 2: its TPDOs stop until started in their slots
  node.slot_candidate = {};
  release_sync(n);
  auto ops = std::make_shared<std::vector<ConfigOp>>(configuration_ops(n));
  run_config(n, node.session, ops, 0);
}

void Uc57Stack::run_config(std::size_t n, unsigned session, const std::shared_ptr<std::vector<ConfigOp>>& ops,
                           std::size_t step) {
  if (nodes_[n]->session != session || nodes_[n]->phase != Node::Phase::kConfiguring) return;
  if (step == ops->size()) {
    enter_starting(n);
    return;
  }
  const auto run = (*ops)[step].run;
  run([this, n, session, ops, step](std::optional<std::string> failure) {
    if (nodes_[n]->session != session) return;
    if (failure) {
      configuration_failed(n, *failure, true);
      return;
    }
    run_config(n, session, ops, step + 1);
  });
}

std::vector<Uc57Stack::ConfigOp> Uc57Stack::configuration_ops(std::size_t n) {
  Node& node = *nodes_[n];
  const NodeSettings& s = node.settings;
  std::vector<ConfigOp> ops;

  const auto read = [this, n](ObjectAddress object,
                              const std::function<std::optional<std::string>(std::span<const std::uint8_t>)>& use) {
    return ConfigOp{[this, n, object, use](const Continue& next) {
      sdo_read(n, object, [this, n, object, use, next](std::error_code ec, std::span<const std::uint8_t> data) {
        if (ec) return next(sdo_failure(n, false, object, ec));
        next(use(data));
      });
    }};
  };
  const auto write = [this, n](ObjectAddress object, const std::vector<std::uint8_t>& data) {
    return ConfigOp{[this, n, object, data](const Continue& next) {
      sdo_write(n, object, data, [this, n, object, next](std::error_code ec, std::span<const std::uint8_t>) {
        next(ec ? std::optional{sdo_failure(n, true, object, ec)} : std::nullopt);
      });
    }};
  };
  const auto expect = [label = s.label()](ObjectAddress object, std::uint64_t wanted) {
    return [label, object, wanted](std::span<const std::uint8_t> data) -> std::optional<std::string> {
      if (read_unsigned(data) == wanted) return std::nullopt;
      return label + ": " + object_text(object) + " reads back " + std::to_string(read_unsigned(data)) + ", " +
             std::to_string(wanted) + " was written";
    };
  };

  // 1. Identify: a CiA 402 device (1000h low word 402), from ADAMPOWER (1018h:01; warning only).
  ops.push_back(read({od::kDeviceType, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    const auto type = static_cast<std::uint32_t>(read_unsigned(data));
    if ((type & 0xFFFF) == kCia402Profile) return std::nullopt;
    const std::string text = nodes_[n]->settings.label() + ": device type (1000h) " + hex(type, 8) +
                             " is not a CiA 402 drive (UC57: 0x00040192)";
    event(n, Event::CONFIG_MISMATCH, Event::ERROR, static_cast<std::int32_t>(type), text);
    return text;
  }));
  ops.push_back(read({0x1018, 1}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    const auto vendor = static_cast<std::uint32_t>(read_unsigned(data));
    if (vendor != kAdampowerVendorId) {
      event(n, Event::CONFIG_MISMATCH, Event::WARNING, static_cast<std::int32_t>(vendor),
            nodes_[n]->settings.label() + ": vendor ID (1018h:01) " + hex(vendor, 8) + ", not ADAMPOWER's 0x00000322");
    }
    return std::nullopt;
  }));
  // 2. Pre-operational: PDOs stop while their parameters change (CiA 301 remap procedure).
  ops.push_back({[this, n](const Continue& next) {
    master_.nmt().send(canopen::NmtCommand::kEnterPreOperational, nodes_[n]->settings.node);
    next(std::nullopt);
  }});
  // 3. Setup keys, written and read back (RW/S objects, not saved to EEPROM: 200Ch default 1).
  if (s.subdivision_code) { ops.push_back(write({od::kMicrostepping, 0}, le<std::uint16_t>(*s.subdivision_code))); }
  ops.push_back(read(
      {od::kMicrostepping, 0},
      [this, n, expect, code = s.subdivision_code](std::span<const std::uint8_t> data) -> std::optional<std::string> {
        if (code) {
          if (auto mismatch = expect({od::kMicrostepping, 0}, *code)(data)) return mismatch;
        }
        const auto ppr = cia402::uc57::pulses_per_revolution(static_cast<std::uint16_t>(read_unsigned(data)));
        if (!ppr)
          return nodes_[n]->settings.label() + ": 2006h holds an unknown subdivision code " +
                 std::to_string(read_unsigned(data));
        nodes_[n]->pulses_per_rev = *ppr;
        return std::nullopt;
      }));
  if (s.run_current) {
    ops.push_back(write({od::kRunCurrent, 0}, le<std::uint16_t>(*s.run_current)));
    ops.push_back(read({od::kRunCurrent, 0}, expect({od::kRunCurrent, 0}, *s.run_current)));
  }
  ops.push_back(read({od::kStartSpeed, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    Node& nd = *nodes_[n];
    nd.start_speed =
        cia402::uc57::rpm_to_pulses_per_second(static_cast<double>(read_unsigned(data)), nd.pulses_per_rev);
    return std::nullopt;
  }));
  // 4. Error control: heartbeat (the UC57 has no node guarding objects).
  ops.push_back(write({od::kProducerHeartbeatTime, 0}, le<std::uint16_t>(s.heartbeat_ms)));
  ops.push_back(read({od::kEmcyCobId, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    const auto cob = static_cast<std::uint32_t>(read_unsigned(data)) & 0x7FF;
    // The manual prints the default as "0x80" (C-11): a drive really using 080h would share SYNC's id.
    if (cob != canopen::emcy_cob_id(nodes_[n]->settings.node) && cob != canopen::kSyncCobId) {
      master_.emcy().set_cob_id(nodes_[n]->settings.node, cob);
      relocated_emcy_ids_.insert(cob);
    }
    return std::nullopt;
  }));
  // 5. RPDO1: remap to controlword + target (synchronous); fall back to the manual's default.
  ops.push_back({[this, n](const Continue& next) {
    Node& nd = *nodes_[n];
    if (nd.remap_refused) {
      nd.layout = RpdoLayout::kManualDefault;
      return next(std::nullopt);
    }
    const unsigned session = nd.session;
    const auto remap =
        rpdo1_remap(nd.settings.node, nd.sync_refused ? kTransmissionEventDriven : kTransmissionSyncEveryCycle);
    const auto steps = canopen::pdo_remap_steps(remap);
    canopen::configure_pdo(
        master_.sdo(), nd.settings.node, remap,
        [this, n, session, next, steps](const canopen::SdoSequenceResult& result) {
          Node& remapped = *nodes_[n];
          if (remapped.session != session) return;
          if (!result.error) {
            remapped.layout = RpdoLayout::kControlwordTarget;
            return next(std::nullopt);
          }
          count_sdo_result(result.error);
          // Only an abort is the drive's answer. Without one (a timeout, a late reply
          // to an earlier request) the step may have been applied, the first one
          // too (1400h:01 invalid: RPDO1 off): reset, configure again, try the remap again.
          const bool refused =
              result.error.category() == canopen::sdo_category() && result.error != canopen::SdoAbortCode::kTimeout;
          if (!refused) {
            master_.nmt().send(canopen::NmtCommand::kResetNode, remapped.settings.node);
            return next(remapped.settings.label() + ": RPDO1 remap step " + std::to_string(result.failed_step + 1) +
                        " got no usable answer (" + result.error.message() +
                        "); node reset to restore its stored PDO mapping");
          }
          const bool type_refused =
              steps && result.failed_step < steps->size() &&
              (*steps)[result.failed_step].object ==
                  ObjectAddress{canopen::pdo_communication_index(canopen::PdoDirection::kReceive, 1),
                                canopen::kPdoTransmissionTypeSub};
          if (type_refused && !remapped.sync_refused) {
            // Transmission type 1 refused (the manual's §5 table gives only FFh): RPDO1 becomes
            // asynchronous (remembered). The PDO is still disabled: the remap again from its
            // first step, with 255.
            remapped.sync_refused = true;
            event(n, Event::CONFIG_MISMATCH, Event::WARNING, result.error.value(),
                  remapped.settings.label() + ": RPDO1 transmission type 1 (synchronous) refused (" +
                      result.error.message() + "); RPDO1 asynchronous (255), moves start node by node");
            return canopen::configure_pdo(
                master_.sdo(), remapped.settings.node, rpdo1_remap(remapped.settings.node, kTransmissionEventDriven),
                [this, n, session, next](const canopen::SdoSequenceResult& again) {
                  Node& async = *nodes_[n];
                  if (async.session != session) return;
                  if (!again.error) {
                    async.layout = RpdoLayout::kControlwordTarget;
                    return next(std::nullopt);
                  }
                  count_sdo_result(again.error);
                  master_.nmt().send(canopen::NmtCommand::kResetNode, async.settings.node);
                  next(async.settings.label() + ": RPDO1 remap with transmission type 255 failed at step " +
                       std::to_string(again.failed_step + 1) + " (" + again.error.message() +
                       "); node reset to restore its stored PDO mapping");
                });
          }
          remapped.remap_refused = true;
          remapped.layout = RpdoLayout::kManualDefault;
          const std::string why = remapped.settings.label() + ": RPDO1 remap refused at step " +
                                  std::to_string(result.failed_step + 1) + " (" + result.error.message() + ")";
          if (result.failed_step == 0) {
            // Nothing changed in the drive: go on with its default mapping.
            event(n, Event::CONFIG_MISMATCH, Event::INFO, 0, why + "; using the manual's default RPDO1");
            return next(std::nullopt);
          }
          // Half-applied: a node reset restores the stored mapping; configure again.
          master_.nmt().send(canopen::NmtCommand::kResetNode, remapped.settings.node);
          next(why + "; node reset to restore its stored PDO mapping");
        });
  }});
  ops.push_back({[this, n, write](Continue next) {
    if (nodes_[n]->layout != RpdoLayout::kManualDefault) return next(std::nullopt);
    const ObjectAddress type{canopen::pdo_communication_index(canopen::PdoDirection::kReceive, 1),
                             canopen::kPdoTransmissionTypeSub};
    if (nodes_[n]->sync_refused) return write(type, le<std::uint8_t>(kTransmissionEventDriven)).run(std::move(next));
    sdo_write(n, type, le<std::uint8_t>(kTransmissionSyncEveryCycle),
              [this, n, type, write, next](std::error_code ec, std::span<const std::uint8_t>) {
                if (!ec) return next(std::nullopt);
                if (ec.category() != canopen::sdo_category() || ec == canopen::SdoAbortCode::kTimeout)
                  return next(sdo_failure(n, true, type, ec));
                // Refused: asynchronous RPDO1, the manual's default FFh (§5 comm. table); moves start node by node.
                nodes_[n]->sync_refused = true;
                event(n, Event::CONFIG_MISMATCH, Event::WARNING, ec.value(),
                      sdo_failure(n, true, type, ec) +
                          " for transmission type 1; RPDO1 asynchronous (255), moves start node by node");
                write(type, le<std::uint8_t>(kTransmissionEventDriven)).run(next);
              });
  }});
  // 6. TPDO1 / TPDO2 transmission type (1800h/1801h:02, RW/S) and whether TPDO2 is mapped (C-09).
  ops.push_back(tpdo_type_op(n));  // staggered: type G (uc57_stack_stagger.cpp)
  ops.push_back(read({canopen::pdo_mapping_index(canopen::PdoDirection::kTransmit, 2), 0},
                     [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
                       Node& nd = *nodes_[n];
                       nd.tpdo2_active = read_unsigned(data) == tpdo2_mapping().size();
                       if (!nd.tpdo2_active) {
                         event(
                             n, Event::CONFIG_MISMATCH, Event::WARNING, 0,
                             nd.settings.label() + ": TPDO2 (1A01h) is not mapped; position is polled by SDO (6064h)");
                       }
                       return std::nullopt;
                     }));
  // 7. The drive's current process image, so the first RPDO changes nothing by accident.
  ops.push_back(
      read({od::kControlword, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
        nodes_[n]->image.controlword = static_cast<std::uint16_t>(read_unsigned(data));
        nodes_[n]->power.note_controlword_sent(nodes_[n]->image.controlword);
        return std::nullopt;
      }));
  ops.push_back(
      read({od::kModesOfOperation, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
        nodes_[n]->image.mode = static_cast<std::int8_t>(read_signed(data));
        return std::nullopt;
      }));
  ops.push_back(
      read({od::kTargetVelocity, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
        nodes_[n]->image.target_velocity = static_cast<std::int32_t>(read_signed(data));
        return std::nullopt;
      }));
  ops.push_back(
      read({od::kTargetPosition, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
        nodes_[n]->image.target_position = static_cast<std::int32_t>(read_signed(data));
        return std::nullopt;
      }));
  ops.push_back(
      read({od::kPositionActual, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
        nodes_[n]->status.position_counts = read_signed(data);
        nodes_[n]->status.position_read = true;
        return std::nullopt;
      }));
  ops.push_back(read({od::kStatusword, 0}, [this, n](std::span<const std::uint8_t> data) -> std::optional<std::string> {
    nodes_[n]->statusword = static_cast<std::uint16_t>(read_unsigned(data));
    return std::nullopt;
  }));
  // 8. Operational (staggered: in the node's slot, uc57_stack_stagger.cpp).
  ops.push_back(nmt_start_op(n));
  // 9. Does RPDO1 apply at the SYNC, on reception, or was type 1 refused (uc57_stack_rpdo.cpp)?
  ops.push_back(rpdo_acceptance_op(n));
  return ops;
}

void Uc57Stack::enter_starting(std::size_t n) {
  Node& node = *nodes_[n];
  if (node.settings.heartbeat_ms == 0) {
    enter_operational(n);
    return;
  }
  // The next heartbeat must say Operational (on_node_event); give it a few producer periods.
  node.phase = Node::Phase::kStarting;
  node.starting_deadline =
      now_ + std::chrono::milliseconds(node.settings.heartbeat_ms) * options_.heartbeat_loss_factor;
  if (master_.nmt().state(node.settings.node) == canopen::NmtState::kOperational) enter_operational(n);
}

void Uc57Stack::enter_operational(std::size_t n) {
  Node& node = *nodes_[n];
  node.phase = Node::Phase::kOperational;
  node.ever_operational = true;
  node.starting_deadline = kNever;
  node.backoff = Duration{};
  node.offline_reported = false;
  node.fault_seen = false;
  node.status.online = true;
  node.next_position_poll = node.tpdo2_active ? kNever : TimePoint{};
  event(
      n, Event::ONLINE, Event::INFO, node.settings.node,
      node.settings.label() + ": configured and operational (RPDO1 " +
          (node.layout == RpdoLayout::kControlwordTarget ? "controlword + target position" : "manual default mapping") +
          ", " + node.rpdo_finding + "; TPDOs " + tpdo_text(n) + ")");
  // What was read at set-up (2006h, 200Eh; manual §5.1) makes the axis's drive model.
  report_facts(n);
  publish_status(n);
}

void Uc57Stack::configuration_failed(std::size_t n, const std::string& reason, bool retry) {
  Node& node = *nodes_[n];
  master_.sdo().cancel(node.settings.node);
  node.phase = retry ? Node::Phase::kOffline : Node::Phase::kConfigError;
  node.starting_deadline = kNever;
  node.offline_reason = reason;
  node.status.online = false;
  node.backoff = node.backoff == Duration{} ? options_.retry_initial : std::min(node.backoff * 2, options_.retry_max);
  node.retry_at = now_ + node.backoff;
  if (!node.offline_reported) {
    node.offline_reported = true;
    event(n, Event::OFFLINE, Event::ERROR, node.settings.node, reason + " (retrying with back-off)");
    publish_status(n);
  }
}

void Uc57Stack::go_offline(std::size_t n, std::int16_t event_kind, const std::string& reason, TimePoint now) {
  Node& node = *nodes_[n];
  end_task(n, error_code(ReplyError::kAxisOffline), reason);
  master_.sdo().cancel(node.settings.node);
  ++node.session;
  node.phase = Node::Phase::kOffline;
  node.starting_deadline = kNever;
  node.rpdo_queue.clear();
  node.held_tpdo1.reset();
  node.slot = {};
  release_sync(n);
  node.statusword.reset();
  node.status.online = false;
  node.offline_reason = reason;
  node.offline_reported = true;
  node.backoff = options_.retry_initial;
  node.retry_at = now + node.backoff;
  event(n, event_kind, Event::ERROR, node.settings.node, reason);
  publish_status(n);
}

void Uc57Stack::on_node_event(const canopen::NodeEvent& e) {
  const auto it = node_index_.find(e.node);
  if (it == node_index_.end()) return;
  const std::size_t n = it->second;
  Node& node = *nodes_[n];
  const std::string label = node.settings.label();
  switch (e.kind) {
    case canopen::NodeEventKind::kBootUp:
    case canopen::NodeEventKind::kRebooted:
      if (node.phase == Node::Phase::kConfigError) return;
      // The boot-up message (CiA 301 §7.2.8.3.2; UC57 manual §4.1.2) ends a power-up or an NMT
      // reset: the position actual value (6064h) starts again from 0, whatever the machine's
      // position is. Whether the node went silent first (heartbeat lost) or not, once it had been
      // operational its position is lost.
      if (node.ever_operational && context_.out != nullptr && !node.settings.axis.empty()) {
        context_.out->position_lost(
            node.settings.axis,
            label + " powered up or was reset, detected by its boot-up message (UC57 manual §4.1.2)");
      }
      if (node.phase == Node::Phase::kOperational || node.phase == Node::Phase::kStarting) {
        // It lost its PDO configuration and its CiA 402 state: everything starts again.
        go_offline(n, Event::REBOOT, label + ": rebooted (boot-up message); configuring it again", e.at);
      }
      if (started_) begin_probe(n, e.at);
      return;
    case canopen::NodeEventKind::kHeartbeatLost:
      if (node.phase == Node::Phase::kOperational || node.phase == Node::Phase::kStarting) {
        go_offline(
            n, Event::HEARTBEAT_LOST,
            label + ": heartbeat lost (none for " +
                std::to_string(std::chrono::ceil<std::chrono::milliseconds>(heartbeat_consumer_time(node)).count()) +
                " ms)",
            e.at);
      }
      return;
    case canopen::NodeEventKind::kHeartbeatRecovered:
    case canopen::NodeEventKind::kStateChanged:
      if (node.phase == Node::Phase::kStarting && e.state == canopen::NmtState::kOperational) {
        enter_operational(n);
      } else if (node.phase == Node::Phase::kOperational && e.state && e.state != canopen::NmtState::kOperational) {
        // Someone else's NMT command (or a node-side error): PDOs stopped; put it back.
        event(n, Event::PROTOCOL_ERROR, Event::WARNING, static_cast<std::int32_t>(*e.state),
              label + ": left Operational (NMT state " + std::string(canopen::to_string(*e.state)) +
                  "); sending NMT start" + (staggered(n) ? " in its TPDO slots" : ""));
        if (!staggered(n)) {
          master_.nmt().send(canopen::NmtCommand::kStart, node.settings.node);
        } else {
          const unsigned session = node.session;
          start_in_slots(
              n, [this, n, session] { return nodes_[n]->session == session; },
              [this, n](const std::optional<std::string>& failure) {
                if (failure) event(n, Event::PROTOCOL_ERROR, Event::WARNING, 0, *failure);
              });
        }
      } else if (node.phase == Node::Phase::kOffline && e.kind == canopen::NodeEventKind::kHeartbeatRecovered) {
        begin_probe(n, e.at);
      }
      return;
  }
}

void Uc57Stack::on_emcy(const canopen::EmcyEvent& e) {
  const auto it = node_index_.find(e.node);
  if (it == node_index_.end()) return;
  ++counters_.emcy;
  const std::size_t n = it->second;
  Node& node = *nodes_[n];
  const std::uint16_t code = e.emergency.error_code;
  if (e.is_reset()) {
    event(n, Event::EMCY, Event::INFO, 0, node.settings.label() + ": EMCY error reset (no error)");
    return;
  }
  std::string manufacturer;
  for (const auto byte : e.emergency.manufacturer) manufacturer += " " + hex(byte, 2).substr(2);
  const std::string text = node.settings.label() + ": EMCY " + hex(code, 4) + " (" +
                           std::string(canopen::to_string(e.error_class)) + "), error register " +
                           hex(e.emergency.error_register, 2) + ", manufacturer bytes" + manufacturer;
  node.status.fault_code = code;
  node.status.fault_text = text;
  event(n, Event::EMCY, Event::ERROR, code, text);
  end_task(n, error_code(ReplyError::kAxisFaulted), text);
  publish_status(n);
}

// ---------------------------------------------------------------------------------------------
// SDO
// ---------------------------------------------------------------------------------------------

void Uc57Stack::count_sdo_result(std::error_code error) {
  if (!error || error.category() != canopen::sdo_category()) return;
  if (error == canopen::SdoAbortCode::kTimeout) {
    ++counters_.sdo_timeouts;
  } else {
    ++counters_.sdo_aborts;
  }
}

Duration Uc57Stack::sdo_timeout(const Node& node) const { return node.settings.sdo_timeout + sdo_allowance_; }

std::string Uc57Stack::sdo_failure(std::size_t n, bool write, ObjectAddress object, std::error_code error) const {
  const NodeSettings& s = nodes_[n]->settings;
  std::string text = s.label() + ": SDO " + (write ? "write " : "read ") + object_text(object);
  if (error == canopen::SdoAbortCode::kTimeout) {
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(sdo_timeout(*nodes_[n])).count();
    return text + " timed out (no answer within " + std::to_string(ms) + " ms, " + std::to_string(s.sdo_retries + 1) +
           " attempts)";
  }
  if (error.category() == canopen::sdo_category()) {
    const auto code = static_cast<std::uint32_t>(error.value());
    std::string why(canopen::description(static_cast<canopen::SdoAbortCode>(code)));
    if (why.empty()) why = "manufacturer-specific abort";
    why[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(why[0])));
    return text + " aborted: " + why + " (" + hex(code, 8) + ")";
  }
  return text + " failed: " + error.message();
}

void Uc57Stack::sdo_read(std::size_t n, ObjectAddress object, SdoDone done, unsigned attempt) {
  const unsigned session = nodes_[n]->session;
  master_.sdo().upload(nodes_[n]->settings.node, object,
                       [this, n, object, done = std::move(done), attempt, session](std::error_code ec,
                                                                                   std::span<const std::uint8_t> data) {
                         if (ec == canopen::SdoAbortCode::kTimeout && attempt < nodes_[n]->settings.sdo_retries &&
                             nodes_[n]->session == session) {
                           ++counters_.sdo_retries;
                           sdo_read(n, object, done, attempt + 1);
                           return;
                         }
                         count_sdo_result(ec);
                         done(ec, data);
                       });
}

void Uc57Stack::sdo_write(std::size_t n, ObjectAddress object, const std::vector<std::uint8_t>& data, SdoDone done,
                          unsigned attempt) {
  const unsigned session = nodes_[n]->session;
  master_.sdo().download(nodes_[n]->settings.node, object, data,
                         [this, n, object, data, done = std::move(done), attempt, session](
                             std::error_code ec, std::span<const std::uint8_t> reply) {
                           if (ec == canopen::SdoAbortCode::kTimeout && attempt < nodes_[n]->settings.sdo_retries &&
                               nodes_[n]->session == session) {
                             ++counters_.sdo_retries;
                             sdo_write(n, object, data, done, attempt + 1);
                             return;
                           }
                           count_sdo_result(ec);
                           done(ec, reply);
                         });
}

void Uc57Stack::sdo_write_all(std::size_t n, std::vector<std::pair<ObjectAddress, std::vector<std::uint8_t>>> writes,
                              Continue done) {
  if (writes.empty()) return done(std::nullopt);
  auto first = writes.front();
  writes.erase(writes.begin());
  sdo_write(n, first.first, first.second,
            [this, n, object = first.first, rest = std::move(writes), done = std::move(done)](
                std::error_code ec, std::span<const std::uint8_t>) mutable {
              if (ec) return done(sdo_failure(n, true, object, ec));
              sdo_write_all(n, std::move(rest), std::move(done));
            });
}

}  // namespace motion::uc57_driver
