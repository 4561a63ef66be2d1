// Uc57Stack (uc57_stack.hpp): the bus budget of synchronous TPDOs, and staggered TPDOs
// (tpdo_mode staggered).
//
// With transmission type 1 every node answers every SYNC with TPDO1 and TPDO2 at once; an SDO
// request (600h + node) or RPDO loses arbitration to the whole burst. CiA 301 §7.5.2.35 gives
// types 1..240 as "synchronous, sent after every n-th SYNC" (the UC57 manual §5 comm. table lists
// 1800h/1801h:02 "Transmission" as RW/S; it has no 1019h SYNC counter and no 1800h:06 SYNC start
// value, so a node's phase cannot be chosen through the SYNC counter). So a staggered node gets
// type G for both TPDOs, and each TPDO a slot of its own in the cycle of G SYNCs: with S
// staggered nodes G = 2S (TPDO1 in slot 2i, TPDO2 in slot 2i + 1) while 2S <= 240, else G = S
// with both TPDOs of a node in its one slot (two frames answer each SYNC). Every SYNC is then
// answered by one TPDO (two above 120 nodes).
//
// Phase. A node counts SYNCs from the moment its TPDO's count is armed: CiA 301 leaves it to the
// device; CANopenNode (and the simulated UC57) restart it when the node enters Operational and when
// the transmission type is written. So TPDO1 (type G, written in pre-operational) starts counting
// at the NMT start, sent right after the SYNC whose index is TPDO1's slot mod G; TPDO2 is left at
// 255 in pre-operational (nothing at SYNCs) and gets type G by SDO right after the SYNC of its
// slot, with no periodic SYNC until the drive has answered. Then the stack watches which SYNC each
// TPDO answers (the last SYNC echoed on the wire, or handed over where the transport gives no
// echo): a TPDO found in another slot is taken where it is (the slot followed from then on; a
// collision only makes that SYNC's answer longer), reported once. A drive that aborts type G at
// set-up gets type 1 (every SYNC) with a warning naming it; the bus's SYNC then keeps to the
// older budget (kPollBusShare) since that node answers every SYNC.
//
// Pacing. The SYNC is paced by the wire, as the UIM342 stack's polls are: the next one is handed
// over no sooner than sync_period_ after the last, only once the last one was echoed (where the
// transport echoes) and its answer(s) came in or had time to (their wire time, plus two frames).
// A command handed over meanwhile waits behind at most the one TPDO answering the SYNC on the
// wire, and goes ahead of the next SYNC (the transmit queue keeps our order). sync_period_ is
// 1 / poll_hz / G, no shorter than SYNC + its mean answer + heartbeats taking kStaggeredBusShare of
// the bus: asked for more than the bus carries, polls fill up to that share; else the asked rate.
#include "uc57_stack_impl.hpp"

#include "motion/can_frame/bit_timing.hpp"
#include "motion/canopen/nmt.hpp"
#include "motion/canopen/sync.hpp"

namespace motion::uc57_driver {
namespace {

constexpr unsigned kMaxSynchronousType = 240;  // CiA 301: 1..240 = every n-th SYNC
// Without an echo of a SYNC within this long, the pacing goes on as if it had come.
constexpr Duration kEchoWait = std::chrono::milliseconds(20);

double hz(Duration d) { return 1.0 / std::chrono::duration<double>(d).count(); }

ObjectAddress transmission_type(std::uint16_t tpdo) {
  return {canopen::pdo_communication_index(canopen::PdoDirection::kTransmit, tpdo), canopen::kPdoTransmissionTypeSub};
}

}  // namespace

bool Uc57Stack::staggered(std::size_t n) const {
  const Node& node = *nodes_[n];
  return stagger_g_ > 0 && node.stagger_index >= 0 && !node.stagger_refused;
}

std::array<std::optional<unsigned>, 2> Uc57Stack::tpdo_slots(std::string_view drive) const {
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    if (nodes_[n]->settings.drive == drive && staggered(n)) return nodes_[n]->slot;
  }
  return {};
}

