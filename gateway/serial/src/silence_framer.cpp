#include "motion/serial/silence_framer.hpp"

#include <utility>

namespace motion::serial {

void SilenceFramer::push(std::span<const std::uint8_t> bytes, TimePoint now) {
  if (bytes.empty()) return;
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
  last_byte_ = now;
}

std::optional<std::vector<std::uint8_t>> SilenceFramer::take_if_silent(TimePoint now) {
  if (buffer_.empty() || now < deadline()) return std::nullopt;
  return complete_now();
}

std::vector<std::uint8_t> SilenceFramer::complete_now() { return std::exchange(buffer_, {}); }

std::vector<std::uint8_t> SilenceFramer::complete_prefix(std::size_t size) {
  if (size >= buffer_.size()) return complete_now();
  std::vector<std::uint8_t> frame(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(size));
  buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(size));
  return frame;
}

}  // namespace motion::serial
