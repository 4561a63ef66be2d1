// From a synchronized plan to what the drives will really do.
//
// Each moving axis's desired cruise velocity / acceleration / deceleration (counts/s, counts/s^2)
// goes through its DriveQuantizer; the drive then runs its own time-optimal trapezoid with the
// representable values over the exact distance in counts, so the axes no longer arrive together.
// Among the representable neighbours of every axis's values (rounded down or up, and one step
// further each way; plus ramps re-fitted to the planned duration), the refinement picks one
// setting per axis so that the spread of arrival times is minimal (exactly, over those
// candidates; ties go to the arrival nearest the plan, then to the setting the quantizer offered
// first), never exceeding the axis's hard limits (SyncPlan::*_limit_*: the speed override does
// not bind there).
// Cost: linear in the candidates, no sort of them all: only those that can lie in the tightest
// window (given the spread of the settings nearest the planned duration) are sorted. Scratch
// buffers are per thread and reused, so once they have grown to a plan's size the only
// allocation is the result's, and none with quantize_plan_into() and a reused result.
// Thread contract: quantize_plan is pure (its scratch is thread-local); thread-safe if the
// quantizers are (ours are).
#pragma once

#include <optional>
#include <span>
#include <vector>

#include "motion/planner/errors.hpp"
#include "motion/planner/profile.hpp"
#include "motion/planner/quantizer.hpp"
#include "motion/planner/sync_planner.hpp"

namespace motion::planner {

struct QuantizeOptions {
  // Representable values considered on either side of the rounded-down value of every desired
  // parameter (1: one below, rounded down, one above). Per axis, (2 * neighbours + 1)^3
  // candidates are evaluated.
  int neighbours = 1;
  // Also try, for every representable velocity, the ramps that would make the axis arrive exactly
  // at the planned duration with it (then quantized the same way). Recovers most of a coarse
  // velocity grid's error (e.g. 1 rpm steps on a slow axis) at 4x the candidates.
  bool match_duration = true;
};

struct RealizedAxis {
  std::optional<DriveSetting> setting;  // nullopt: still axis, nothing to send
  AxisProfile profile;                  // what the drive will do, counts; duration 0 when still
  [[nodiscard]] double duration_s() const { return profile.duration_s(); }
};

struct QuantizedPlan {
  std::vector<RealizedAxis> axes;  // in the plan's order
  double planned_duration_s = 0.0;
  // Over the moving axes (0 when none moves): realized arrival times after a common start.
  double earliest_arrival_s = 0.0;
  double latest_arrival_s = 0.0;
  [[nodiscard]] double predicted_spread_s() const { return latest_arrival_s - earliest_arrival_s; }
};

// The representable settings the refinement chooses from for one axis (see QuantizeOptions),
// already restricted to the axis's hard limits; appended to `out`, none for a still axis.
void append_axis_candidates(const SyncPlan& plan, std::size_t axis, const DriveQuantizer& quantizer,
                            const QuantizeOptions& options, std::vector<DriveSetting>& out);

// `quantizers[i]` serves axis i (one per axis, non-null; a still axis never calls it).
[[nodiscard]] Result<QuantizedPlan> quantize_plan(const SyncPlan& plan,
                                                  std::span<const DriveQuantizer* const> quantizers,
                                                  const QuantizeOptions& options = {});

// The same into a caller's result, overwritten whole (its axes keep their storage): with a result
// kept from plan to plan, quantization allocates nothing once the buffers have grown. nullopt on
// success; on a failure `out` holds nothing meaningful.
[[nodiscard]] std::optional<PlanFailure> quantize_plan_into(const SyncPlan& plan,
                                                            std::span<const DriveQuantizer* const> quantizers,
                                                            QuantizedPlan& out, const QuantizeOptions& options = {});

}  // namespace motion::planner
