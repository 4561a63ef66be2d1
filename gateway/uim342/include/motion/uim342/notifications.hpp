// Real-time notifications (RT, CW 0x5A), manual §2.4 / §4.4 / §5.29: unsolicited drive frames
// for alarms (DL 5: d0 = 0, d1 = alarm code), input edges (DL 1: d0 = 1..6) and "PTP positioning
// finished" (DL 8: d0 = 0x29, [d7..d4] = position). Reserved bytes are written as zero and ignored
// when decoding; unknown alarm codes are kept (a newer firmware may add some), unknown d0 values
// are rejected. Thread contract: pure functions, thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <variant>

#include "motion/can_frame/frame.hpp"
#include "motion/uim342/errors.hpp"
#include "motion/uim342/instructions.hpp"
#include "motion/uim342/message.hpp"

namespace motion::uim342 {

inline constexpr std::uint8_t kNotificationControlWord = 0x5A;

// d0 of a notification.
enum class NotificationCode : std::uint8_t {
  kAlarm = 0x00,
  kIn1Falling = 0x01,
  kIn1Rising = 0x02,
  kIn2Falling = 0x03,
  kIn2Rising = 0x04,
  kIn3Falling = 0x05,
  kIn3Rising = 0x06,
  kPositionReached = 0x29,
};

// d1 of an alarm (§2.4).
enum class AlarmCode : std::uint8_t {
  kEmergencyStopLock = 0x0A,  // system emergency stop and lock
  kSpeedOverLimit = 0x19,
  kBelowLowerLimit = 0x1A,  // exceeded lower working (software) limit
  kAboveUpperLimit = 0x1B,  // exceeded upper working (software) limit
  kStall = 0x1D,            // motor stall detected
  kEncoderError = 0x1E,
  kEncoderBatteryLow = 0x1F,
};
[[nodiscard]] std::string describe(AlarmCode alarm);  // manual wording; "unknown alarm 0xNN" else

enum class Edge : std::uint8_t { kFalling, kRising };

struct AlarmNotification {
  AlarmCode alarm{};
  friend bool operator==(const AlarmNotification&, const AlarmNotification&) = default;
};
struct InputEdgeNotification {
  InputPort port = InputPort::kIn1;
  Edge edge = Edge::kFalling;
  // d0 = 2*port + 1, +1 for the rising edge.
  [[nodiscard]] NotificationCode code() const {
    return static_cast<NotificationCode>(2 * static_cast<unsigned>(port) + 1 + (edge == Edge::kRising ? 1 : 0));
  }
  friend bool operator==(const InputEdgeNotification&, const InputEdgeNotification&) = default;
};
struct PositionReachedNotification {
  std::int32_t position = 0;  // absolute position (assumed: §2.4 says "current position")
  friend bool operator==(const PositionReachedNotification&, const PositionReachedNotification&) = default;
};
using Notification = std::variant<AlarmNotification, InputEdgeNotification, PositionReachedNotification>;

[[nodiscard]] Message encode(const Notification& notification);
[[nodiscard]] Result<Notification> decode_notification(const Message& message);
[[nodiscard]] Result<can::Frame> notification_frame(std::uint8_t node, const Notification& notification,
                                                    std::uint8_t host = kMasterId);

// The IE[i] bit that gates the notification (§5.3); nullopt for alarms (always sent: §5.3 has no
// enable bit for them, assumed).
[[nodiscard]] std::optional<InformationEnable> enabled_by(const Notification& notification);

// Everything a drive sends: ACK / error report, or notification.
using DriveMessage = std::variant<Reply, Notification>;
[[nodiscard]] Result<DriveMessage> decode_drive_message(const Message& message);

}  // namespace motion::uim342