bool Uc57Stack::stagger_refused(std::string_view drive) const {
  for (const auto& node : nodes_) {
    if (node->settings.drive == drive) return node->stagger_refused;
  }
  return false;
}

std::string Uc57Stack::tpdo_text(std::size_t n) const {
  const Node& node = *nodes_[n];
  if (node.settings.tpdo_mode == TpdoMode::kEvent) return "event-driven";
  if (!staggered(n))
    return node.stagger_refused ? "every SYNC (type " + std::to_string(stagger_g_) + " refused)" : "every SYNC";
  const auto slot = [](const std::optional<unsigned>& s) { return s ? std::to_string(*s) : std::string("?"); };
  return "every " + std::to_string(stagger_g_) + "th SYNC, slots " + slot(node.slot[0]) + " and " + slot(node.slot[1]) +
         " of " + std::to_string(stagger_g_);
}

void Uc57Stack::plan_stagger() {
  unsigned count = 0;
  for (const auto& node : nodes_) {
    if (node->settings.tpdo_mode == TpdoMode::kStaggered && node->settings.errors.empty())
      node->stagger_index = static_cast<int>(count++);
  }
  if (count == 0) return;
  stagger_separate_ = 2 * count <= kMaxSynchronousType;
  stagger_g_ = stagger_separate_ ? 2 * count : count;  // node IDs end at 127: G <= 240
}

void Uc57Stack::warn_bus(const std::string& text) {
  if (context_.out == nullptr || text.empty()) return;
  gateway::DriveEvent e;
  e.kind = Event::CONFIG_MISMATCH;
  e.severity = Event::WARNING;
  e.text = text;
  context_.out->axis_event("", e);
}

