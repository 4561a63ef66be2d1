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

// Kept small (16 bytes; the setting stays in the workspace): hundreds of them are sorted per plan.
struct Candidate {
  double duration_s;
  std::uint32_t axis;
  std::uint32_t setting;  // index into the workspace's settings (every axis's, in order)
};

// By duration; equal durations in the order their settings were made (axis by axis, each axis's
// quantizer order), so that a choice among them never depends on the sort.
constexpr auto earlier = [](const Candidate& a, const Candidate& b) {
  return a.duration_s < b.duration_s || (a.duration_s == b.duration_s && a.setting < b.setting);
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
  const double half_inverse_ramps =
      0.5 * (1.0 / planned.acceleration_counts_per_s2 + 1.0 / planned.deceleration_counts_per_s2);
  const double cruise_only_s = distance / velocity;
  if (!(duration_s > cruise_only_s)) return std::nullopt;
  // Trapezoid: distance/v + v * k / lambda = T.
  double lambda = velocity * half_inverse_ramps / (duration_s - cruise_only_s);
  if (velocity * velocity * half_inverse_ramps / lambda > distance) {
    // The ramps do not fit: a triangle, whose duration is sqrt(4 * distance * k / lambda).
    lambda = 4.0 * distance * half_inverse_ramps / (duration_s * duration_s);
  }
  return DriveMotion{velocity, lambda * planned.acceleration_counts_per_s2,
                     lambda * planned.deceleration_counts_per_s2};
}

// Smallest window of the duration-sorted candidates holding at least one candidate of every moving
// axis (classic "smallest range covering k lists", O(M) after the sort). Returns [first, last].
std::pair<std::size_t, std::size_t> tightest_window(const std::vector<Candidate>& sorted, std::size_t axis_count,
                                                    std::size_t moving_count, double planned_duration_s,
                                                    std::vector<std::size_t>& in_window) {
  in_window.assign(axis_count, 0);
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

// The candidates that can be part of the tightest window, in `earlier` order. A window of spread
// at most `bound` (the spread of some covering choice, so at least the tightest one's) fits in two
// adjacent buckets of that width, so only candidates in a bucket that, with a neighbour, holds every
// moving axis are kept (per bucket, the axes present as a bit mask, axis index modulo 64: more
// axes only keep more). The candidates kept are sorted; the window search over them finds what
// it finds over all (every window within the tie margin of the tightest, and every candidate
// inside it, is kept).
// The axes present in one duration bucket; `plan` tells whether it was written by this plan, so
// that the buckets need no clearing between plans.
struct BucketAxes {
  std::uint64_t plan = 0;
  std::uint64_t axes = 0;
};

void tight_candidates(const std::vector<Candidate>& candidates, double shortest, double longest, double bound,
                      std::uint64_t plan_stamp, std::vector<BucketAxes>& bucket_axes, std::vector<Candidate>& sorted) {
  // The width covers the tie margin and the rounding of the bucket index.
  const double width = (bound + 4.0 * kSpreadTieSeconds) * (1.0 + 1e-9) + 1e-300;
  const double range = longest - shortest;
  const std::size_t most = 16 * candidates.size() + 16;
  const double wanted = range / width + 1.0;
  const std::size_t buckets = wanted < static_cast<double>(most) ? static_cast<std::size_t>(wanted) + 1 : most;
  const double per_second = static_cast<double>(buckets) / std::max(range, static_cast<double>(buckets) * width);
  const auto bucket_of = [&](const Candidate& c) {
    return std::min(buckets - 1, static_cast<std::size_t>((c.duration_s - shortest) * per_second)) + 1;
  };
  if (bucket_axes.size() < buckets + 2) bucket_axes.resize(buckets + 2);  // one empty bucket on either side
  const auto axes_in = [&](std::size_t b) { return bucket_axes[b].plan == plan_stamp ? bucket_axes[b].axes : 0; };
  std::uint64_t every_axis = 0;
  for (const Candidate& c : candidates) {
    const std::uint64_t bit = std::uint64_t{1} << (c.axis % 64);
    every_axis |= bit;
    BucketAxes& bucket = bucket_axes[bucket_of(c)];
    bucket.axes = (bucket.plan == plan_stamp ? bucket.axes : 0) | bit;
    bucket.plan = plan_stamp;
  }
  sorted.clear();
  for (const Candidate& c : candidates) {
    const std::size_t b = bucket_of(c);
    const std::uint64_t here = bucket_axes[b].axes;
    if ((here | axes_in(b - 1)) == every_axis || (here | axes_in(b + 1)) == every_axis) sorted.push_back(c);
  }
  std::ranges::sort(sorted, earlier);
}

// Scratch buffers of one thread's plans, reused: planning allocates only for its result once they
// have grown to the largest plan seen.
struct Workspace {
  std::vector<DriveSetting> settings;  // every moving axis's settings, axis after axis
  std::vector<Candidate> candidates;
  std::vector<Candidate> sorted;         // the candidates in `earlier` order
  std::vector<BucketAxes> bucket_axes;   // tight_candidates' axes per bucket
  std::uint64_t plans = 0;               // plans made with this workspace
  std::vector<std::size_t> in_window;    // tightest_window's per-axis counts
  std::vector<const Candidate*> chosen;  // per axis
  std::vector<double> nearest;           // per axis, its duration nearest the planned one (-1: still)
};

Workspace& thread_workspace() {
  thread_local Workspace workspace;
  return workspace;
}

}  // namespace

