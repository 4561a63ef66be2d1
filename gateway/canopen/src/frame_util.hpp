// Internal: building standard-ID data frames for the codecs.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>

#include "motion/can_frame/frame.hpp"

namespace motion::canopen::detail {

// Callers pass at most 8 bytes and an 11-bit id, so construction cannot fail.
inline can::Frame standard_frame(std::uint32_t id, std::span<const std::uint8_t> payload) {
  can::Frame frame;
  frame.id = id & can::kMaxStandardId;
  frame.dlc = static_cast<std::uint8_t>(std::min<std::size_t>(payload.size(), frame.data.size()));
  std::copy_n(payload.begin(), frame.dlc, frame.data.begin());
  return frame;
}

// A data frame in the standard format (the predefined connection set has no RTR/extended use).
inline bool is_standard_data_frame(const can::Frame& frame) { return !frame.extended && !frame.rtr; }

}  // namespace motion::canopen::detail
