// Vocabulary shared by every CiA 301 piece of the CANopen master core: node-IDs, object
// dictionary addresses, the injected frame sink and a small fixed-capacity byte buffer.
// Value types only; thread-safe as values.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <optional>
#include <span>
#include <stdexcept>

#include "motion/can_frame/frame.hpp"

namespace motion::canopen {

// CiA 301 §7.3.2: node-IDs 1..127; 0 addresses all nodes in NMT commands.
using NodeId = std::uint8_t;
inline constexpr NodeId kAllNodes = 0;
inline constexpr NodeId kMinNodeId = 1;
inline constexpr NodeId kMaxNodeId = 127;
[[nodiscard]] constexpr bool is_valid_node_id(NodeId node) { return node >= kMinNodeId && node <= kMaxNodeId; }

// An object dictionary entry: the SDO "multiplexer" (index + sub-index), CiA 301 §7.2.4.3.
struct ObjectAddress {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  friend constexpr bool operator==(const ObjectAddress&, const ObjectAddress&) = default;
};

// Where the passive cores put the frames they want transmitted (a transport, a test recorder).
using FrameSink = std::function<void(const can::Frame&)>;

// Up to `Capacity` bytes stored inline (SDO expedited data, segment data, PDO payloads).
template <std::size_t Capacity>
class InlineBytes {
  static_assert(Capacity <= 255);

 public:
  constexpr InlineBytes() = default;
  // Throws std::length_error when the list does not fit (literals in code and tests).
  InlineBytes(std::initializer_list<std::uint8_t> list) {
    if (list.size() > Capacity) throw std::length_error("InlineBytes: too many bytes");
    std::copy(list.begin(), list.end(), bytes_.begin());
    size_ = static_cast<std::uint8_t>(list.size());
  }
  // nullopt when `bytes` does not fit.
  [[nodiscard]] static constexpr std::optional<InlineBytes> from(std::span<const std::uint8_t> bytes) {
    if (bytes.size() > Capacity) return std::nullopt;
    InlineBytes out;
    std::copy(bytes.begin(), bytes.end(), out.bytes_.begin());
    out.size_ = static_cast<std::uint8_t>(bytes.size());
    return out;
  }

  [[nodiscard]] constexpr std::span<const std::uint8_t> view() const { return {bytes_.data(), size_}; }
  [[nodiscard]] constexpr std::size_t size() const { return size_; }
  [[nodiscard]] constexpr bool empty() const { return size_ == 0; }
  [[nodiscard]] static constexpr std::size_t capacity() { return Capacity; }

  friend constexpr bool operator==(const InlineBytes& a, const InlineBytes& b) {
    return a.size_ == b.size_ && std::equal(a.bytes_.begin(), a.bytes_.begin() + a.size_, b.bytes_.begin());
  }

 private:
  std::array<std::uint8_t, Capacity> bytes_{};
  std::uint8_t size_ = 0;
};

}  // namespace motion::canopen
