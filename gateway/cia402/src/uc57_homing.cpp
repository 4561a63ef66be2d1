#include "motion/cia402/uc57_homing.hpp"

#include <array>

#include "motion/cia402/words.hpp"

namespace motion::cia402::uc57 {
namespace {

using enum HomingMethod;
constexpr auto kNeg = Direction::kNegative;
constexpr auto kPos = Direction::kPositive;

// Manual §4.2.6, paraphrased per method; C-17 for 29 and 42.
constexpr std::array kMethods{
    HomingMethodInfo{kNegativeLimit, "negative limit mode", kNeg, HomeSignal::kNegativeLimit, true, kNeg,
                     LimitReaction::kNotApplicable, true},
    HomingMethodInfo{kPositiveLimit, "positive limit mode", kPos, HomeSignal::kPositiveLimit, true, kPos,
                     LimitReaction::kNotApplicable, true},
    HomingMethodInfo{kHomeSwitchPositive, "forward origin mode", kPos, HomeSignal::kOrigin, true, kPos,
                     LimitReaction::kReverse, true},
    HomingMethodInfo{kHomeSwitchNegative, "reverse origin mode", kNeg, HomeSignal::kOrigin, true, kNeg,
                     LimitReaction::kReverse, true},
    HomingMethodInfo{kHomeSwitchNegativeImmediate, "origin in the negative direction, stop immediately", kNeg,
                     HomeSignal::kOrigin, false, kNeg, LimitReaction::kStopFailed, false},
    HomingMethodInfo{kHomeSwitchPositiveImmediate, "origin in the positive direction, stop immediately", kPos,
                     HomeSignal::kOrigin, false, kPos, LimitReaction::kStopFailed, false},
};

const OdEntry& entry(std::uint16_t index, std::uint8_t subindex) { return *find_entry(index, subindex); }

}  // namespace

std::span<const HomingMethodInfo> homing_methods() { return kMethods; }

const HomingMethodInfo* find_homing_method(std::uint8_t value) {
  for (const HomingMethodInfo& info : kMethods) {
    if (static_cast<std::uint8_t>(info.method) == value) return &info;
  }
  return nullptr;
}

HomingResult homing_result(std::uint16_t statusword) {
  if (!is_set(statusword, StatusBit::kTargetReached)) return HomingResult::kInProgress;
  const bool attained = is_set(statusword, StatusBit::kHomingDone) || is_set(statusword, kHomingAttained);
  return attained ? HomingResult::kSucceeded : HomingResult::kStoppedWithoutHome;
}

HomingSettings quantize_homing(const HomingRequest& request, std::uint32_t pulses_per_rev, RampUnit unit,
                               Rounding rounding) {
  HomingSettings settings;
  settings.method = static_cast<std::uint8_t>(request.method);
  settings.search_speed =
      quantize_speed(entry(index::kHomingSpeeds, 1), request.search_speed, pulses_per_rev, rounding);
  settings.locate_speed =
      quantize_speed(entry(index::kHomingSpeeds, 2), request.locate_speed, pulses_per_rev, rounding);
  settings.acceleration = quantize_ramp(entry(index::kHomingAcceleration, 0), request.acceleration,
                                        settings.search_speed.realized, pulses_per_rev, unit, rounding);
  settings.offset = quantize_position(entry(index::kHomeOffset, 0), request.offset);
  return settings;
}

}  // namespace motion::cia402::uc57