// Polling within a bus budget. Type 1: each SYNC makes every node with synchronous TPDOs send
// TPDO1 and TPDO2 (UC57 manual §5 comm. table, 1800h/1801h:02 = 1; CiA 301 §7.2.2). At the UC57's
// default 125 kbit/s (2009h = 2, manual §5.1) 32 nodes at 20 Hz ask for 1,300 frames/s, more than
// the bus carries. The SYNC, and with it the status rate, is slowed until the SYNC and those
// TPDOs, with the nodes' heartbeats (1017h, set up here), take at most kPollBusShare of the wire:
// the TPDOs answering one SYNC come from every node at once and outrank SDO requests by
// arbitration, so the idle time between bursts is kept for commands. Staggered: see the top of
// this file. Stuff bits are counted for all-zero data (the most a 0-filled payload gets), so a
// real cycle is at most a few bits shorter.
void Uc57Stack::fit_sync_period() {
  const Duration sync = can::frame_duration(canopen::encode_sync({}), bitrate_);
  Duration every{};   // answers to each SYNC (type 1)
  Duration spread{};  // the staggered nodes' TPDOs, spread over G SYNCs
  std::size_t every_nodes = 0;
  std::size_t staggered_nodes = 0;
  double heartbeat_share = 0;  // of the wire, per second
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    const Node& node = *nodes_[n];
    if (node.settings.heartbeat_ms > 0) {
      const auto beat = canopen::encode_heartbeat(node.settings.node, canopen::NmtState::kOperational);
      heartbeat_share += std::chrono::duration<double>(can::frame_duration(beat, bitrate_)).count() * 1000.0 /
                         node.settings.heartbeat_ms;
    }
    if (node.settings.tpdo_mode == TpdoMode::kEvent) continue;
    const Duration answers = can::frame_duration(encode_tpdo1(node.settings.node, {}), bitrate_) +
                             can::frame_duration(encode_tpdo2(node.settings.node, {}), bitrate_);
    if (staggered(n)) {
      spread += answers;
      ++staggered_nodes;
    } else {
      every += answers;
      ++every_nodes;
    }
  }
  const unsigned g = std::max(stagger_g_, 1U);
  const Duration cycle = sync + every + spread / g;
  // An SDO request (600h + node) and its answer (580h + node) each lose arbitration to every TPDO
  // answering a SYNC (180h/280h + node): each may wait behind one SYNC's answers. At 125 kbit/s,
  // 32 nodes of type 1 answer each SYNC with 64 ms of frames, more than a 50 ms timeout; without
  // this a node configured while the others poll timed out again and again.
  sdo_allowance_ = 2 * (sync + every + (stagger_g_ > 0 ? spread / g : Duration{}));
  const double budget = stagger_g_ > 0 && every_nodes == 0 ? kStaggeredBusShare : kPollBusShare;
  poll_cycle_ = cycle;
  heartbeat_share_ = heartbeat_share;
  const double share = std::max(budget - heartbeat_share, budget / 4);
  const auto needed = std::chrono::duration_cast<Duration>(
      std::chrono::duration<double, std::nano>(static_cast<double>(cycle.count()) / share));
  const Duration asked = asked_period_ / g;
  poll_share_ = share;
  budget_gap_ = stagger_g_ > 0 ? needed : std::chrono::ceil<std::chrono::milliseconds>(needed);
  sync_period_ = asked;
  poll_warning_.clear();
  if (needed <= asked) return;
  char text[400];
  if (stagger_g_ == 0) {
    sync_period_ = std::chrono::ceil<std::chrono::milliseconds>(needed);
    std::snprintf(text, sizeof text,
                  "bus %s: %zu UC57 nodes with synchronous TPDOs at %.1f Hz need %.0f%% of %u bit/s; SYNC (and status) "
                  "at %.1f Hz instead (polls and heartbeats keep to %.0f%% of the bus)",
                  bus_.c_str(), every_nodes, hz(asked),
                  100.0 * std::chrono::duration<double>(cycle).count() * hz(asked), bitrate_, hz(sync_period_),
                  100.0 * budget);
  } else {
    sync_period_ = std::chrono::ceil<std::chrono::microseconds>(needed);
    std::snprintf(text, sizeof text,
                  "bus %s: %zu UC57 nodes with staggered TPDOs (%u SYNCs per cycle, %s per SYNC)%s at %.1f Hz need "
                  "%.0f%% of %u bit/s; SYNC at %.0f Hz, each node's status at %.1f Hz instead (polls and heartbeats "
                  "fill up to %.0f%% of the bus)",
                  bus_.c_str(), staggered_nodes, stagger_g_, stagger_separate_ ? "one TPDO" : "two TPDOs",
                  every_nodes > 0 ? (", " + std::to_string(every_nodes) + " answering every SYNC").c_str() : "",
                  hz(asked_period_), 100.0 * std::chrono::duration<double>(cycle).count() * hz(asked), bitrate_,
                  hz(sync_period_), hz(sync_period_ * g), 100.0 * budget);
  }
  poll_warning_ = text;
}

Duration Uc57Stack::heartbeat_consumer_time(const Node& node) const {
  return std::chrono::milliseconds(node.settings.heartbeat_ms) * options_.heartbeat_loss_factor + sdo_allowance_;
}

Duration Uc57Stack::period_within(double budget) const {
  const double share = std::max(budget - heartbeat_share_, budget / 4);
  const auto needed = std::chrono::ceil<std::chrono::milliseconds>(
      std::chrono::duration<double, std::nano>(static_cast<double>(poll_cycle_.count()) / share));
  return std::max<Duration>(needed, asked_period_);
}

