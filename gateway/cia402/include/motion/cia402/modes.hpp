// Modes of operation (6060h / 6061h) and the profile-position new-set-point handshake.
//
// Sources: CiA 402 (mode numbers; set-point handshake semantics), UC57 manual §4.2.2 (0x0F -> 0x1F
// absolute start, 0x4F -> 0x5F relative start), §4.2.3 and §5.2 (mode values; see the 1/2/3 vs
// 1/3/6 conflict in uc57_units.hpp), §4.2.4 (controlword bits 4, 5, 6, 8; statusword bits 10, 12,
// 15), §7 MC_MOVABS / MC_MOVREL (the handshake steps 4-9).
//
// Thread contract: ModeOfOperation helpers are pure; a NewSetPointHandshake instance is
// single-threaded (one per drive, on the thread owning the drive). It is passive: it is handed
// `now` and statuswords and returns the controlword to send and its next deadline.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string_view>

#include "motion/core/clock.hpp"

namespace motion::cia402 {

// CiA 402 modes of operation (6060h values, I8). The UC57 supports only kProfilePosition,
// kProfileVelocity and kHoming (manual §4.2.3, §5.2); the others are listed so that a value read
// from another drive decodes, and are rejected by uc57_supports().
enum class ModeOfOperation : std::int8_t {
  kNoMode = 0,  // UC57: "undefined", the 6060h/6061h power-on value
  kProfilePosition = 1,
  kVelocity = 2,  // CiA "velocity mode"; NOT the UC57's profile velocity (the §4.2.3 misprint)
  kProfileVelocity = 3,
  kProfileTorque = 4,
  kHoming = 6,
  kInterpolatedPosition = 7,
  kCyclicSynchronousPosition = 8,
  kCyclicSynchronousVelocity = 9,
  kCyclicSynchronousTorque = 10,
};
[[nodiscard]] std::string_view to_string(ModeOfOperation mode);
// Decodes a 6060h/6061h value; nullopt for values CiA 402 does not define.
[[nodiscard]] std::optional<ModeOfOperation> decode_mode(std::int8_t value);
// The values the UC57 accepts in 6060h: 0 (undefined), 1 (PP), 3 (PV), 6 (HM).
[[nodiscard]] bool uc57_supports(ModeOfOperation mode);

// What a profile-position set-point asks for (controlword bits 5 and 6).
struct SetPointOptions {
  bool relative = false;            // bit 6: target is relative (0x4F/0x5F) instead of absolute (0x0F/0x1F)
  bool change_immediately = false;  // bit 5: abort the running positioning instead of queueing
};

// Master side of the PP new-set-point handshake (§7 MC_MOVABS/MC_MOVREL, with CiA semantics):
//   arm:     send 0x0F/0x4F (bit 4 = 0), wait for statusword bit 12 (set-point ack) = 0
//   trigger: send 0x1F/0x5F (bit 4 rising edge), wait for bit 12 = 1
//   release: send 0x0F/0x4F (bit 4 = 0), wait for bit 12 = 0
//   moving:  until bit 10 (target reached) = 1 or bit 15 (UC57 "in position") = 1
// Write 607Ah/6081h/6083h/6084h before start(). The controlwords have the device-control bits of
// Enable operation (0x0F) plus bits 4, 5, 6 and 8 (halt); the drive must be in Operation enabled
// with 6061h = 1. Each wait for bit 12 has a deadline; the move itself has none (its duration
// depends on the profile; the caller supervises it).
class NewSetPointHandshake {
 public:
  enum class Phase : std::uint8_t {
    kIdle,
    kArming,     // bit 4 = 0 sent, waiting for ack = 0
    kTriggered,  // bit 4 = 1 sent, waiting for ack = 1
    kReleasing,  // ack seen, bit 4 = 0 sent, waiting for ack = 0
    kMoving,     // set-point taken, waiting for target reached / in position
    kTargetReached,
    kTimedOut,  // an ack wait exceeded its deadline; the handshake stopped
  };
  struct Output {
    Phase phase = Phase::kIdle;
    std::optional<std::uint16_t> controlword;  // send it now when present
    TimePoint deadline = kNever;
  };

  explicit NewSetPointHandshake(Duration ack_timeout = std::chrono::milliseconds(500)) : ack_timeout_(ack_timeout) {}

  // Begins a new set-point (also while a move runs: with change_immediately it replaces it).
  Output start(SetPointOptions options, TimePoint now);
  Output on_statusword(std::uint16_t statusword, TimePoint now);
  Output on_timer(TimePoint now);
  // Halt (bit 8): decelerate with 6084h and hold. Returns the controlword to send.
  std::uint16_t set_halt(bool halt);

  [[nodiscard]] Phase phase() const { return phase_; }
  // The controlword as the handshake currently wants it.
  [[nodiscard]] std::uint16_t controlword() const;

 private:
  Output advance(Phase next, bool new_set_point, TimePoint now);
  [[nodiscard]] Output current(std::optional<std::uint16_t> controlword = std::nullopt) const;

  Duration ack_timeout_;
  SetPointOptions options_{};
  bool new_set_point_ = false;
  bool halt_ = false;
  Phase phase_ = Phase::kIdle;
  TimePoint deadline_ = kNever;
};

// The controlword of a PP set-point: Enable operation + bits 4, 5, 6, 8 (manual §4.2.2, §4.2.4).
// Vectors: 0x000F, 0x001F (absolute start), 0x004F, 0x005F (relative start), 0x002F/0x003F and
// 0x006F/0x007F (change immediately), 0x010F (halt).
[[nodiscard]] std::uint16_t profile_position_controlword(SetPointOptions options, bool new_set_point, bool halt);

}  // namespace motion::cia402
