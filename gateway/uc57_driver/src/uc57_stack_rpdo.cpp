// Uc57Stack (uc57_stack.hpp): how RPDO1 applies on this drive, found at set-up, and what a start
// by RPDO1 looks like on the wire.
//
// The UC57 manual does not say that a UC57 honours synchronous RPDOs: §4.1.2 describes SYNC
// "assuming that the devices in the network support synchronous PDO function", and the §5 comm.
// table gives 1400h:02 (RPDO transmission type, RW/S) only its default FFh. Three readings
// (docs/protocols.md, UC57 #1; simulation.variants rpdo_sync):
//  - honoured: type 1 accepted, the mapped values apply at the next SYNC (CiA 301 §7.2.2);
//  - on_reception: type 1 accepted, but an RPDO applies when it arrives;
//  - refused: the SDO write of type 1 is aborted (handled where it is written, uc57_stack_boot.cpp:
//    RPDO1 then runs with FFh).
// The acceptance test tells the first two apart without moving anything: it sends RPDO1 with the
// values read at set-up (replacing anything stale buffered in the drive), and right after a SYNC it
// sends RPDO1 with the drive's own controlword (no new set-point edge: bit 4 unchanged, manual
// §4.2.4) and a changed target (607Ah; with the manual's default mapping 60FFh, which only
// profile velocity reads, §4.2.5), reads the target back by SDO before the next SYNC, then again
// after it, and puts the old value back. Read changed before the SYNC: on reception. Changed only
// after it: honoured. A SYNC between the RPDO and the answer makes the attempt inconclusive (up to
// three, each with its own test value). Where the test cannot run (default mapping in profile
// velocity mode, or no answer within a SYNC period) the set-up key rpdo_sync answers; without
// one, on reception is assumed: a start node by node is right under every reading, a preloaded
// start under "on reception" would start the move before the trigger.
#include "uc57_stack_impl.hpp"

#include "motion/can_frame/bit_timing.hpp"

