#include "motion/planner/quantize_plan.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>

namespace motion::planner {
namespace {

// Spreads closer than this are equal; the tie goes to the window nearest the planned duration.
constexpr double kSpreadTieSeconds = 1e-12;

// Kept small (16 bytes; the setting stays in the workspace): hundreds of them are sorted per plan.
// Default construction leaves it uninitialized: buffers of them are resized, then written.
struct Candidate {
  Candidate() {}  // NOLINT(modernize-use-equals-default): "= default" would zero them in resize()
  Candidate(double duration, std::uint32_t axis_index, std::uint32_t setting_key)
      : duration_s(duration), axis(axis_index), setting(setting_key) {}
  double duration_s;
  std::uint32_t axis;
  // The setting: block index (in the workspace's blocks, every axis's in order), then the
  // acceleration and deceleration within the block; increasing in the order settings were made.
  std::uint32_t setting;
};
constexpr unsigned kRampBits = 4;
constexpr std::uint32_t kRampMask = (1U << kRampBits) - 1;
constexpr unsigned kBlockShift = 2 * kRampBits;
constexpr std::size_t kMaxBlocks = std::size_t{1} << (32 - kBlockShift);
constexpr std::size_t kMaxBlockRamps = kRampMask;  // 2 * neighbours + 1 ramps of each kind
constexpr int kMaxBlockNeighbours = static_cast<int>(kMaxBlockRamps - 1) / 2;

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

// Ramp time per unit velocity at scale 1: (1/a + 1/d) / 2; scaling both ramps by `lambda`
// divides it by lambda.
double half_inverse_ramps(const DriveMotion& planned) {
  return 0.5 * (1.0 / planned.acceleration_counts_per_s2 + 1.0 / planned.deceleration_counts_per_s2);
}

// The acceleration/deceleration (in the planned ratio) with which a drive cruising at `velocity`
// covers `distance` in exactly `duration_s`; nullopt when even infinite ramps would be too slow.
// `half_inverse_ramps` is half_inverse_ramps(planned).
std::optional<DriveMotion> duration_matching(double distance, double duration_s, double velocity,
                                             const DriveMotion& planned, double half_inverse_ramps) {
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
// at most `bound` (the spread of some covering choice, so at least the tightest one's) holds a
// candidate of every axis, so it lies within [that axis's shortest - bound, its longest + bound]
// for every axis; and it fits in two adjacent buckets of that width, so only candidates in that
// interval and in a bucket that, with a neighbour, holds every moving axis are kept (per bucket,
// the axes present as a bit mask, axis index modulo 64: more axes only keep more). The candidates
// kept are sorted; the window search over them finds what it finds over all (every window within
// the tie margin of the tightest, and every candidate inside it, is kept).
// The axes present in one duration bucket; `plan` tells whether it was written by this plan, so
// that the buckets need no clearing between plans.
struct BucketAxes {
  std::uint64_t plan = 0;
  std::uint64_t axes = 0;
};

// Sorts candidates into `earlier` order, `spare` as scratch. They come in setting order, so a
// stable distribution by the leading bits of their durations (positive doubles order as their bit
// patterns) leaves only candidates with the same leading bits out of order, which are then sorted
// among themselves (a few by insertion): fewer mispredicted comparisons than one sort of all.
// Every duration lies within [shortest_s, longest_s] (both >= 0).
void sort_by_duration(std::vector<Candidate>& candidates, std::vector<Candidate>& spare, double shortest_s,
                      double longest_s) {
  constexpr std::size_t kComparisonSortBelow = 32;
  if (candidates.size() < kComparisonSortBelow) {
    std::ranges::sort(candidates, earlier);
    return;
  }
  const auto bits = [](const Candidate& c) { return std::bit_cast<std::uint64_t>(c.duration_s); };
  const auto lowest = std::bit_cast<std::uint64_t>(shortest_s);
  const auto highest = std::bit_cast<std::uint64_t>(longest_s);
  // About one digit per two candidates: few per digit, and few digits to clear and visit.
  constexpr int kMostDigitBits = 11;
  const int digit_bits = std::clamp(static_cast<int>(std::bit_width(candidates.size())) - 1, 4, kMostDigitBits);
  const std::size_t digits = std::size_t{1} << digit_bits;
  const int shift = std::max(0, static_cast<int>(std::bit_width(highest - lowest)) - digit_bits);
  const auto digit = [&](const Candidate& c) { return static_cast<std::size_t>((bits(c) - lowest) >> shift); };
  std::array<std::uint32_t, (std::size_t{1} << kMostDigitBits) + 1> start;  // NOLINT: the first digits + 1 cleared
  std::fill_n(start.begin(), digits + 1, 0U);
  for (const Candidate& c : candidates) ++start[digit(c) + 1];
  for (std::size_t d = 1; d <= digits; ++d) start[d] += start[d - 1];
  // As much room as `candidates` has: they are swapped below, and the caller's next plan must find
  // room in either (else one of them would grow again, allocating, plan after plan until both had).
  spare.reserve(candidates.capacity());
  spare.resize(candidates.size());
  for (const Candidate& c : candidates) spare[start[digit(c)]++] = c;
  candidates.swap(spare);
  // start[d] is now where digit d's candidates end. A few are put in order by insertion; a
  // cluster (many durations within one digit) by a comparison sort.
  constexpr std::size_t kInsertionUpTo = 8;
  std::size_t begin = 0;
  for (std::size_t d = 0; d < digits; ++d) {
    const std::size_t end = start[d];
    if (end - begin > kInsertionUpTo) {
      std::sort(candidates.begin() + static_cast<std::ptrdiff_t>(begin),
                candidates.begin() + static_cast<std::ptrdiff_t>(end), earlier);
    } else {
      for (std::size_t k = begin + 1; k < end; ++k) {
        const Candidate c = candidates[k];
        std::size_t j = k;
        for (; j > begin && earlier(c, candidates[j - 1]); --j) candidates[j] = candidates[j - 1];
        candidates[j] = c;
      }
    }
    begin = end;
  }
}

// The durations of all candidates: over all axes, and the extremes of the axes' own ranges.
struct DurationRange {
  double shortest = std::numeric_limits<double>::infinity();
  double longest = 0.0;
  double latest_shortest = 0.0;                                       // the largest of the axes' shortest durations
  double earliest_longest = std::numeric_limits<double>::infinity();  // the smallest of their longest
};

void tight_candidates(const std::vector<Candidate>& candidates, const DurationRange& durations, double bound,
                      std::uint64_t every_axis, std::uint64_t plan_stamp, std::vector<BucketAxes>& bucket_axes,
                      std::vector<Candidate>& sorted, std::vector<Candidate>& spare) {
  // The width covers the tie margin and the rounding of the bucket index.
  const double width = (bound + 4.0 * kSpreadTieSeconds) * (1.0 + 1e-9) + 1e-300;
  const double shortest = std::max(durations.shortest, durations.latest_shortest - width);
  const double longest = std::min(durations.longest, durations.earliest_longest + width);
  const auto inside = [&](const Candidate& c) { return c.duration_s >= shortest && c.duration_s <= longest; };
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
  // Those inside the interval, then those of them in a bucket that with a neighbour holds every
  // axis, compacted without branches.
  sorted.resize(candidates.size());
  std::size_t count = 0;
  for (const Candidate& c : candidates) {
    sorted[count] = c;
    count += inside(c) ? 1U : 0U;
  }
  sorted.resize(count);
  // Over three buckets at most, the passes below would drop few if any: skipped (the window search
  // finds the same window with or without the candidates they drop).
  if (buckets <= 3) {
    sort_by_duration(sorted, spare, shortest, longest);
    return;
  }
  for (const Candidate& c : sorted) {
    BucketAxes& bucket = bucket_axes[bucket_of(c)];
    bucket.axes = (bucket.plan == plan_stamp ? bucket.axes : 0) | (std::uint64_t{1} << (c.axis % 64));
    bucket.plan = plan_stamp;
  }
  std::size_t kept = 0;
  for (const Candidate& c : sorted) {
    const std::size_t b = bucket_of(c);
    const std::uint64_t here = bucket_axes[b].axes;
    sorted[kept] = c;
    kept += (here | axes_in(b - 1)) == every_axis || (here | axes_in(b + 1)) == every_axis ? 1U : 0U;
  }
  sorted.resize(kept);
  sort_by_duration(sorted, spare, shortest, longest);
}

// Scratch buffers of one thread's plans, reused: planning allocates only for its result once they
// have grown to the largest plan seen.
struct Workspace {
  std::vector<GridBlock> blocks;       // every moving axis's settings, axis after axis, in blocks
  std::vector<GridRamp> ramps;         // the blocks' ramps
  std::vector<DriveSetting> settings;  // a quantizer's settings before they become blocks
  std::vector<double> velocities;      // an axis's first-round velocities
  std::vector<Candidate> candidates;
  std::vector<Candidate> sorted;         // the candidates in `earlier` order
  std::vector<Candidate> spare;          // sort_by_duration's scratch
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

// The second round of QuantizeOptions::match_duration: for every velocity of the first round
// (`velocities`, as offered), in increasing order and each once, the ramps that make the axis
// arrive at the planned duration with it, passed to `round(desired)`.
template <typename Round>
void matching_round(const SyncPlan& plan, std::size_t axis, const DriveMotion& desired, const AxisCaps& caps,
                    std::vector<double>& velocities, Round&& round) {
  if (!std::ranges::is_sorted(velocities, std::ranges::less_equal{})) {
    std::ranges::sort(velocities);
    // std::unique rather than std::ranges::unique: clang 14 (clang-tidy) cannot instantiate the
    // subrange libstdc++ 12 returns from it.
    velocities.erase(std::unique(velocities.begin(), velocities.end()), velocities.end());
  }
  const double distance = std::abs(static_cast<double>(plan.axes[axis].distance_counts()));
  const double ramp_time_per_velocity = half_inverse_ramps(desired);
  for (const double velocity : velocities) {
    const auto matching = duration_matching(distance, plan.duration_s(), velocity, desired, ramp_time_per_velocity);
    if (!matching) continue;
    // The ramps were fitted to this velocity only; its neighbours are already in the first round.
    round(DriveMotion{velocity, std::min(matching->acceleration_counts_per_s2, caps.acceleration),
                      std::min(matching->deceleration_counts_per_s2, caps.deceleration)});
  }
}

// append_axis_candidates() before the filter by the axis's hard limits.
void axis_settings(const SyncPlan& plan, std::size_t axis, const DriveQuantizer& quantizer,
                   const QuantizeOptions& options, const AxisCaps& caps, std::vector<DriveSetting>& out) {
  const DriveMotion desired = desired_motion(plan.axes[axis].shape, caps);
  const std::size_t first = out.size();
  quantizer.candidates(desired, options.neighbours, out);
  if (!options.match_duration) return;
  // The velocities of the first round, each once (a grid gives them grouped and in order).
  thread_local std::vector<double> velocities;
  velocities.clear();
  for (std::size_t k = first; k < out.size(); ++k) {
    const double v = out[k].realized.velocity_counts_per_s;
    if (velocities.empty() || velocities.back() != v) velocities.push_back(v);
  }
  matching_round(plan, axis, desired, caps, velocities,
                 [&](const DriveMotion& wanted) { quantizer.candidates_at_velocity(wanted, options.neighbours, out); });
}

// axis_settings() of a grid, as blocks: the same settings in the same order.
void axis_blocks(const SyncPlan& plan, std::size_t axis, const GridQuantizer& grid, const QuantizeOptions& options,
                 const AxisCaps& caps, Workspace& w) {
  const DriveMotion desired = desired_motion(plan.axes[axis].shape, caps);
  const std::size_t first = w.blocks.size();
  grid.blocks(desired, options.neighbours, false, w.blocks, w.ramps);
  if (!options.match_duration) return;
  w.velocities.clear();
  for (std::size_t k = first; k < w.blocks.size(); ++k) w.velocities.push_back(w.blocks[k].velocity_counts_per_s);
  matching_round(plan, axis, desired, caps, w.velocities,
                 [&](const DriveMotion& wanted) { grid.blocks(wanted, options.neighbours, true, w.blocks, w.ramps); });
}

// Any quantizer's settings (axis_settings()) as blocks of one setting each.
void axis_setting_blocks(const SyncPlan& plan, std::size_t axis, const DriveQuantizer& quantizer,
                         const QuantizeOptions& options, const AxisCaps& caps, Workspace& w) {
  w.settings.clear();
  axis_settings(plan, axis, quantizer, options, caps, w.settings);
  for (const DriveSetting& s : w.settings) {
    w.blocks.push_back(GridBlock{s.native.velocity, s.realized.velocity_counts_per_s,
                                 static_cast<std::uint32_t>(w.ramps.size()), 1, 1});
    w.ramps.push_back(GridRamp{s.native.acceleration, s.realized.acceleration_counts_per_s2});
    w.ramps.push_back(GridRamp{s.native.deceleration, s.realized.deceleration_counts_per_s2});
  }
}

// What the candidates of one axis's blocks have come to.
struct AxisDurations {
  double nearest = -1.0;  // the duration nearest the planned one, -1 when no setting is usable
  double shortest = std::numeric_limits<double>::infinity();
  double longest = 0.0;
};

// A ramp of a block, evaluated at the block's velocity: the terms of time_optimal_shape that
// depend on it alone.
struct RampTerms {
  double rate;
  double inverse;  // 1 / rate
  double time;     // velocity / rate
  bool usable;
};

std::size_t ramp_terms(const GridRamp* ramps, std::size_t count, double velocity, double limit, RampTerms* out) {
  std::size_t usable_count = 0;
  for (std::size_t j = 0; j < count; ++j) {
    const double rate = ramps[j].counts_per_s2;
    out[j].rate = rate;
    out[j].usable = usable(rate, limit);
    if (!out[j].usable) continue;
    out[j].inverse = 1.0 / rate;
    out[j].time = velocity / rate;
    ++usable_count;
  }
  return usable_count;
}

// The same terms at another velocity (ramps shared by the blocks of a rate grid).
void ramp_times(std::size_t count, double velocity, RampTerms* terms) {
  for (std::size_t j = 0; j < count; ++j) {
    if (terms[j].usable) terms[j].time = velocity / terms[j].rate;
  }
}

// Appends to w.candidates every setting of blocks [first, w.blocks.size()) within `caps`, with the
// duration of the drive's own trapezoid over `distance`: time_optimal_shape(...).duration_s() bit
// for bit (the same operations in the same order), but each ramp's reciprocal and ramp time
// computed once per block rather than once per setting.
AxisDurations evaluate_blocks(Workspace& w, std::size_t first, std::uint32_t axis, double distance,
                              const AxisCaps& caps, double planned_s) {
  // Kept in locals (registers), not in the result: they are updated for every setting.
  double nearest = -1.0;
  double shortest = std::numeric_limits<double>::infinity();
  double longest = 0.0;
  double nearest_offset = 0.0;  // |nearest - planned_s|
  // Written in place: room for every setting, cut back to those within the caps at the end.
  const std::size_t before = w.candidates.size();
  std::size_t most = before;
  for (std::size_t k = first; k < w.blocks.size(); ++k) {
    most += std::size_t{w.blocks[k].accelerations} * w.blocks[k].decelerations;
  }
  w.candidates.resize(most);
  Candidate* next = w.candidates.data() + before;
  // Not cleared: ramp_terms() writes a block's before any is read.
  std::array<RampTerms, kMaxBlockRamps> accelerations;  // NOLINT(cppcoreguidelines-pro-type-member-init)
  std::array<RampTerms, kMaxBlockRamps> decelerations;  // NOLINT(cppcoreguidelines-pro-type-member-init)
  // The terms above are those of the ramps at w.ramps[terms_of ...]; a block that shares them
  // (same first ramp: a rate grid's) recomputes only the ramp times.
  std::uint32_t terms_of = std::numeric_limits<std::uint32_t>::max();
  std::size_t usable_accelerations = 0;
  std::size_t usable_decelerations = 0;
  for (std::size_t k = first; k < w.blocks.size(); ++k) {
    const GridBlock& block = w.blocks[k];
    const double v = block.velocity_counts_per_s;
    if (!usable(v, caps.velocity)) continue;
    if (block.first_ramp != terms_of) {
      terms_of = block.first_ramp;
      const GridRamp* ramps = w.ramps.data() + block.first_ramp;
      usable_accelerations = ramp_terms(ramps, block.accelerations, v, caps.acceleration, accelerations.data());
      usable_decelerations = usable_accelerations == 0 ? 0
                                                       : ramp_terms(ramps + block.accelerations, block.decelerations, v,
                                                                    caps.deceleration, decelerations.data());
    } else if (usable_accelerations != 0 && usable_decelerations != 0) {
      ramp_times(block.accelerations, v, accelerations.data());
      ramp_times(block.decelerations, v, decelerations.data());
    }
    if (usable_accelerations == 0 || usable_decelerations == 0) continue;
    const double half_v_squared = 0.5 * v * v;
    const auto key = static_cast<std::uint32_t>(k << kBlockShift);
    for (std::uint32_t ja = 0; ja < block.accelerations; ++ja) {
      const RampTerms& a = accelerations[ja];
      if (!a.usable) continue;
      for (std::uint32_t jd = 0; jd < block.decelerations; ++jd) {
        const RampTerms& d = decelerations[jd];
        if (!d.usable) continue;
        const double ramps_distance = half_v_squared * (a.inverse + d.inverse);
        const double duration_s = ramps_distance <= distance
                                      ? a.time + (distance - ramps_distance) / v + d.time
                                      : time_optimal_shape(distance, v, a.rate, d.rate).duration_s();
        // A setting too slow for its duration to be a number (a velocity scaled down to a
        // denormal: the distance over it overflows) is no candidate.
        if (!std::isfinite(duration_s)) continue;
        shortest = std::min(shortest, duration_s);
        longest = std::max(longest, duration_s);
        const double offset = std::abs(duration_s - planned_s);
        // Both compared (no short circuit): a select, not a branch the data decides.
        const bool nearer = (nearest < 0.0) | (offset < nearest_offset);
        nearest = nearer ? duration_s : nearest;
        nearest_offset = nearer ? offset : nearest_offset;
        *next++ = Candidate{duration_s, axis, key | (ja << kRampBits) | jd};
      }
    }
  }
  w.candidates.resize(static_cast<std::size_t>(next - w.candidates.data()));
  return {nearest, shortest, longest};
}

// The setting a candidate stands for.
DriveSetting setting_of(const Workspace& w, const Candidate& c) {
  const GridBlock& block = w.blocks[c.setting >> kBlockShift];
  const GridRamp& a = w.ramps[block.first_ramp + ((c.setting >> kRampBits) & kRampMask)];
  const GridRamp& d = w.ramps[block.first_ramp + block.accelerations + (c.setting & kRampMask)];
  return DriveSetting{NativeMotion{block.velocity_native, a.native, d.native},
                      DriveMotion{block.velocity_counts_per_s, a.counts_per_s2, d.counts_per_s2}};
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
  QuantizedPlan out;
  if (auto failure = quantize_plan_into(plan, quantizers, out, options)) return *std::move(failure);
  return out;
}

std::optional<PlanFailure> quantize_plan_into(const SyncPlan& plan, std::span<const DriveQuantizer* const> quantizers,
                                              QuantizedPlan& out, const QuantizeOptions& options) {
  const std::size_t axis_count = plan.axes.size();
  if (quantizers.size() != axis_count || std::ranges::find(quantizers, nullptr) != quantizers.end()) {
    return PlanFailure{PlanErrc::kQuantizerCountMismatch,
                       kNoAxis,
                       {},
                       static_cast<double>(quantizers.size()),
                       static_cast<double>(axis_count)};
  }

  out.planned_duration_s = plan.duration_s();
  out.earliest_arrival_s = 0.0;
  out.latest_arrival_s = 0.0;
  out.axes.assign(axis_count, RealizedAxis{});
  Workspace& w = thread_workspace();
  w.blocks.clear();
  w.ramps.clear();
  w.candidates.clear();
  w.nearest.assign(axis_count, -1.0);
  std::size_t moving_count = 0;
  std::uint64_t every_axis = 0;  // the moving axes, index modulo 64 (tight_candidates' masks)
  DurationRange range;
  for (std::size_t i = 0; i < axis_count; ++i) {
    const AxisProfile& planned = plan.axes[i];
    out.axes[i].profile = AxisProfile{planned.start_counts, planned.target_counts, {}};
    if (planned.is_still()) continue;
    ++moving_count;
    every_axis |= std::uint64_t{1} << (i % 64);
    const double distance = std::abs(static_cast<double>(planned.distance_counts()));
    const AxisCaps caps = hard_limits(plan, static_cast<Eigen::Index>(i));
    const std::size_t candidates_first = w.candidates.size();
    const std::size_t blocks_first = w.blocks.size();
    const GridQuantizer* grid = quantizers[i]->as_grid();
    if (grid != nullptr && options.neighbours <= kMaxBlockNeighbours) {
      axis_blocks(plan, i, *grid, options, caps, w);
    } else {
      axis_setting_blocks(plan, i, *quantizers[i], options, caps, w);
    }
    if (w.blocks.size() > kMaxBlocks) throw std::length_error("quantize_plan: more than 2^24 candidate blocks");
    // The settings within the hard limits, each with the duration the drive's own trapezoid takes.
    const AxisDurations durations =
        evaluate_blocks(w, blocks_first, static_cast<std::uint32_t>(i), distance, caps, out.planned_duration_s);
    w.nearest[i] = durations.nearest;
    range.shortest = std::min(range.shortest, durations.shortest);
    range.longest = std::max(range.longest, durations.longest);
    range.latest_shortest = std::max(range.latest_shortest, durations.shortest);
    range.earliest_longest = std::min(range.earliest_longest, durations.longest);
    if (w.candidates.size() == candidates_first) {
      return PlanFailure{PlanErrc::kQuantizationImpossible, i, plan.axis_names[i],
                         desired_motion(planned.shape, caps).velocity_counts_per_s, caps.velocity};
    }
  }
  if (moving_count == 0) return std::nullopt;

  // A first covering choice: per axis the candidate nearest the planned duration.
  double nearest_shortest = std::numeric_limits<double>::infinity();
  double nearest_longest = 0.0;
  for (std::size_t i = 0; i < axis_count; ++i) {
    if (w.nearest[i] < 0.0) continue;
    nearest_shortest = std::min(nearest_shortest, w.nearest[i]);
    nearest_longest = std::max(nearest_longest, w.nearest[i]);
  }
  tight_candidates(w.candidates, range, nearest_longest - nearest_shortest, every_axis, ++w.plans, w.bucket_axes,
                   w.sorted, w.spare);
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
    axis.setting = setting_of(w, *w.chosen[i]);
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
  return std::nullopt;
}

}  // namespace motion::planner
