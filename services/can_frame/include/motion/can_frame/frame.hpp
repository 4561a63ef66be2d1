// A classic CAN 2.0 frame as every CAN-side layer of the project sees it (transports, protocol
// stacks, simulators, candump I/O). Value type, trivially copyable.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace motion::can {

inline constexpr std::uint32_t kMaxStandardId = 0x7FF;
inline constexpr std::uint32_t kMaxExtendedId = 0x1FFFFFFF;

struct Frame {
  std::uint32_t id = 0;   // 11-bit (standard) or 29-bit (extended) identifier
  bool extended = false;  // IDE
  bool rtr = false;       // remote transmission request (no data bytes on the wire)
  std::uint8_t dlc = 0;   // 0..8
  std::array<std::uint8_t, 8> data{};
  // Receive time, microseconds since the Unix epoch: the end-of-frame time on the simulated bus,
  // the kernel timestamp on SocketCAN, 0 for frames not yet sent.
  std::int64_t timestamp_us = 0;

  [[nodiscard]] std::span<const std::uint8_t> payload() const { return {data.data(), dlc}; }

  // Builds a data frame; nullopt when the id does not fit its format or payload exceeds 8 bytes.
  static std::optional<Frame> make(std::uint32_t id, bool extended, std::span<const std::uint8_t> payload);

  friend bool operator==(const Frame& a, const Frame& b) {
    // Timestamps are metadata, not content.
    return a.id == b.id && a.extended == b.extended && a.rtr == b.rtr && a.dlc == b.dlc &&
           std::equal(a.data.begin(), a.data.begin() + a.dlc, b.data.begin());
  }
};

// cansend / candump -L notation: "123#DEADBEEF" (standard), "04280095#01" (extended: 8 hex
// digits), "123#R" (RTR). Parsing rejects anything else with nullopt.
std::optional<Frame> parse_cansend(std::string_view text);
std::string to_cansend(const Frame& frame);

// One candump -L log line: "(1700000000.123456) can0 04280095#01".
std::string to_candump_line(const Frame& frame, std::string_view interface);
struct LogLine {
  std::int64_t timestamp_us;
  std::string interface;
  Frame frame;
};
std::optional<LogLine> parse_candump_line(std::string_view line);

}  // namespace motion::can