namespace {

// append_axis_candidates() before the filter by the axis's hard limits.
void axis_settings(const SyncPlan& plan, std::size_t axis, const DriveQuantizer& quantizer,
                   const QuantizeOptions& options, const AxisCaps& caps, std::vector<DriveSetting>& out) {
  const AxisProfile& planned = plan.axes[axis];
  const DriveMotion desired = desired_motion(planned.shape, caps);
  const std::size_t first = out.size();
  quantizer.candidates(desired, options.neighbours, out);
  if (!options.match_duration) return;
  // One more round per representable velocity, around its duration-matching ramps: the velocities
  // of the first round in increasing order, each once (a grid gives them grouped and in order).
  thread_local std::vector<double> velocities;
  velocities.clear();
  for (std::size_t k = first; k < out.size(); ++k) {
    const double v = out[k].realized.velocity_counts_per_s;
    if (velocities.empty() || velocities.back() != v) velocities.push_back(v);
  }
  if (!std::ranges::is_sorted(velocities, std::ranges::less_equal{})) {
    std::ranges::sort(velocities);
    const auto [duplicates, end] = std::ranges::unique(velocities);
    velocities.erase(duplicates, end);
  }
  const double distance = std::abs(static_cast<double>(planned.distance_counts()));
  for (const double velocity : velocities) {
    const auto matching = duration_matching(distance, plan.duration_s(), velocity, desired);
    if (!matching) continue;
    // The ramps were fitted to this velocity only; its neighbours are already in the first round.
    quantizer.candidates_at_velocity(
        DriveMotion{velocity, std::min(matching->acceleration_counts_per_s2, caps.acceleration),
                    std::min(matching->deceleration_counts_per_s2, caps.deceleration)},
        options.neighbours, out);
  }
}

}  // namespace

void append_axis_candidates(const SyncPlan& plan, std::size_t axis, const DriveQuantizer& quantizer,
                            const QuantizeOptions& options, std::vector<DriveSetting>& out) {
  if (plan.axes[axis].is_still()) return;
  const AxisCaps caps = hard_limits(plan, static_cast<Eigen::Index>(axis));
  const std::size_t first = out.size();
  axis_settings(plan, axis, quantizer, options, caps, out);
  const auto kept = std::remove_if(out.begin() + static_cast<std::ptrdiff_t>(first), out.end(),
                                   [&](const DriveSetting& s) { return !within(s.realized, caps); });
  out.erase(kept, out.end());
}

