// The UIROBOT serial gateway's byte stream (UIM342 manual §2.6, 16-byte UIMessages with CRC):
// arbitrary pieces fed to UiMessageStream, every message taken out, and each 16-byte window
// decoded on its own. First byte: CRC acceptance and piece size.
#include "motion/uim342/uimessage_stream.hpp"
#include "fuzz_targets.hpp"
#include "motion/uim342/uimessage.hpp"

namespace motion::fuzz {

int uimessage_stream(const std::uint8_t* data, std::size_t size) {
  Input in(data, size);
  const std::uint8_t mode = in.byte();
  const auto accept = static_cast<uim342::CrcAcceptance>(mode % 3U);
  const std::size_t piece = 1U + (mode >> 2U);
  const auto bytes = in.rest();
  uim342::UiMessageStream stream(accept);
  for (std::size_t at = 0; at < bytes.size(); at += piece) {
    stream.feed(bytes.subspan(at, std::min(piece, bytes.size() - at)));
    while (const auto message = stream.next()) { (void)uim342::drive_message_from_ui(message->message); }
  }
  for (std::size_t at = 0; at + 16 <= bytes.size(); ++at)
    (void)uim342::decode_ui_message(bytes.subspan(at, 16), accept);
  return 0;
}

}  // namespace motion::fuzz