// A node is configured by SDO exchanges (600h/580h + node), which lose arbitration to every TPDO
// answering a SYNC, and its heartbeat consumer is armed early: on a bus whose polls take 75 %,
// what is left was too little for the set-up traffic and the heartbeats of 32 nodes at 125 kbit/s
// (heartbeats missed, an RPDO acceptance test with no answer within a SYNC period). The SYNC,
// and with it every node's status, slows while the set-up runs.
void Uc57Stack::ease_polls_while_configuring(TimePoint now) {
  if (stagger_g_ > 0 || !master_.sync()->running()) return;
  const bool ease = configuring() > 0 && period_within(kConfiguringPollBusShare) > sync_period_;
  if (ease == polls_eased_) return;
  polls_eased_ = ease;
  master_.sync()->set_period(ease ? period_within(kConfiguringPollBusShare) : sync_period_, now);
}

// ---------------------------------------------------------------------------------------------
// Set-up: transmission types and the start in the node's slot
// ---------------------------------------------------------------------------------------------

Uc57Stack::ConfigOp Uc57Stack::tpdo_type_op(std::size_t n) {
  return {[this, n](const Continue& next) {
    const auto plain = [this, n, next](std::uint8_t type) {
      sdo_write_all(n, {{transmission_type(1), le<std::uint8_t>(type)}, {transmission_type(2), le<std::uint8_t>(type)}},
                    next);
    };
    if (!staggered(n)) return plain(nodes_[n]->settings.tpdo_transmission_type());
    const auto g = static_cast<std::uint8_t>(stagger_g_);
    sdo_write(n, transmission_type(1), le<std::uint8_t>(g),
              [this, n, g, plain, next](std::error_code ec, std::span<const std::uint8_t>) {
                if (!ec) {
                  // TPDO2 silent at SYNCs until its own slot (nmt_start_op), or with TPDO1 in one slot.
                  const auto second = stagger_separate_ ? kTransmissionEventDriven : g;
                  return sdo_write_all(n, {{transmission_type(2), le<std::uint8_t>(second)}}, next);
                }
                if (ec.category() != canopen::sdo_category() || ec == canopen::SdoAbortCode::kTimeout)
                  return next(sdo_failure(n, true, transmission_type(1), ec));
                Node& node = *nodes_[n];
                node.stagger_refused = true;  // remembered: type 1 from now on
                event(n, Event::CONFIG_MISMATCH, Event::WARNING, ec.value(),
                      sdo_failure(n, true, transmission_type(1), ec) + " for transmission type " + std::to_string(g) +
                          " (staggered TPDOs); its TPDOs answer every SYNC (type 1) and the bus's polls keep to " +
                          std::to_string(static_cast<int>(100 * kPollBusShare)) + "%");
                fit_sync_period();
                warn_bus(poll_warning_);
                plain(kTransmissionSyncEveryCycle);
              });
  }};
}

Uc57Stack::ConfigOp Uc57Stack::nmt_start_op(std::size_t n) {
  return {[this, n](const Continue& next) {
    Node& node = *nodes_[n];
    // A heartbeat (700h + node, the lowest priority) waits behind whatever else is on the wire,
    // a SYNC's answers included: the consumer time counts that wait too (sdo_allowance_).
    master_.nmt().monitor(node.settings.node, heartbeat_consumer_time(node));
    master_.nmt().mark_configured(node.settings.node);
    if (!staggered(n)) {
      master_.nmt().send(canopen::NmtCommand::kStart, node.settings.node);
      return next(std::nullopt);
    }
    const unsigned session = node.session;
    start_in_slots(
        n,
        [this, n, session] { return nodes_[n]->session == session && nodes_[n]->phase == Node::Phase::kConfiguring; },
        next);
  }};
}

