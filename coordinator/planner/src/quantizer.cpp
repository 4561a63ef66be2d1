#include "motion/planner/quantizer.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <span>
#include <stdexcept>
#include <utility>

namespace motion::planner {
namespace {

void require_valid(bool ok, std::string_view what) {
  if (!ok) throw std::invalid_argument(std::string("GridQuantizer: ") + std::string(what));
}

bool valid_range(std::int64_t min_steps, std::int64_t max_steps) { return min_steps >= 1 && max_steps >= min_steps; }

// The grid index n of the value at or just below `desired`, within [min_steps - 1, max_steps + 1]:
// the settings offered are that index and the `neighbours` next ones on either side of it, inside
// [min_steps, max_steps] (so an exactly representable desired value still gets a lower
// alternative, whatever the floating-point rounding of value_of). value_of is monotonic
// (increasing for rates, decreasing for ramp times); `guess` is the real index of `desired` in
// closed form, corrected here by at most a step or two because value_of(n) is computed in
// floating point.
template <typename ValueOf>
std::int64_t at_or_below_index(double desired, double guess, bool increasing, std::int64_t min_steps,
                               std::int64_t max_steps, ValueOf value_of) {
  const auto lowest = min_steps - 1;
  const auto highest = max_steps + 1;
  const double clamped = std::clamp(guess, static_cast<double>(lowest), static_cast<double>(highest));
  // clamped >= lowest >= 0: truncation is the floor, and the ceiling one above it when not exact
  // (cheaper than std::floor / std::ceil without SSE4.1).
  auto at_or_below = static_cast<std::int64_t>(clamped);
  if (!increasing && static_cast<double>(at_or_below) < clamped) ++at_or_below;
  const std::int64_t toward_lower_value = increasing ? -1 : +1;
  const auto inside = [&](std::int64_t n) { return n >= lowest && n <= highest; };
  while (inside(at_or_below + toward_lower_value) && value_of(at_or_below) > desired) at_or_below += toward_lower_value;
  while (inside(at_or_below - toward_lower_value) && value_of(at_or_below - toward_lower_value) <= desired) {
    at_or_below -= toward_lower_value;
  }
  return at_or_below;
}

// The offered indices around `at_or_below`, in order of increasing value: k = -neighbours..neighbours,
// k <= 0 at or below desired, k > 0 above; those outside [min_steps, max_steps] are left out.
struct Bracket {
  std::int64_t at_or_below;
  std::int64_t toward_lower_value;  // -1 for increasing values, +1 for decreasing ones
  int neighbours;
  std::int64_t min_steps;
  std::int64_t max_steps;

