// UIM342 SimpleCAN 3.0 frames as the gateway receives them (UIM342 manual §2.5, §5): identifier
// decoding, replies, notifications, instructions (the simulator's side), error reports. Input:
// a sequence of frames, each u32 identifier (bit 31 = extended), a length byte, the payload.
#include "fuzz_targets.hpp"
#include "motion/can_frame/frame.hpp"
#include "motion/uim342/instructions.hpp"
#include "motion/uim342/message.hpp"
#include "motion/uim342/notifications.hpp"

namespace motion::fuzz {

int uim342_can(const std::uint8_t* data, std::size_t size) {
  Input in(data, size);
  while (!in.empty()) {
    std::uint32_t id = in.u32();
    const bool extended = (id & 0x80000000U) != 0;
    id &= extended ? 0x1FFFFFFFU : 0x7FFU;
    const auto payload = in.take(in.byte() % 9U);
    const auto frame = can::Frame::make(id, extended, payload);
    if (!frame) continue;
    (void)uim342::decode_reply_frame(*frame);
    (void)uim342::decode_instruction_frame(*frame);
    const auto message = uim342::decode_can(*frame);
    if (!message) continue;
    (void)uim342::decode_drive_message(message->message);
    (void)uim342::decode_notification(message->message);
    (void)uim342::decode_reply(message->message);
    (void)uim342::decode_instruction(message->message);
  }
  return 0;
}

}  // namespace motion::fuzz
