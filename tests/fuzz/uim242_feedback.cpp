// UIM242 feedback through the UIM2501/2502 RS232-CAN gateway (UIM242 manual §2.6, §2.10, §3.2,
// appendix A): the byte stream split by FeedbackFramer in arbitrary pieces, each frame parsed and
// read as status, error, notification, greeting and every field layout; and the text as an
// instruction (what the simulator parses). First byte: piece size.
#include <string_view>

#include "fuzz_targets.hpp"
#include "motion/uim242/feedback.hpp"
#include "motion/uim242/instruction.hpp"

namespace motion::fuzz {

int uim242_feedback(const std::uint8_t* data, std::size_t size) {
  Input in(data, size);
  const std::size_t piece = 1U + in.byte() % 32U;
  const auto bytes = in.rest();
  uim242::FeedbackFramer framer;
  for (std::size_t at = 0; at < bytes.size(); at += piece) {
    for (const auto& run : framer.push(bytes.subspan(at, std::min(piece, bytes.size() - at)))) {
      const auto frame = uim242::parse_frame(run);
      if (!frame) continue;
      (void)uim242::decode_status(*frame);
      (void)uim242::as_error(*frame);
      (void)uim242::as_notification(*frame);
      (void)uim242::as_greeting(*frame);
      for (int layout = 0; layout <= static_cast<int>(uim242::Layout::kRaw); ++layout) {
        (void)uim242::decode_fields(frame->data, static_cast<uim242::Layout>(layout));
      }
    }
  }
  (void)uim242::parse_instruction(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
  return 0;
}

}  // namespace motion::fuzz