void Uc57Stack::start_in_slots(std::size_t n, const std::function<bool()>& current, const Continue& done) {
  const auto index = static_cast<unsigned>(nodes_[n]->stagger_index);
  const unsigned first = stagger_separate_ ? 2 * index : index;
  at_slot(first, [this, n, first, current, done] {
    if (!current()) return;
    Node& started = *nodes_[n];
    master_.nmt().send(canopen::NmtCommand::kStart, started.settings.node);
    started.slot[0] = first;
    started.slot_candidate = {};
    if (!stagger_separate_) {
      started.slot[1] = first;
      return done(std::nullopt);
    }
    // Both counts start here (Operational entered): TPDO2 keeps quiet in the stack's eyes until its
    // own slot's write moves it.
    started.slot[1].reset();
    at_slot(first + 1, [this, n, first, current, done] {
      if (!current()) return;
      Node& armed = *nodes_[n];
      // TPDO2 counts from this write: no periodic SYNC until the drive has taken it.
      hold_sync(n, now_ + sdo_timeout(armed) * (armed.settings.sdo_retries + 1));
      sdo_write(n, transmission_type(2), le<std::uint8_t>(static_cast<std::uint8_t>(stagger_g_)),
                [this, n, first, current, done](std::error_code ec, std::span<const std::uint8_t>) {
                  release_sync(n);
                  if (!current()) return;
                  if (ec) return done(sdo_failure(n, true, transmission_type(2), ec));
                  nodes_[n]->slot[1] = first + 1;
                  done(std::nullopt);
                });
    });
  });
}

void Uc57Stack::at_slot(unsigned slot, std::function<void()> run) {
  slot_waiters_.emplace_back(slot % std::max(stagger_g_, 1U), std::move(run));
}

void Uc57Stack::run_slot_waiters() {
  if (stagger_g_ == 0 || slot_waiters_.empty()) return;
  const auto slot = static_cast<unsigned>(syncs_handed_ % stagger_g_);
  std::vector<std::function<void()>> due;
  for (auto it = slot_waiters_.begin(); it != slot_waiters_.end();) {
    if (it->first == slot) {
      due.push_back(std::move(it->second));
      it = slot_waiters_.erase(it);
    } else {
      ++it;
    }
  }
  for (auto& run : due) run();
}

// ---------------------------------------------------------------------------------------------
// Pacing and observation
// ---------------------------------------------------------------------------------------------

void Uc57Stack::spend_wire(const can::Frame& frame, TimePoint now) {
  if (stagger_g_ == 0) return;
  const auto info = canopen::classify_cob_id(frame.id);
  if (!frame.extended && info && info->kind == canopen::MessageKind::kHeartbeat) return;
  if (credit_at_ != TimePoint{}) {
    const auto earned = std::chrono::duration_cast<Duration>((now - credit_at_) * poll_share_);
    // At most a few frames' worth saved up: an idle second buys no burst.
    poll_credit_ = std::min(poll_credit_ + earned, 4 * can::frame_duration(encode_tpdo2(1, {}), bitrate_));
  }
  credit_at_ = now;
  poll_credit_ -= can::frame_duration(frame, bitrate_);
}

TimePoint Uc57Stack::credit_ready_at() const {
  if (!echoes_ || poll_credit_ >= Duration::zero()) return TimePoint{};
  return credit_at_ + std::chrono::ceil<Duration>(-poll_credit_ / poll_share_);
}

bool Uc57Stack::sync_due(TimePoint now) {
  if (now < next_sync_at_) return false;
  if (now < credit_ready_at()) return false;
  if (echoes_ && sync_awaiting_echo_ && now < sync_handed_at_ + kEchoWait) return false;
  if (answers_left_ > 0 && now < answers_due_) return false;
  for (auto it = sync_holds_.begin(); it != sync_holds_.end();) {
    if (now < it->second) return false;
    it = sync_holds_.erase(it);
  }
  return true;
}

TimePoint Uc57Stack::next_sync_check() const {
  TimePoint next = next_sync_at_;
  next = std::max(next, credit_ready_at());
  if (echoes_ && sync_awaiting_echo_) next = std::max(next, sync_handed_at_ + kEchoWait);
  if (answers_left_ > 0) next = std::max(next, answers_due_);
  for (const auto& [n, until] : sync_holds_) next = std::max(next, until);
  return next;
}