namespace motion::uc57_driver {
namespace {

constexpr unsigned kRpdoTestAttempts = 3;

}  // namespace

void Uc57Stack::after_sync(std::uint64_t count, std::function<void()> run) {
  sync_waiters_.emplace_back(count, std::move(run));
}

void Uc57Stack::run_sync_waiters() {
  const std::uint64_t sent = master_.sync()->sent();
  std::vector<std::function<void()>> due;
  for (auto it = sync_waiters_.begin(); it != sync_waiters_.end();) {
    if (sent > it->first) {
      due.push_back(std::move(it->second));
      it = sync_waiters_.erase(it);
    } else {
      ++it;
    }
  }
  for (auto& run : due) run();
}

void Uc57Stack::rpdo_found(std::size_t n, bool at_sync, const std::string& finding) {
  Node& node = *nodes_[n];
  node.rpdo_at_sync = at_sync;
  node.rpdo_finding = finding;
  const RpdoSyncAnswer answer = node.settings.rpdo_sync;
  const bool detected = finding.find("detected") != std::string::npos || finding.starts_with("refused");
  if (detected && answer != RpdoSyncAnswer::kDetect && (answer == RpdoSyncAnswer::kHonoured) != at_sync) {
    event(n, Event::CONFIG_MISMATCH, Event::WARNING, 0,
          node.settings.label() + ": set-up says rpdo_sync " +
              (answer == RpdoSyncAnswer::kHonoured ? "honoured" : "on_reception") + ", the drive's RPDO1 is " +
              finding + "; going by the drive");
  }
  if (!at_sync) {
    event(n, Event::CONFIG_MISMATCH, Event::INFO, 0,
          node.settings.label() + ": RPDO1 " + finding +
              ": its moves start by their own RPDO1, node by node (skew in STARTED)");
  }
}

Uc57Stack::ConfigOp Uc57Stack::rpdo_acceptance_op(std::size_t n) {
  return {[this, n](const Continue& next) {
    Node& node = *nodes_[n];
    if (node.sync_refused) {
      rpdo_found(n, false, "refused (transmission type 1 aborted; asynchronous, FFh)");
      return next(std::nullopt);
    }
    if (node.layout == RpdoLayout::kManualDefault && node.image.mode == kModeProfileVelocity) {
      // 60FFh would change a running speed: not tested.
      switch (node.settings.rpdo_sync) {
        case RpdoSyncAnswer::kHonoured:
          rpdo_found(n, true, "honoured (configured; not testable in profile velocity mode)");
          break;
        case RpdoSyncAnswer::kOnReception: rpdo_found(n, false, "on_reception (configured)"); break;
        case RpdoSyncAnswer::kDetect:
          rpdo_found(n, false, "on_reception (assumed: not testable in profile velocity mode; set rpdo_sync to say)");
          break;
      }
      return next(std::nullopt);
    }
    const unsigned session = node.session;
    // First the drive's own image (as read at set-up): a synchronous RPDO1 still buffered in the
    // drive (an earlier set-up's test, a gateway that died between an RPDO and its SYNC) is
    // replaced by it, so the SYNC below leaves the values the test compares against. Then start
    // right after that SYNC: the RPDO and the read have a whole period.
    send_image(n, node.image);
    after_sync(master_.sync()->sent(), [this, n, session, next] { rpdo_test_attempt(n, session, 0, next); });
  }};
}

void Uc57Stack::rpdo_test_attempt(std::size_t n, unsigned session, unsigned attempt, const Continue& next) {
  Node& node = *nodes_[n];
  if (node.session != session || node.phase != Node::Phase::kConfiguring) return;
  const bool target_layout = node.layout == RpdoLayout::kControlwordTarget;
  const ObjectAddress probe{target_layout ? od::kTargetPosition : od::kTargetVelocity, 0};
  const RpdoImage original = node.image;
  const std::int32_t old_value = target_layout ? original.target_position : original.target_velocity;
  const std::int32_t test_value = old_value ^ static_cast<std::int32_t>(attempt + 1);
  RpdoImage test = original;
  (target_layout ? test.target_position : test.target_velocity) = test_value;
  // Puts the old value back: at once (on reception) or at the next SYNC (honoured).
  const auto restore = [this, n, original] {
    send_image(n, original);
    nodes_[n]->image_sync = master_.sync()->sent() + 1;
  };
  const std::uint64_t before = master_.sync()->sent();
  // A staggered bus's SYNC comes every few frames: none until the read is answered.
  hold_sync(n, now_ + sdo_timeout(node) * (node.settings.sdo_retries + 1));
  send_image(n, test);
  node.image = original;  // what the drive holds once restored
  sdo_read(
      n, probe,
      [this, n, session, attempt, next, probe, before, test_value, restore](std::error_code ec,
                                                                            std::span<const std::uint8_t> data) {
        release_sync(n);
        Node& nd = *nodes_[n];
        if (nd.session != session) return;
        if (ec) {
          restore();
          return next(sdo_failure(n, false, probe, ec));
        }
        const std::string label = nd.settings.label();
        if (master_.sync()->sent() != before) {
          restore();
          if (attempt + 1 < kRpdoTestAttempts) {
            return after_sync(master_.sync()->sent(),
                              [this, n, session, attempt, next] { rpdo_test_attempt(n, session, attempt + 1, next); });
          }
          switch (nd.settings.rpdo_sync) {
            case RpdoSyncAnswer::kHonoured:
              rpdo_found(n, true, "honoured (configured; the test got no answer within a SYNC period)");
              break;
            case RpdoSyncAnswer::kOnReception: rpdo_found(n, false, "on_reception (configured)"); break;
            case RpdoSyncAnswer::kDetect:
              rpdo_found(n, false,
                         "on_reception (assumed: the test got no answer within a SYNC period; set rpdo_sync to say)");
              break;
          }
          return next(std::nullopt);
        }
        if (read_signed(data) == test_value) {
          restore();
          rpdo_found(n, false, "on_reception (detected: " + object_text(probe) + " changed before the SYNC)");
          return next(std::nullopt);
        }
        // Not applied on reception: the next SYNC must apply it.
        after_sync(before, [this, n, session, next, probe, test_value, restore] {
          if (nodes_[n]->session != session) return;
          sdo_read(n, probe,
                   [this, n, session, next, probe, test_value, restore](std::error_code ec2,
                                                                        std::span<const std::uint8_t> data2) {
                     if (nodes_[n]->session != session) return;
                     restore();
                     if (ec2) return next(sdo_failure(n, false, probe, ec2));
                     if (read_signed(data2) != test_value) {
                       return next(nodes_[n]->settings.label() +
                                   ": RPDO1 is applied neither on reception nor at the SYNC (" + object_text(probe) +
                                   " reads " + std::to_string(read_signed(data2)) + ", " + std::to_string(test_value) +
                                   " was sent)");
                     }
                     rpdo_found(n, true,
                                "honoured (detected: " + object_text(probe) + " changed at the SYNC, not before)");
                     next(std::nullopt);
                   });
        });
      });
}

Uc57Stack::StartFacts Uc57Stack::start_facts(const Job& job) const {
  StartFacts facts;
  facts.mechanism = "sync";
  can::Frame sync_frame{};
  sync_frame.id = canopen::kSyncCobId;  // configure_sync() in the constructor
  facts.frame = sync_frame;
  // When each node's move starts, as wire time handed over so far: a node honouring SYNC at the
  // SYNC's end of frame, any other at its own RPDO1's (sent back to back, in node order).
  std::optional<Duration> first;
  Duration last{};
  for (const std::size_t n : job.nodes) {
    const Node& node = *nodes_[n];
    const Duration at = node.rpdo_at_sync ? last_sync_end_ : node.rpdo_end;
    if (!node.rpdo_at_sync) facts.mechanism = "rpdo";
    if (!first || at < *first) {
      first = at;
      facts.frame = node.rpdo_at_sync ? sync_frame : node.last_rpdo;
    }
    last = std::max(last, at);
  }
  if (first) facts.skew_us = std::chrono::duration<double, std::micro>(last - *first).count();
  return facts;
}

}  // namespace motion::uc57_driver