Result<QuantizedPlan> quantize_plan(const SyncPlan& plan, std::span<const DriveQuantizer* const> quantizers,
                                    const QuantizeOptions& options) {
  const std::size_t axis_count = plan.axes.size();
  if (quantizers.size() != axis_count || std::ranges::find(quantizers, nullptr) != quantizers.end()) {
    return PlanFailure{PlanErrc::kQuantizerCountMismatch,
                       kNoAxis,
                       {},
                       static_cast<double>(quantizers.size()),
                       static_cast<double>(axis_count)};
  }

  QuantizedPlan out;
  out.planned_duration_s = plan.duration_s();
  out.axes.resize(axis_count);
  Workspace& w = thread_workspace();
  w.settings.clear();
  w.candidates.clear();
  w.nearest.assign(axis_count, -1.0);
  std::size_t moving_count = 0;
  double shortest = std::numeric_limits<double>::infinity();
  double longest = 0.0;
  for (std::size_t i = 0; i < axis_count; ++i) {
    const AxisProfile& planned = plan.axes[i];
    out.axes[i].profile = AxisProfile{planned.start_counts, planned.target_counts, {}};
    if (planned.is_still()) continue;
    ++moving_count;
    const double distance = std::abs(static_cast<double>(planned.distance_counts()));
    const AxisCaps caps = hard_limits(plan, static_cast<Eigen::Index>(i));
    const std::size_t settings_first = w.settings.size();
    const std::size_t candidates_first = w.candidates.size();
    axis_settings(plan, i, *quantizers[i], options, caps, w.settings);
    // The settings within the hard limits, each with the duration the drive's own trapezoid takes.
    const std::size_t settings_end = w.settings.size();
    w.candidates.resize(candidates_first + (settings_end - settings_first));
    Candidate* next = w.candidates.data() + candidates_first;
    const double planned_s = out.planned_duration_s;
    double nearest = -1.0;
    for (std::size_t k = settings_first; k < settings_end; ++k) {
      const DriveMotion& realized = w.settings[k].realized;
      if (!within(realized, caps)) continue;
      const TrapezoidShape shape =
          time_optimal_shape(distance, realized.velocity_counts_per_s, realized.acceleration_counts_per_s2,
                             realized.deceleration_counts_per_s2);
      const double duration_s = shape.duration_s();
      shortest = std::min(shortest, duration_s);
      longest = std::max(longest, duration_s);
      if (nearest < 0.0 || std::abs(duration_s - planned_s) < std::abs(nearest - planned_s)) nearest = duration_s;
      *next++ = Candidate{duration_s, static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(k)};
    }
    w.nearest[i] = nearest;
    w.candidates.resize(static_cast<std::size_t>(next - w.candidates.data()));
    if (w.candidates.size() == candidates_first) {
      return PlanFailure{PlanErrc::kQuantizationImpossible, i, plan.axis_names[i],
                         desired_motion(planned.shape, caps).velocity_counts_per_s, caps.velocity};
    }
  }
  if (moving_count == 0) return out;

  // A first covering choice: per axis the candidate nearest the planned duration.
  double nearest_shortest = std::numeric_limits<double>::infinity();
  double nearest_longest = 0.0;
  for (std::size_t i = 0; i < axis_count; ++i) {
    if (w.nearest[i] < 0.0) continue;
    nearest_shortest = std::min(nearest_shortest, w.nearest[i]);
    nearest_longest = std::max(nearest_longest, w.nearest[i]);
  }
  tight_candidates(w.candidates, shortest, longest, nearest_longest - nearest_shortest, ++w.plans, w.bucket_axes,
                   w.sorted);
  const std::vector<Candidate>& candidates = w.sorted;
  const auto [first, last] = tightest_window(candidates, axis_count, moving_count, out.planned_duration_s, w.in_window);
  // Every axis has a candidate in the window; within it, take the one nearest the window centre.
  const double centre = 0.5 * (candidates[first].duration_s + candidates[last].duration_s);
  w.chosen.assign(axis_count, nullptr);
  for (std::size_t k = first; k <= last; ++k) {
    const Candidate& c = candidates[k];
    const Candidate*& best = w.chosen[c.axis];
    if (best == nullptr || std::abs(c.duration_s - centre) < std::abs(best->duration_s - centre)) best = &c;
  }
  for (std::size_t i = 0; i < axis_count; ++i) {
    if (w.chosen[i] == nullptr) continue;
    RealizedAxis& axis = out.axes[i];
    axis.setting = w.settings[w.chosen[i]->setting];
    const DriveMotion& realized = axis.setting->realized;
    axis.profile =
        time_optimal_profile(axis.profile.start_counts, axis.profile.target_counts, realized.velocity_counts_per_s,
                             realized.acceleration_counts_per_s2, realized.deceleration_counts_per_s2);
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
