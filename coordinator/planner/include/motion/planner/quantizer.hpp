// What a drive can really execute: DriveQuantizer maps desired motion parameters (counts/s,
// counts/s^2) to the nearby values the drive can represent, with the native integers to send.
//
// A drive family plugs in by either configuring a GridQuantizer (velocity on an integer grid,
// acceleration as an integer rate or as an integer ramp time: covers UIM342, UIM242, UC57 and the
// ADAM steppers once their exact units are known) or by deriving from DriveQuantizer.
// Thread contract: quantizers are immutable after construction; candidates() is const and
// thread-safe, so one instance may serve every plan of every thread.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace motion::planner {

// Motion parameters in drive counts: cruise velocity (counts/s), acceleration and deceleration
// (counts/s^2), all magnitudes.
struct DriveMotion {
  double velocity_counts_per_s = 0.0;
  double acceleration_counts_per_s2 = 0.0;
  double deceleration_counts_per_s2 = 0.0;
};

// The integers written to the drive; their unit is the quantizer's (documented per class).
struct NativeMotion {
  std::int64_t velocity = 0;
  std::int64_t acceleration = 0;
  std::int64_t deceleration = 0;
  friend bool operator==(const NativeMotion&, const NativeMotion&) = default;
};

// One representable setting: what to send, and what the drive will then really do.
struct DriveSetting {
  NativeMotion native;
  DriveMotion realized;
};

class GridQuantizer;

class DriveQuantizer {
 public:
  virtual ~DriveQuantizer() = default;
  // Appends to `out` the representable settings around `desired`: for each parameter, the value
  // at or just below it and the `neighbours` (>= 1) next values on either side, in every
  // combination. Values outside the drive's native range are left out; the caller filters by the
  // axis limits.
  virtual void candidates(const DriveMotion& desired, int neighbours, std::vector<DriveSetting>& out) const = 0;
  // The settings of candidates(desired, neighbours) whose realized velocity is exactly
  // desired.velocity_counts_per_s (a representable velocity): only the ramps around it. Appended
  // to `out` in the same order. The default filters candidates(); grids compute only those.
  virtual void candidates_at_velocity(const DriveMotion& desired, int neighbours, std::vector<DriveSetting>& out) const;
  [[nodiscard]] virtual std::string_view name() const = 0;
  // This quantizer as a GridQuantizer, or null: the planner takes a grid's settings in blocks
  // (a virtual call, cheaper than a dynamic_cast per axis and plan).
  [[nodiscard]] virtual const GridQuantizer* as_grid() const { return nullptr; }

 protected:
  DriveQuantizer() = default;
  DriveQuantizer(const DriveQuantizer&) = default;
  DriveQuantizer& operator=(const DriveQuantizer&) = default;
};

// No quantization: the drive takes real numbers (simulations, tests). Native fields stay 0.
class IdentityQuantizer final : public DriveQuantizer {
 public:
  void candidates(const DriveMotion& desired, int neighbours, std::vector<DriveSetting>& out) const override;
  [[nodiscard]] std::string_view name() const override { return "identity"; }
};

// Velocity as an integer n: n * counts_per_s_per_step counts/s, n in [min_steps, max_steps].
struct VelocityGrid {
  double counts_per_s_per_step = 1.0;
  std::int64_t min_steps = 1;
  std::int64_t max_steps = std::numeric_limits<std::int32_t>::max();
};

// Acceleration (and deceleration) as an integer n, either
//   rate:      n * step counts/s^2, or
//   ramp time: the drive goes from `ramp_from` (counts/s; 0 = rest) to the commanded velocity (or
//              back) in n * step seconds, i.e. acceleration = (velocity - ramp_from) / (n * step).
//              A drive with a start / cut-in speed (UC57 200Eh, UIM342 time mode) jumps from rest
//              to that speed, then ramps: the realized acceleration is the slope of that ramp
//              (what the drive programs); the planner's trapezoid model ignores the jump, so such
//              an axis arrives up to ramp_from * ramp time / velocity early. A velocity at or below
//              ramp_from has no ramp and is not offered.
struct AccelerationGrid {
  enum class Kind { kRate, kRampTime };
  Kind kind = Kind::kRate;
  double step = 1.0;  // counts/s^2 per n (rate) or seconds per n (ramp time)
  std::int64_t min_steps = 1;
  std::int64_t max_steps = std::numeric_limits<std::int32_t>::max();
  double ramp_from = 0.0;  // ramp time only: the speed (counts/s, >= 0) the ramps start from / end at

