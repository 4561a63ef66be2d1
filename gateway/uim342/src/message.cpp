#include "motion/uim342/message.hpp"

namespace motion::uim342 {

Result<Message> Message::make(std::uint8_t control_word, std::span<const std::uint8_t> payload) {
  if (payload.size() > kMaxDataLength) return CodecErrc::kLengthOutOfRange;
  Message m;
  m.control_word = control_word;
  m.length = static_cast<std::uint8_t>(payload.size());
  std::copy(payload.begin(), payload.end(), m.data.begin());
  return m;
}

Result<can::Frame> encode_can(const CanMessage& message) {
  const auto id = encode_can_id({message.address.producer, message.address.consumer, message.message.control_word});
  if (!id) return id.error();
  if (message.message.length > kMaxDataLength) return CodecErrc::kLengthOutOfRange;
  const auto frame = can::Frame::make(*id, true, message.message.payload());
  if (!frame) return CodecErrc::kIdentifierOutOfRange;  // unreachable: the id has 29 bits
  return *frame;
}

Result<CanMessage> decode_can(const can::Frame& frame) {
  if (!frame.extended) return CodecErrc::kNotExtendedFrame;
  if (frame.rtr) return CodecErrc::kRemoteFrame;
  if (frame.dlc > kMaxDataLength) return CodecErrc::kLengthOutOfRange;
  const auto fields = decode_can_id(frame.id);
  if (!fields) return fields.error();
  const auto message = Message::make(fields->control_word, frame.payload());
  if (!message) return message.error();
  return CanMessage{{fields->producer, fields->consumer}, *message};
}

}  // namespace motion::uim342
