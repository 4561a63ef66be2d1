#include "motion/uim342/uimessage_stream.hpp"

namespace motion::uim342 {
namespace {

bool is_start(std::uint8_t byte) { return byte == kUiStartWithCrc || byte == kUiStartWithoutCrc; }

}  // namespace

void UiMessageStream::feed(std::span<const std::uint8_t> bytes) {
  // Consumed bytes go first, so the buffer holds at most a partial frame before the append.
  buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(start_));
  start_ = 0;
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
}

std::optional<DecodedUiMessage> UiMessageStream::next() {
  for (;;) {
    while (start_ < buffer_.size() && !is_start(buffer_[start_])) {
      ++start_;
      ++counters_.discarded_bytes;
    }
    if (buffered() < kUiMessageSize) return std::nullopt;
    const auto decoded = decode_ui_message(std::span(buffer_).subspan(start_, kUiMessageSize), accept_);
    if (decoded) {
      start_ += kUiMessageSize;
      ++counters_.frames;
      return *decoded;
    }
    if (decoded.error() == CodecErrc::kBadCrc) ++counters_.crc_errors;
    if (decoded.error() == CodecErrc::kLengthOutOfRange) ++counters_.malformed;
    ++start_;  // not a frame here; one may start inside the candidate
    ++counters_.discarded_bytes;
  }
}

void UiMessageStream::clear() {
  buffer_.clear();
  start_ = 0;
}

}  // namespace motion::uim342