  [[nodiscard]] static AccelerationGrid rate(double counts_per_s2_per_step) {
    return {Kind::kRate, counts_per_s2_per_step};
  }
  [[nodiscard]] static AccelerationGrid ramp_time(double seconds_per_step, double from_counts_per_s = 0.0) {
    AccelerationGrid g{Kind::kRampTime, seconds_per_step};
    g.ramp_from = from_counts_per_s;
    return g;
  }
  // The same grid restricted to n in [min, max].
  [[nodiscard]] AccelerationGrid steps(std::int64_t min, std::int64_t max) const {
    AccelerationGrid g = *this;
    g.min_steps = min;
    g.max_steps = max;
    return g;
  }
  // Rate in rpm/s (times rpm_per_s_per_step per n), for a drive with `counts_per_rev` counts.
  [[nodiscard]] static AccelerationGrid rpm_per_s(double counts_per_rev, double rpm_per_s_per_step) {
    return rate(counts_per_rev * rpm_per_s_per_step / 60.0);
  }
};

// One representable acceleration (or deceleration) of a grid: what to send, what the drive does.
struct GridRamp {
  std::int64_t native = 0;
  double counts_per_s2 = 0.0;
};

// A grid's settings at one velocity: every acceleration with every deceleration, acceleration
// first (the order candidates() lists them in). The ramps are ramps[first_ramp ...]: the
// accelerations, then the decelerations. The blocks of a rate grid (AccelerationGrid::Kind::kRate)
// from one blocks() call share their ramps, which do not depend on the velocity.
struct GridBlock {
  std::int64_t velocity_native = 0;
  double velocity_counts_per_s = 0.0;
  std::uint32_t first_ramp = 0;
  std::uint32_t accelerations = 0;
  std::uint32_t decelerations = 0;
};

// The general integer-grid drive. Native velocity/acceleration/deceleration = the grid integers.
// Throws std::invalid_argument on a non-positive step or an empty range.
// candidates() and candidates_at_velocity() are final: the planner takes the same settings from
// blocks() (in blocks, so that it evaluates each velocity and ramp once, not once per setting).
class GridQuantizer : public DriveQuantizer {
 public:
  GridQuantizer(std::string name, VelocityGrid velocity, AccelerationGrid acceleration);
  void candidates(const DriveMotion& desired, int neighbours, std::vector<DriveSetting>& out) const final;
  void candidates_at_velocity(const DriveMotion& desired, int neighbours, std::vector<DriveSetting>& out) const final;
  // The settings of candidates() (with `at_velocity`, of candidates_at_velocity()) as blocks,
  // appended to `blocks` in the same order, their ramps appended to `ramps`. No block is empty.
  void blocks(const DriveMotion& desired, int neighbours, bool at_velocity, std::vector<GridBlock>& blocks,
              std::vector<GridRamp>& ramps) const;
  [[nodiscard]] std::string_view name() const override { return name_; }
  [[nodiscard]] const GridQuantizer* as_grid() const final { return this; }
  [[nodiscard]] const VelocityGrid& velocity_grid() const { return velocity_; }
  [[nodiscard]] const AccelerationGrid& acceleration_grid() const { return acceleration_; }

 private:
  std::string name_;
  VelocityGrid velocity_;
  AccelerationGrid acceleration_;
};

// UIM342 rate mode: velocity in integer pulses/s, acceleration/deceleration in integer pulses/s^2
// (a pulse = one count).
class PpsRateQuantizer final : public GridQuantizer {
 public:
  explicit PpsRateQuantizer(std::int64_t max_pps = std::numeric_limits<std::int32_t>::max(),
                            std::int64_t max_pps_per_s = std::numeric_limits<std::int32_t>::max());
};

// UIM342 time mode: velocity in integer pulses/s, acceleration/deceleration as an integer ramp
// time in milliseconds to reach the commanded speed from rest (or rest from it).
class PpsRampTimeQuantizer final : public GridQuantizer {
 public:
  explicit PpsRampTimeQuantizer(std::int64_t max_pps = std::numeric_limits<std::int32_t>::max(),
                                std::int64_t max_ramp_ms = std::numeric_limits<std::int32_t>::max());
};

// UC57 / ADAM style: velocity in steps of `rpm_per_step` rpm for a motor of `counts_per_rev`
// counts per revolution; acceleration in the unit the family gives (e.g.
// AccelerationGrid::rpm_per_s(counts_per_rev, 1.0) or AccelerationGrid::ramp_time(0.001)).
class RpmQuantizer final : public GridQuantizer {
 public:
  RpmQuantizer(double counts_per_rev, double rpm_per_step, AccelerationGrid acceleration,
               std::int64_t max_velocity_steps = std::numeric_limits<std::int32_t>::max());
};

}  // namespace motion::planner
