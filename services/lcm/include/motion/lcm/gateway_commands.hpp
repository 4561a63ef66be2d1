// The two versions of a gateway command (lcmtypes/gateway_command_t.lcm: motion values as counts/s
// doubles; gateway_command2_t.lcm: as integers of the axes' drive-model grids) share everything
// but those values. Here: copying what they share, and telling an encoded one from the other by
// its LCM fingerprint (a signed_gateway_command_t's `command` bytes hold either).
// Pure, header-only. Thread-safe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <variant>

#include <motionlcm/gateway_command2_t.hpp>
#include <motionlcm/gateway_command_t.hpp>

#include "motion/lcm/wire_bounds.hpp"

namespace motion::lcm {

// Copies what both versions carry (header, kind, trigger, param; per axis its name, target and
// outputs) from `from` into `to`; `to`'s axes are resized to `from`'s, their motion values left as
// they were (value-initialized for new axes).
template <typename From, typename To>
void copy_command_common(const From& from, To& to) {
  to.utime = from.utime;
  to.bus = from.bus;
  to.command_id = from.command_id;
  to.request_id = from.request_id;
  to.kind = from.kind;
  to.trigger_id = from.trigger_id;
  to.param = from.param;
  to.axes.resize(from.axes.size());
  for (std::size_t i = 0; i < from.axes.size(); ++i) {
    to.axes[i].axis = from.axes[i].axis;
    to.axes[i].target_counts = from.axes[i].target_counts;
    to.axes[i].output_mask = from.axes[i].output_mask;
    to.axes[i].output_value = from.axes[i].output_value;
  }
  to.num_axes = static_cast<std::int32_t>(to.axes.size());
}

// True when `bytes` begin with the LCM fingerprint of type T (8 bytes, big-endian).
template <typename T>
[[nodiscard]] bool has_fingerprint(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < 8) return false;
  const auto hash = static_cast<std::uint64_t>(T::getHash());
  for (std::size_t i = 0; i < 8; ++i) {
    if (bytes[i] != static_cast<std::uint8_t>(hash >> (8 * (7 - i)))) return false;
  }
  return true;
}

// Either version, told apart by the fingerprint of `bytes` and decoded bounded
// (wire::decode_bounded); or why they are neither.
using AnyGatewayCommand = std::variant<motionlcm::gateway_command_t, motionlcm::gateway_command2_t, std::string>;
[[nodiscard]] inline AnyGatewayCommand decode_gateway_command(std::span<const std::uint8_t> bytes) {
  if (has_fingerprint<motionlcm::gateway_command2_t>(bytes)) {
    motionlcm::gateway_command2_t command;
    if (std::string why = wire::decode_bounded(bytes.data(), bytes.size(), command); !why.empty()) return why;
    return command;
  }
  motionlcm::gateway_command_t command;
  if (std::string why = wire::decode_bounded(bytes.data(), bytes.size(), command); !why.empty()) return why;
  return command;
}

// Which motion values a kind carries (velocity, acceleration, deceleration): ARM_MOVE, JOG, HOME.
[[nodiscard]] inline bool carries_motion(std::int8_t kind) {
  return kind == motionlcm::gateway_command_t::ARM_MOVE || kind == motionlcm::gateway_command_t::JOG ||
         kind == motionlcm::gateway_command_t::HOME;
}

}  // namespace motion::lcm
