#include "motion/planner/quantize_plan.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

namespace motion::planner {
namespace {

// Spreads closer than this are equal; the tie goes to the window nearest the planned duration.
constexpr double kSpreadTieSeconds = 1e-12;

// Kept small (16 bytes; the setting itself is regenerated for the winner only): thousands of them
// are sorted per plan and must stay in cache.
struct Candidate {
  double duration_s;
  std::uint32_t axis;
  std::uint32_t setting;  // index into the axis's append_axis_candidates()
};

struct AxisCaps {
  double velocity;
  double acceleration;
  double deceleration;
};

AxisCaps hard_limits(const SyncPlan& plan, Eigen::Index i) {
  return {plan.velocity_limit_counts_per_s[i], plan.acceleration_limit_counts_per_s2[i],
          plan.deceleration_limit_counts_per_s2[i]};
}

bool usable(double value, double limit) { return std::isfinite(value) && value > 0.0 && value <= limit; }

bool within(const DriveMotion& motion, const AxisCaps& caps) {
  return usable(motion.velocity_counts_per_s, caps.velocity) &&
         usable(motion.acceleration_counts_per_s2, caps.acceleration) &&
         usable(motion.deceleration_counts_per_s2, caps.deceleration);
}

// The plan's values, capped to the limits they may exceed by a rounding ulp of the scaling.
DriveMotion desired_motion(const TrapezoidShape& shape, const AxisCaps& caps) {
  return {std::min(shape.peak_velocity, caps.velocity), std::min(shape.acceleration, caps.acceleration),
          std::min(shape.deceleration, caps.deceleration)};
}

// The acceleration/deceleration (in the planned ratio) with which a drive cruising at `velocity`
// covers `distance` in exactly `duration_s`; nullopt when even infinite ramps would be too slow.
std::optional<DriveMotion> duration_matching(double distance, double duration_s, double velocity,
                                             const DriveMotion& planned) {
  // Ramp time per unit velocity at scale 1: (1/a + 1/d) / 2; scaling both ramps by `lambda`
  // divides it by lambda.
  const double half_inverse_ramps = 0.5 * (1.0 / planned.acceleration_counts_per_s2 +
                                           1.0 / planned.deceleration_counts_per_s2);
  const double cruise_only_s = distance / velocity;
  if (!(duration_s > cruise_only_s)) return std::nullopt;
  // Trapezoid: distance/v + v * k / lambda = T.
  double lambda = velocity * half_inverse_ramps / (duration_s - cruise_only_s);
  if (velocity * velocity * half_inverse_ramps / lambda > distance) {
    // The ramps do not fit: a triangle, whose duration is sqrt(4 * distance * k / lambda).
    lambda = 4.0 * distance * half_inverse_ramps / (duration_s * duration_s);
  }
  return DriveMotion{velocity, lambda * planned.acceleration_counts_per_s2, lambda * planned.deceleration_counts_per_s2};
}

// Smallest window of the duration-sorted candidates holding at least one candidate of every moving
// axis (classic "smallest range covering k lists", O(M) after the sort). Returns [first, last].
std::pair<std::size_t, std::size_t> tightest_window(const std::vector<Candidate>& sorted, std::size_t axis_count,
                                                    std::size_t moving_count, double planned_duration_s) {
  std::vector<std::size_t> in_window(axis_count, 0);
  std::size_t covered = 0;
  std::size_t first = 0;
  std::pair<std::size_t, std::size_t> best{0, sorted.size() - 1};
  double best_spread = std::numeric_limits<double>::infinity();
  double best_offset = std::numeric_limits<double>::infinity();
  for (std::size_t last = 0; last < sorted.size(); ++last) {
    if (in_window[sorted[last].axis]++ == 0) ++covered;
    while (covered == moving_count) {
      const double spread = sorted[last].duration_s - sorted[first].duration_s;
      const double offset = std::abs(0.5 * (sorted[last].duration_s + sorted[first].duration_s) - planned_duration_s);
      if (spread < best_spread - kSpreadTieSeconds ||
          (spread <= best_spread + kSpreadTieSeconds && offset < best_offset)) {
        best = {first, last};
        best_spread = std::min(spread, best_spread);
        best_offset = offset;
      }
      if (--in_window[sorted[first].axis] == 0) --covered;
      ++first;
    }
  }
  return best;
}

}  // namespace

void append_axis_candidates(const SyncPlan& plan, std::size_t axis, const DriveQuantizer& quantizer,
                            const QuantizeOptions& options, std::vector<DriveSetting>& out) {
  const AxisProfile& planned = plan.axes[axis];
  if (planned.is_still()) return;
  const AxisCaps caps = hard_limits(plan, static_cast<Eigen::Index>(axis));
  const DriveMotion desired = desired_motion(planned.shape, caps);
  const std::size_t first = out.size();
  quantizer.candidates(desired, options.neighbours, out);
  if (options.match_duration) {
    // One more round per representable velocity, around its duration-matching ramps.
    const double distance = std::abs(static_cast<double>(planned.distance_counts()));
    std::vector<double> velocities;
    for (std::size_t k = first; k < out.size(); ++k) velocities.push_back(out[k].realized.velocity_counts_per_s);
    std::ranges::sort(velocities);
    const auto [duplicates, end] = std::ranges::unique(velocities);
    velocities.erase(duplicates, end);
    for (const double velocity : velocities) {
      const auto matching = duration_matching(distance, plan.duration_s(), velocity, desired);
      if (!matching) continue;
      const std::size_t round_first = out.size();
      quantizer.candidates(DriveMotion{velocity, std::min(matching->acceleration_counts_per_s2, caps.acceleration),
                                       std::min(matching->deceleration_counts_per_s2, caps.deceleration)},
                           options.neighbours, out);
      // The ramps were fitted to this velocity only; its neighbours are already in the first round.
      const auto other_velocity = std::remove_if(
          out.begin() + static_cast<std::ptrdiff_t>(round_first), out.end(),
          [velocity](const DriveSetting& s) { return s.realized.velocity_counts_per_s != velocity; });
      out.erase(other_velocity, out.end());
    }
  }
  const auto kept = std::remove_if(out.begin() + static_cast<std::ptrdiff_t>(first), out.end(),
                                   [&](const DriveSetting& s) { return !within(s.realized, caps); });
  out.erase(kept, out.end());
}

Result<QuantizedPlan> quantize_plan(const SyncPlan& plan, std::span<const DriveQuantizer* const> quantizers,
                                    const QuantizeOptions& options) {
  const std::size_t axis_count = plan.axes.size();
  if (quantizers.size() != axis_count || std::ranges::find(quantizers, nullptr) != quantizers.end()) {
    return PlanFailure{PlanErrc::quantizer_count_mismatch, kNoAxis, {}, static_cast<double>(quantizers.size()),
                       static_cast<double>(axis_count)};
  }

  QuantizedPlan out;
  out.planned_duration_s = plan.duration_s();
  out.axes.resize(axis_count);
  std::vector<Candidate> candidates;
  std::vector<DriveSetting> settings;  // scratch, one axis at a time
  const auto generate = [&](std::size_t axis) {
    settings.clear();
    append_axis_candidates(plan, axis, *quantizers[axis], options, settings);
  };
  std::size_t moving_count = 0;
  for (std::size_t i = 0; i < axis_count; ++i) {
    const AxisProfile& planned = plan.axes[i];
    out.axes[i].profile = AxisProfile{planned.start_counts, planned.target_counts, {}};
    if (planned.is_still()) continue;
    ++moving_count;
    const double distance = std::abs(static_cast<double>(planned.distance_counts()));
    generate(i);
    if (settings.empty()) {
      const AxisCaps caps = hard_limits(plan, static_cast<Eigen::Index>(i));
      return PlanFailure{PlanErrc::quantization_impossible, i, plan.axis_names[i],
                         desired_motion(planned.shape, caps).velocity_counts_per_s, caps.velocity};
    }
    const std::size_t axis_first = candidates.size();
    for (std::size_t k = 0; k < settings.size(); ++k) {
      const DriveMotion& realized = settings[k].realized;
      const TrapezoidShape shape = time_optimal_shape(distance, realized.velocity_counts_per_s,
                                                      realized.acceleration_counts_per_s2,
                                                      realized.deceleration_counts_per_s2);
      candidates.push_back(Candidate{shape.duration_s(), static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(k)});
    }
    // Equal durations of one axis are interchangeable (the rounds overlap): keep one of each, so
    // that the global sort below handles a fraction of the settings.
    const auto axis_candidates = std::ranges::subrange(candidates.begin() + static_cast<std::ptrdiff_t>(axis_first),
                                                       candidates.end());
    std::ranges::sort(axis_candidates, {}, &Candidate::duration_s);
    const auto duplicates = std::ranges::unique(axis_candidates, {}, &Candidate::duration_s);
    candidates.erase(duplicates.begin(), duplicates.end());
  }
  if (moving_count == 0) return out;

  std::ranges::sort(candidates, {}, &Candidate::duration_s);  // a merge of sorted runs
  const auto [first, last] = tightest_window(candidates, axis_count, moving_count, out.planned_duration_s);
  // Every axis has a candidate in the window; within it, take the one nearest the window centre.
  const double centre = 0.5 * (candidates[first].duration_s + candidates[last].duration_s);
  std::vector<const Candidate*> chosen(axis_count, nullptr);
  for (std::size_t k = first; k <= last; ++k) {
    const Candidate& c = candidates[k];
    const Candidate*& best = chosen[c.axis];
    if (best == nullptr || std::abs(c.duration_s - centre) < std::abs(best->duration_s - centre)) best = &c;
  }
  for (std::size_t i = 0; i < axis_count; ++i) {
    if (chosen[i] == nullptr) continue;
    generate(i);
    RealizedAxis& axis = out.axes[i];
    axis.setting = settings[chosen[i]->setting];
    const DriveMotion& realized = axis.setting->realized;
    axis.profile = time_optimal_profile(axis.profile.start_counts, axis.profile.target_counts,
                                        realized.velocity_counts_per_s, realized.acceleration_counts_per_s2,
                                        realized.deceleration_counts_per_s2);
  }
  out.earliest_arrival_s = std::numeric_limits<double>::infinity();
  out.latest_arrival_s = 0.0;
  for (const RealizedAxis& axis : out.axes) {
    if (!axis.setting) continue;
    out.earliest_arrival_s = std::min(out.earliest_arrival_s, axis.duration_s());
    out.latest_arrival_s = std::max(out.latest_arrival_s, axis.duration_s());
  }
  return out;
}

}  // namespace motion::planner
