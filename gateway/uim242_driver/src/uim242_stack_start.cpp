// Uim242Stack (uim242_stack.hpp): the start of armed moves, and what a controller does with a
// displacement loaded at desired speed 0 (docs/protocols.md, UIM242 #3): the probe and the crawl.
#include "uim242_stack_impl.hpp"

namespace motion::uim242_driver {

std::string Uim242Stack::spd0_position_move(std::string_view drive) const {
  for (const auto& d : drives_) {
    if (d->name != drive) continue;
    switch (d->spd0) {
      case Drive::Spd0::kHolds: return "holds";
      case Drive::Spd0::kRunsAtLastSpeed: return "runs_at_last_speed";
      case Drive::Spd0::kRefused: return "refused";
      case Drive::Spd0::kUnknown: return {};
    }
  }
  return {};
}

void Uim242Stack::report_facts(const Drive& d) {
  if (context_.out == nullptr || d.axis_name.empty()) return;
  gateway::DriveFacts facts;
  // Not known yet: modelled as holding (the default); the probe reports again at the first move.
  facts.crawl_start = d.spd0 == Drive::Spd0::kRunsAtLastSpeed || d.spd0 == Drive::Spd0::kRefused;
  context_.out->drive_facts(d.axis_name, facts);
}

std::vector<Instruction> Uim242Stack::position_run(const Drive& d, std::int64_t displacement,
                                                   std::int64_t speed) const {
  std::vector<Instruction> steps;
  if (d.spd0 != Drive::Spd0::kHolds)
    steps.push_back(set(Mnemonic::kSPD, displacement < 0 ? -kCrawlSpeed : kCrawlSpeed));
  steps.push_back(set(Mnemonic::kSTP, displacement));
  steps.push_back(set(Mnemonic::kSPD, speed));
  return steps;
}

// The manuals show a displacement only after a speed (§6.1 PT: "After setting the desired speed,
// user can enter desired positions"); whether `STP n;` at desired speed 0 waits for a later
// `SPD v;` (#37, #44) is tested once per drive, at rest, by one count.
void Uim242Stack::probe_spd0(Drive& d, std::int64_t group, const std::function<void(TimePoint)>& then) {
  const std::int64_t before = d.status.position_counts;
  const auto found = [this, &d](Drive::Spd0 answer, const std::string& how) {
    d.spd0 = answer;
    report_facts(d);
    event(d, event_t::CONFIG_MISMATCH, event_t::INFO, 0,
          fmt::format("{} (node {}): a displacement loaded at speed 0 {} (spd0_position_move {}); {}", d.name, d.node,
                      how, spd0_position_move(d.name),
                      answer == Drive::Spd0::kHolds ? "moves are preloaded and started by their speed"
                                                    : "moves start with a 1 pps crawl"));
  };
  // Leaves PT mode (`STP 0;` stops a probe that ran), then goes on if the command still runs. The
  // probe's own requests are in no command's group: a stop or e-stop of the move does not cancel
  // them, so the drive never stays in PT mode with the probe's count held.
  const auto leave = [this, &d, group, then](TimePoint) {
    submit(
        d, set(Mnemonic::kSTP, 0), 0,
        [this, group, then](const Frame&, TimePoint t) {
          if (commands_.find(group) != nullptr) then(t);
        },
        true);
  };
  Request r;
  r.drive = d.name;
  r.node = d.node;
  r.instruction = set(Mnemonic::kSTP, 1);
  r.group = 0;  // see leave
  r.on_reply = [this, &d, group, before, found, leave](const Frame&, TimePoint now) {
    after(now + kSpd0ProbeWait, [this, &d, group, before, found, leave](TimePoint t) {
      // The move ended meanwhile (a stop, an e-stop: the drive may be off): no finding, only
      // leave PT mode; the next armed move probes again.
      if (commands_.find(group) == nullptr) return leave(t);
      submit(
          d, bare(Mnemonic::kFBK), 0,
          [this, &d, group, before, found, leave](const Frame& f, TimePoint) {
            const auto status = uim242::decode_status(f);
            const std::int64_t speed = status ? status->speed : 0;
            submit(
                d, bare(Mnemonic::kQEC), 0,
                [this, group, before, speed, found, leave](const Frame& q, TimePoint at) {
                  const std::int64_t position = field(q, uim242::Layout::kS32, 0);
                  if (commands_.find(group) == nullptr) {
                    // Ended meanwhile: no finding.
                  } else if (speed != 0 || position != before) {
                    found(Drive::Spd0::kRunsAtLastSpeed,
                          fmt::format("runs at once (`STP 1;` at speed 0: {} pps, {} count(s) moved)", speed,
                                      position - before));
                  } else {
                    found(Drive::Spd0::kHolds, "holds still (`STP 1;` at speed 0: no motion)");
                  }
                  leave(at);
                },
                true);
          },
          true);
    });
  };
  r.on_failure = [this, &d, group, found, leave](const std::string& reason, bool timed_out, TimePoint now) {
    if (timed_out) {
      mark_offline(d, reason, now);
      finish(group, false, reason, kTimeout);
      return;
    }
    found(Drive::Spd0::kRefused, "is refused (" + reason + ")");
    leave(now);
  };
  channel_.submit(std::move(r), true);
}

Duration Uim242Stack::global_start_shortfall(const Move& m) const {
  std::size_t starting = 0;
  std::optional<std::int64_t> speed;
  for (const auto& a : m.axes) {
    if (a.arrived) continue;
    if (!a.preloaded || (speed && *speed != a.speed)) return Duration::zero();  // crawls, or drive by drive
    speed = a.speed;
    ++starting;
  }
  if (!speed || starting != drives_.size()) return Duration::zero();
  const auto longest = uim242::encode_global(Mnemonic::kSPD, uim242::spec(Mnemonic::kSPD).max);
  const auto actual = uim242::encode(Instruction{Mnemonic::kSPD, true, *speed, false});
  if (!longest.ok() || !actual.ok() || longest->size() <= actual->size()) return Duration::zero();
  return channel_.character_time() * static_cast<std::int64_t>(longest->size() - actual->size());
}

void Uim242Stack::start_move(Move& m, TimePoint scheduled) {
  m.start_sent = true;
  const std::int64_t id = m.command_id;
  std::vector<Move::Axis*> to_start;
  for (auto& a : m.axes) {
    if (!a.arrived) to_start.push_back(&a);
  }
  const auto started = [this, id, &m](std::string mechanism) {
    Command* c = commands_.find(id);
    if (c == nullptr) return;
    const TimePoint first = m.first_start.value_or(TimePoint{});
    // Measured spread between the first and the last start instruction on the wire.
    c->reply.started(context_.utime_of ? context_.utime_of(first) : steady_us(first), std::move(mechanism),
                     std::chrono::duration<double, std::micro>(m.last_start - first).count());
    commands_.advance_all(id, Lifecycle::kStarted);  // the ledger replies STARTED
    if (std::all_of(m.axes.begin(), m.axes.end(), [](const auto& a) { return a.arrived; })) return finish(id, true);
    for (const auto& a : m.axes) {
      if (a.arrived) commands_.advance(id, index_of(*a.drive), Lifecycle::kDone);  // at its target before the start
    }
  };
  const auto on_sent = [&m](TimePoint sent) {
    if (!m.first_start) m.first_start = sent;
    m.last_start = sent;
  };
  for (auto* a : to_start) {
    a->planned =
        trapezoid_duration(a->target - a->drive->status.position_counts, a->speed, a->acceleration, a->deceleration);
    a->drive->status.target_counts = a->target;
    a->drive->status.in_position = false;
    a->drive->still_polls = 0;
  }
  if (to_start.empty()) {
    m.first_start = m.last_start = TimePoint{};
    started("none");
    return;
  }
  const bool every_drive = to_start.size() == drives_.size();
  const bool one_speed =
      std::all_of(to_start.begin(), to_start.end(), [&](const auto* a) { return a->speed == to_start.front()->speed; });
  const bool crawl = std::any_of(to_start.begin(), to_start.end(), [](const auto* a) { return !a->preloaded; });
  const std::string kind = crawl ? "crawl_" : "";
  const auto failure = [this, id](Drive* d) {
    return [this, id, d](const std::string& reason, bool timed_out, TimePoint t) {
      if (timed_out && d != nullptr) mark_offline(*d, reason, t);
      finish(id, false, reason, timed_out ? kTimeout : kDriveError);
    };
  };
  // The requests in the order they go out; handed to the front of the queue (ahead of any queued
  // poll) in reverse. An axis not preloaded first crawls into its displacement (`SPD ±1;` in VT
  // mode, then `STP n;` in PT mode at 1 pps: neither is a displacement at speed 0, so every
  // spd0_position_move variant runs it alike); then the speeds start every axis.
  std::vector<Request> out;
  for (auto* a : to_start) {
    if (a->preloaded) continue;
    const std::int64_t displacement = a->target - a->drive->status.position_counts;
    for (const auto& in :
         {set(Mnemonic::kSPD, displacement < 0 ? -kCrawlSpeed : kCrawlSpeed), set(Mnemonic::kSTP, displacement)}) {
      Request r;
      r.drive = a->drive->name;
      r.node = a->drive->node;
      r.instruction = in;
      r.group = id;
      r.on_sent = on_sent;
      r.on_failure = failure(a->drive);
      out.push_back(std::move(r));
    }
  }
  if (every_drive && one_speed) {
    // Every controller is loaded (or crawling in PT mode): one global speed starts them all.
    Request r;
    r.drive = "gateway";
    r.instruction = Instruction{Mnemonic::kSPD, true, to_start.front()->speed, false};
    r.group = id;
    r.on_sent = on_sent;
    // The coordinator led this start by the drive model's wire time of the longest global form
    // (gSPD 65535;): a shorter one waits the difference after the scheduled time, so that it
    // ends when that one would (the gateway fires it then: start_delay()).
    const Duration shortfall = global_start_shortfall(m);
    if (shortfall > Duration::zero()) r.not_before = scheduled + shortfall;
    r.on_reply = [started, kind](const Frame&, TimePoint) { started(kind + "broadcast"); };
    r.on_failure = failure(nullptr);
    out.push_back(std::move(r));
  } else {
    // Axis by axis.
    for (auto* a : to_start) {
      Request r;
      r.drive = a->drive->name;
      r.node = a->drive->node;
      r.instruction = set(Mnemonic::kSPD, a->speed);
      r.group = id;
      r.on_sent = on_sent;
      r.on_failure = failure(a->drive);
      out.push_back(std::move(r));
    }
    out.back().on_reply = [started, kind](const Frame&, TimePoint) { started(kind + "sequential"); };
  }
  for (auto it = out.rbegin(); it != out.rend(); ++it) channel_.submit(std::move(*it), true);
}

}  // namespace motion::uim242_driver
