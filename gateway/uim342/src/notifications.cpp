#include "motion/uim342/notifications.hpp"

#include <fmt/format.h>

#include "motion/core/bytes.hpp"

namespace motion::uim342 {
namespace {
constexpr std::uint8_t kAlarmLength = 5;
constexpr std::uint8_t kInputEdgeLength = 1;
constexpr std::uint8_t kPositionReachedLength = 8;
}  // namespace

std::string describe(AlarmCode alarm) {
  switch (alarm) {
    case AlarmCode::kEmergencyStopLock: return "system emergency stop and lock";
    case AlarmCode::kSpeedOverLimit: return "speed over limit";
    case AlarmCode::kBelowLowerLimit: return "exceeded lower working limit";
    case AlarmCode::kAboveUpperLimit: return "exceeded upper working limit";
    case AlarmCode::kStall: return "motor stall detected";
    case AlarmCode::kEncoderError: return "encoder error";
    case AlarmCode::kEncoderBatteryLow: return "encoder battery low";
  }
  return fmt::format("unknown alarm 0x{:02X}", static_cast<unsigned>(alarm));
}

Message encode(const Notification& notification) {
  Message m;
  m.control_word = kNotificationControlWord;
  if (const auto* alarm = std::get_if<AlarmNotification>(&notification)) {
    m.length = kAlarmLength;
    m.data[0] = static_cast<std::uint8_t>(NotificationCode::kAlarm);
    m.data[1] = static_cast<std::uint8_t>(alarm->alarm);
  } else if (const auto* edge = std::get_if<InputEdgeNotification>(&notification)) {
    m.length = kInputEdgeLength;
    m.data[0] = static_cast<std::uint8_t>(edge->code());
  } else if (const auto* reached = std::get_if<PositionReachedNotification>(&notification)) {
    m.length = kPositionReachedLength;
    m.data[0] = static_cast<std::uint8_t>(NotificationCode::kPositionReached);
    bytes::write_le(std::span<std::uint8_t>(m.data), 4, reached->position);
  }
  return m;
}

Result<Notification> decode_notification(const Message& message) {
  if (message.control_word != kNotificationControlWord) return CodecErrc::kNotANotification;
  if (message.length == 0) return CodecErrc::kWrongLength;
  if (message.length > kMaxDataLength) return CodecErrc::kLengthOutOfRange;
  const auto d = message.payload();
  const auto expect_length = [&message](std::uint8_t length) { return message.length == length; };
  const std::uint8_t code = d[0];
  if (code == static_cast<std::uint8_t>(NotificationCode::kAlarm)) {
    if (!expect_length(kAlarmLength)) return CodecErrc::kWrongLength;
    return Notification{AlarmNotification{static_cast<AlarmCode>(d[1])}};
  }
  if (code >= static_cast<std::uint8_t>(NotificationCode::kIn1Falling) &&
      code <= static_cast<std::uint8_t>(NotificationCode::kIn3Rising)) {
    if (!expect_length(kInputEdgeLength)) return CodecErrc::kWrongLength;
    const auto zero_based = static_cast<unsigned>(code - 1);
    return Notification{InputEdgeNotification{static_cast<InputPort>(zero_based / 2),
                                              zero_based % 2 == 0 ? Edge::kFalling : Edge::kRising}};
  }
  if (code == static_cast<std::uint8_t>(NotificationCode::kPositionReached)) {
    if (!expect_length(kPositionReachedLength)) return CodecErrc::kWrongLength;
    return Notification{PositionReachedNotification{*bytes::read_le<std::int32_t>(d, 4)}};
  }
  return CodecErrc::kUnknownNotification;
}

Result<can::Frame> notification_frame(std::uint8_t node, const Notification& notification, std::uint8_t host) {
  return encode_can({drive_to_host(node, host), encode(notification)});
}

std::optional<InformationEnable> enabled_by(const Notification& notification) {
  if (const auto* edge = std::get_if<InputEdgeNotification>(&notification)) {
    return static_cast<InformationEnable>(edge->port);  // IE[0..2] = IN1..IN3
  }
  if (std::holds_alternative<PositionReachedNotification>(notification)) return InformationEnable::kPositionReached;
  return std::nullopt;
}

Result<DriveMessage> decode_drive_message(const Message& message) {
  if (message.control_word == kNotificationControlWord) {
    auto notification = decode_notification(message);
    if (!notification) return notification.error();
    return DriveMessage{*notification};
  }
  auto reply = decode_reply(message);
  if (!reply) return reply.error();
  return DriveMessage{*reply};
}

}  // namespace motion::uim342