void Uc57Stack::on_sync_handed() {
  if (stagger_g_ == 0) return;  // type 1 / event only: the timer's SYNC, nothing to pace
  if (echoes_) syncs_in_flight_.push_back(syncs_handed_);
  sync_handed_at_ = now_;
  sync_awaiting_echo_ = true;
  // The answers this SYNC asks for: the staggered TPDOs of its slot, every type-1 node's TPDOs.
  const auto slot = static_cast<unsigned>(syncs_handed_ % stagger_g_);
  unsigned answers = 0;
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    const Node& node = *nodes_[n];
    if (node.phase == Node::Phase::kOffline || node.phase == Node::Phase::kConfigError) continue;
    if (staggered(n)) {
      answers += (node.slot[0] == slot ? 1U : 0U) + (node.slot[1] == slot && node.tpdo2_active ? 1U : 0U);
    } else if (node.settings.tpdo_mode != TpdoMode::kEvent && node.phase != Node::Phase::kConfiguring) {
      answers += node.tpdo2_active ? 2U : 1U;
    }
  }
  answers_left_ = answers;
  const Duration frame = can::frame_duration(encode_tpdo2(1, {}), bitrate_);
  // Their wire time after the SYNC, and two frames more: one that took the wire at the SYNC's end
  // (pending before the answers were) and stuff bits.
  answers_due_ = now_ + can::frame_duration(canopen::encode_sync({}), bitrate_) + (answers + 2) * frame;
}

void Uc57Stack::on_transmitted(const can::Frame& frame, TimePoint now) {
  if (!frame.extended && !frame.rtr && frame.id == canopen::kSyncCobId) last_sync_at_ = now;
  if (stagger_g_ == 0) return;
  now_ = now;
  echoes_ = true;
  spend_wire(frame, now);
  if (frame.extended || frame.rtr || frame.id != canopen::kSyncCobId) return;
  if (syncs_in_flight_.empty()) {
    syncs_on_wire_ = syncs_handed_;
  } else {
    syncs_on_wire_ = syncs_in_flight_.front();
    syncs_in_flight_.pop_front();
  }
  sync_awaiting_echo_ = !syncs_in_flight_.empty();
  answers_due_ = now + (answers_left_ + 2) * can::frame_duration(encode_tpdo2(1, {}), bitrate_);
}

void Uc57Stack::on_tpdo_seen(std::size_t n, unsigned pdo) {
  Node& node = *nodes_[n];
  if (node.settings.tpdo_mode == TpdoMode::kEvent) return;
  // Only an answer to the last SYNC handed over counts for it (a late one to the SYNC before does not).
  const std::uint64_t index = sync_index();
  if (answers_left_ > 0 && index == syncs_handed_) --answers_left_;
  if (!staggered(n) || pdo < 1 || pdo > 2) return;
  auto& slot = node.slot[pdo - 1];
  if (!slot || index == 0) return;  // its count is not armed yet
  const auto seen = static_cast<unsigned>(index % stagger_g_);
  auto& candidate = node.slot_candidate[pdo - 1];
  if (*slot == seen) {
    candidate.reset();
    return;
  }
  // Moved only when seen there twice running: one answer overtaken by the next SYNC (it waited
  // behind other frames past its time) does not move it.
  if (candidate != seen) {
    candidate = seen;
    return;
  }
  candidate.reset();
  if (!node.slot_reported) {
    node.slot_reported = true;
    event(n, Event::CONFIG_MISMATCH, Event::WARNING, static_cast<std::int32_t>(seen),
          node.settings.label() + ": TPDO" + std::to_string(pdo) + " answers the SYNCs of slot " +
              std::to_string(seen) + " of " + std::to_string(stagger_g_) + ", not its planned slot " +
              std::to_string(*slot) + " (the drive counts SYNCs from another moment); polled in that slot");
  }
  slot = seen;
}

}  // namespace motion::uc57_driver
