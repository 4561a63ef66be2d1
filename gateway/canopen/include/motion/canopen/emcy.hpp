// CiA 301 §7.2.7 emergency objects: codec, error-code classes (CiA 301 table 21) and a passive
// EMCY consumer that turns frames into typed events.
//
// EmcyConsumer thread contract: single-threaded, owned by the poll loop; the handler runs inside
// on_frame().
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <string_view>

#include "motion/can_frame/frame.hpp"
#include "motion/canopen/types.hpp"
#include "motion/core/clock.hpp"

namespace motion::canopen {

struct Emergency {
  std::uint16_t error_code = 0;                // bytes 0-1 (LE); 0000h = error reset / no error
  std::uint8_t error_register = 0;             // byte 2, a copy of 1001h
  std::array<std::uint8_t, 5> manufacturer{};  // bytes 3-7
  friend constexpr bool operator==(const Emergency&, const Emergency&) = default;
};

[[nodiscard]] can::Frame encode_emcy(NodeId node, const Emergency& emergency);
// Exactly 8 bytes.
[[nodiscard]] std::optional<Emergency> decode_emcy(std::span<const std::uint8_t> payload);

// 1001h error register bits (CiA 301 §7.5.2.2).
enum class ErrorRegisterBit : std::uint8_t {
  kGeneric = 0x01,
  kCurrent = 0x02,
  kVoltage = 0x04,
  kTemperature = 0x08,
  kCommunication = 0x10,
  kDeviceProfile = 0x20,
  kManufacturer = 0x80,
};
[[nodiscard]] constexpr bool has(std::uint8_t error_register, ErrorRegisterBit bit) {
  return (error_register & static_cast<std::uint8_t>(bit)) != 0;
}

// The error-code group, from its high bits (CiA 301 §7.2.7.1, table 21).
enum class EmcyErrorClass : std::uint8_t {
  kNoError,              // 00xxh
  kGeneric,              // 10xxh
  kCurrent,              // 2xxxh
  kVoltage,              // 3xxxh
  kTemperature,          // 4xxxh
  kHardware,             // 50xxh
  kSoftware,             // 6xxxh
  kAdditionalModules,    // 70xxh
  kMonitoring,           // 8xxxh other than 81xxh/82xxh
  kCommunication,        // 81xxh (CAN overrun, error passive, heartbeat, bus-off recovery)
  kProtocol,             // 82xxh (PDO length errors, unexpected SYNC length)
  kExternal,             // 90xxh
  kAdditionalFunctions,  // F0xxh
  kDeviceSpecific,       // FFxxh
  kReserved,             // codes CiA 301 leaves unassigned
};
[[nodiscard]] EmcyErrorClass classify_error_code(std::uint16_t error_code);
[[nodiscard]] std::string_view to_string(EmcyErrorClass error_class);

struct EmcyEvent {
  NodeId node = 0;
  Emergency emergency;
  EmcyErrorClass error_class = EmcyErrorClass::kNoError;
  TimePoint received{};
  // Error reset: the node reports that all its errors cleared.
  [[nodiscard]] bool is_reset() const { return error_class == EmcyErrorClass::kNoError; }
};

class EmcyConsumer {
 public:
  using Handler = std::function<void(const EmcyEvent&)>;

  void on_event(Handler handler) { handler_ = std::move(handler); }
  // A node whose 1014h is not the default 80h + node-ID (read it, then register it here).
  void set_cob_id(NodeId node, std::uint32_t cob_id);

  // True when `frame` is an EMCY (default COB-ID 81h..FFh or a registered one) and was handled.
  // A frame on an EMCY COB-ID that is not 8 bytes long is consumed and dropped.
  bool on_frame(const can::Frame& frame, TimePoint now);

  // The last EMCY of `node` (the active error state after a reset is error code 0000h).
  [[nodiscard]] std::optional<Emergency> last(NodeId node) const;

 private:
  [[nodiscard]] std::optional<NodeId> node_for(std::uint32_t cob_id) const;

  Handler handler_;
  std::map<std::uint32_t, NodeId> custom_cob_ids_;
  std::map<NodeId, Emergency> last_;
};

}  // namespace motion::canopen