  [[nodiscard]] int size() const { return 2 * neighbours + 1; }
  // The j-th index (j = k + neighbours), or 0 when it lies outside the range.
  [[nodiscard]] std::int64_t index(int j) const {
    const std::int64_t n = at_or_below - toward_lower_value * (j - neighbours);
    return n >= min_steps && n <= max_steps ? n : 0;
  }
};

// The settings of GridQuantizer::candidates, velocity by velocity: the representable ramps are
// appended to `ramps` (accelerations, then decelerations, in order), then `visit(v_native,
// velocity, first, accelerations, decelerations)` is called with where they start and how many
// there are (neither none: a velocity without is skipped and its ramps removed); with
// `only_velocity`, only the velocity equal to it (the velocity loop runs as for candidates(), the
// ramps only for that one). With `share_rates`, the velocities of a rate grid (whose ramps do not
// depend on the velocity) are all visited with the ramps appended for the first: `ramps` must then
// keep them from visit to visit.
template <typename Visit>
void grid_blocks(const VelocityGrid& velocity_grid, const AccelerationGrid& acceleration_grid,
                 const DriveMotion& desired, int neighbours, const double* only_velocity, bool share_rates,
                 std::vector<GridRamp>& ramps, Visit&& visit) {
  neighbours = std::max(neighbours, 1);
  const double v_step = velocity_grid.counts_per_s_per_step;
  const double a_step = acceleration_grid.step;
  const bool ramp_time = acceleration_grid.kind == AccelerationGrid::Kind::kRampTime;

  // A ramp-time drive has no ramp at or below its start speed: a slower wish is served by the
  // nearest speeds above it (long ramps then stretch the profile to the planned duration).
  double wanted_velocity = desired.velocity_counts_per_s;
  if (ramp_time) {
    const double first_above = (std::floor(acceleration_grid.ramp_from / v_step) + 1.0) * v_step;
    wanted_velocity = std::max(wanted_velocity, first_above);
  }
  const auto velocity_of = [&](std::int64_t n) { return static_cast<double>(n) * v_step; };
  const Bracket velocities{at_or_below_index(wanted_velocity, wanted_velocity / v_step, true, velocity_grid.min_steps,
                                             velocity_grid.max_steps, velocity_of),
                           -1, neighbours, velocity_grid.min_steps, velocity_grid.max_steps};

  std::optional<std::size_t> shared_first;  // share_rates: where the first velocity's ramps start
  std::size_t shared_accelerations = 0;
  std::size_t shared_decelerations = 0;
  for (int jv = 0; jv < velocities.size(); ++jv) {
    const std::int64_t v_native = velocities.index(jv);
    if (v_native == 0) continue;
    const double velocity = velocity_of(v_native);
    if (only_velocity != nullptr && velocity != *only_velocity) continue;
    if (shared_first) {
      visit(v_native, velocity, *shared_first, shared_accelerations, shared_decelerations);
      continue;
    }
    // The speed change a ramp covers (ramp time only).
    const double ramp_span = velocity - acceleration_grid.ramp_from;
    // No ramp (the drive steps to this speed); the relative margin absorbs the rounding of a grid
    // velocity that equals ramp_from.
    if (ramp_time && !(ramp_span > 1e-9 * velocity)) continue;
    const auto realized_acceleration = [&](std::int64_t n) {
      return ramp_time ? ramp_span / (static_cast<double>(n) * a_step) : static_cast<double>(n) * a_step;
    };
    const auto bracket = [&](double wanted) {
      const double guess = ramp_time ? ramp_span / (wanted * a_step) : wanted / a_step;
      return Bracket{at_or_below_index(wanted, guess, !ramp_time, acceleration_grid.min_steps,
                                       acceleration_grid.max_steps, realized_acceleration),
                     ramp_time ? 1 : -1, neighbours, acceleration_grid.min_steps, acceleration_grid.max_steps};
    };
    const std::size_t first = ramps.size();
    const auto append = [&](const Bracket& offered) {
      const std::size_t before = ramps.size();
      for (int j = 0; j < offered.size(); ++j) {
        const std::int64_t n = offered.index(j);
        if (n != 0) ramps.push_back(GridRamp{n, realized_acceleration(n)});
      }
      return ramps.size() - before;
    };
    const std::size_t accelerations = append(bracket(desired.acceleration_counts_per_s2));
    const std::size_t decelerations = append(bracket(desired.deceleration_counts_per_s2));
    if (accelerations == 0 || decelerations == 0) {
      ramps.resize(first);
      // A rate grid's other velocities have the same ramps: none.
      if (share_rates && !ramp_time) return;
      continue;
    }
    if (share_rates && !ramp_time) {
      shared_first = first;
      shared_accelerations = accelerations;
      shared_decelerations = decelerations;
    }
    visit(v_native, velocity, first, accelerations, decelerations);
  }
}

// grid_blocks() expanded into settings (acceleration-major).
void grid_candidates(const VelocityGrid& velocity_grid, const AccelerationGrid& acceleration_grid,
                     const DriveMotion& desired, int neighbours, const double* only_velocity,
                     std::vector<DriveSetting>& out) {
  thread_local std::vector<GridRamp> ramps;
  grid_blocks(velocity_grid, acceleration_grid, desired, neighbours, only_velocity, false, ramps,
              [&](std::int64_t v_native, double velocity, std::size_t first, std::size_t accelerations,
                  std::size_t decelerations) {
                const std::span<const GridRamp> block(ramps.data() + first, accelerations + decelerations);
                for (const GridRamp& a : block.first(accelerations)) {
                  for (const GridRamp& d : block.last(decelerations)) {
                    out.push_back(DriveSetting{NativeMotion{v_native, a.native, d.native},
                                               DriveMotion{velocity, a.counts_per_s2, d.counts_per_s2}});
                  }
                }
                ramps.clear();
              });
}

}  // namespace

void IdentityQuantizer::candidates(const DriveMotion& desired, int /*neighbours*/,
                                   std::vector<DriveSetting>& out) const {
  out.push_back(DriveSetting{NativeMotion{}, desired});
}

GridQuantizer::GridQuantizer(std::string name, VelocityGrid velocity, AccelerationGrid acceleration)
    : name_(std::move(name)), velocity_(velocity), acceleration_(acceleration) {
  require_valid(std::isfinite(velocity_.counts_per_s_per_step) && velocity_.counts_per_s_per_step > 0.0,
                "velocity step must be finite and > 0");
  require_valid(std::isfinite(acceleration_.step) && acceleration_.step > 0.0,
                "acceleration step must be finite and > 0");
  require_valid(valid_range(velocity_.min_steps, velocity_.max_steps), "velocity range must be 1 <= min <= max");
  require_valid(valid_range(acceleration_.min_steps, acceleration_.max_steps),
                "acceleration range must be 1 <= min <= max");
  require_valid(std::isfinite(acceleration_.ramp_from) && acceleration_.ramp_from >= 0.0,
                "ramp start speed must be finite and >= 0");
}

void GridQuantizer::candidates(const DriveMotion& desired, int neighbours, std::vector<DriveSetting>& out) const {
  grid_candidates(velocity_, acceleration_, desired, neighbours, nullptr, out);
}

void GridQuantizer::candidates_at_velocity(const DriveMotion& desired, int neighbours,
                                           std::vector<DriveSetting>& out) const {
  grid_candidates(velocity_, acceleration_, desired, neighbours, &desired.velocity_counts_per_s, out);
}

void GridQuantizer::blocks(const DriveMotion& desired, int neighbours, bool at_velocity, std::vector<GridBlock>& blocks,
                           std::vector<GridRamp>& ramps) const {
  grid_blocks(velocity_, acceleration_, desired, neighbours, at_velocity ? &desired.velocity_counts_per_s : nullptr,
              true, ramps,
              [&](std::int64_t v_native, double velocity, std::size_t first, std::size_t accelerations,
                  std::size_t decelerations) {
                blocks.push_back(GridBlock{v_native, velocity, static_cast<std::uint32_t>(first),
                                           static_cast<std::uint32_t>(accelerations),
                                           static_cast<std::uint32_t>(decelerations)});
              });
}

void DriveQuantizer::candidates_at_velocity(const DriveMotion& desired, int neighbours,
                                            std::vector<DriveSetting>& out) const {
  const std::size_t first = out.size();
  candidates(desired, neighbours, out);
  const auto other_velocity = std::remove_if(
      out.begin() + static_cast<std::ptrdiff_t>(first), out.end(),
      [&](const DriveSetting& s) { return s.realized.velocity_counts_per_s != desired.velocity_counts_per_s; });
  out.erase(other_velocity, out.end());
}

PpsRateQuantizer::PpsRateQuantizer(std::int64_t max_pps, std::int64_t max_pps_per_s)
    : GridQuantizer("pps+pps/s", VelocityGrid{1.0, 1, max_pps},
                    AccelerationGrid{AccelerationGrid::Kind::kRate, 1.0, 1, max_pps_per_s}) {}

PpsRampTimeQuantizer::PpsRampTimeQuantizer(std::int64_t max_pps, std::int64_t max_ramp_ms)
    : GridQuantizer("pps+ramp ms", VelocityGrid{1.0, 1, max_pps},
                    AccelerationGrid{AccelerationGrid::Kind::kRampTime, 0.001, 1, max_ramp_ms}) {}

RpmQuantizer::RpmQuantizer(double counts_per_rev, double rpm_per_step, AccelerationGrid acceleration,
                           std::int64_t max_velocity_steps)
    : GridQuantizer("rpm", VelocityGrid{counts_per_rev * rpm_per_step / 60.0, 1, max_velocity_steps}, acceleration) {}

}  // namespace motion::planner
