// Motion of one simulated stepper axis: the shared kinematics of every simulated drive family.
//
// Exact, not time-stepped: a motion is a list of constant-acceleration segments computed when it
// starts (or changes), and the state at any time is evaluated analytically. Units are the
// drive's: counts (pulses) and seconds.
//
// Stepper semantics modelled (UIM342 SimpleCAN §3.3 and the other manuals' equivalents):
//  - cut-in (start/stop) speed: from rest the motor jumps to min(cut_in, target speed), and a
//    deceleration to rest ends by jumping from the cut-in speed to 0;
//  - point-to-point: trapezoid (or triangle) with separate acceleration and deceleration, ending
//    exactly on the integer target;
//  - jog: ramp to a signed velocity and hold it;
//  - stop: ramp down with a given deceleration (normal or emergency), or halt at once.
// A new command while moving starts from the current position and velocity (a reversal first
// decelerates to rest).
//
// Thread contract: single-threaded value type; all methods take `now` (no clock inside).
#pragma once

#include <cstdint>
#include <vector>

#include "motion/core/clock.hpp"

namespace motion::sim {

struct Profile {
  double velocity = 0;      // counts/s: PTP speed (magnitude) or jog velocity (signed)
  double acceleration = 0;  // counts/s^2, > 0
  double deceleration = 0;  // counts/s^2, > 0
  double cut_in = 0;        // counts/s, >= 0
};

class Kinematics {
 public:
  struct State {
    double position = 0;  // counts (fractional while moving)
    double velocity = 0;  // counts/s
    bool moving = false;
  };

  [[nodiscard]] State at(TimePoint now) const;
  // Rounded position, as a drive reports it.
  [[nodiscard]] std::int64_t position_counts(TimePoint now) const;
  [[nodiscard]] bool moving(TimePoint now) const { return at(now).moving; }
  [[nodiscard]] bool jogging() const { return jogging_; }
  // When the current motion ends (PTP arrival, stop), or kNever (jog, at rest).
  [[nodiscard]] TimePoint end_time() const;

  void move_to(TimePoint now, std::int64_t target, const Profile& profile);
  void jog(TimePoint now, const Profile& profile);
  void stop(TimePoint now, double deceleration, double cut_in = 0);
  void halt(TimePoint now);                                 // velocity 0 at once (driver off, stall)
  void set_position(TimePoint now, std::int64_t position);  // origin / set position, at rest

 private:
  struct Segment {
    TimePoint start;
    double x0 = 0;
    double v0 = 0;
    double a = 0;
    double duration = 0;  // seconds; infinity for a held jog velocity
  };
  // Rebuilds the segment list from the state at `now`.
  void plan_ptp(TimePoint now, State from, double target, const Profile& p);
  void ramp_to(TimePoint& t, double& x, double& v, double v_target, double rate);
  void push(TimePoint& t, double& x, double& v, double a, double duration);

  std::vector<Segment> segments_;
  double rest_position_ = 0;  // where the axis rests after the last segment
  std::int64_t exact_target_ = 0;
  bool has_exact_target_ = false;
  bool jogging_ = false;
};

}  // namespace motion::sim
