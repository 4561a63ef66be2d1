// Finding UIMessages in a serial byte stream (manual §2.6, Appendix-1). The line has no framing but
// SM (0xAA / 0xAD) and EM (0xCC) 15 bytes apart, so a receiver that starts mid-frame or sees line
// noise resynchronizes by trying every SM byte as a frame start. A candidate whose EM, DL or CRC
// is wrong gives up only its first byte: a real frame may begin inside it.
//
// Pure (no I/O). Memory is bounded by one incomplete frame plus the bytes of the last feed() when
// the owner drains next() after each feed().
// Thread contract: one owner thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "motion/uim342/uimessage.hpp"

namespace motion::uim342 {

class UiMessageStream {
 public:
  struct Counters {
    std::uint64_t frames = 0;           // messages returned by next()
    std::uint64_t crc_errors = 0;       // SM..EM candidates whose CRC matched no accepted coverage
    std::uint64_t malformed = 0;        // SM..EM candidates with DL above 8
    std::uint64_t discarded_bytes = 0;  // bytes dropped while looking for a frame start
  };

  explicit UiMessageStream(CrcAcceptance accept = CrcAcceptance::kEither) : accept_(accept) {}

  void feed(std::span<const std::uint8_t> bytes);
  // The next complete message; nullopt when the buffered bytes hold none (yet).
  [[nodiscard]] std::optional<DecodedUiMessage> next();
  // Drops the buffered bytes (a new connection starts clean); counters are kept.
  void clear();

  [[nodiscard]] std::size_t buffered() const { return buffer_.size() - start_; }
  [[nodiscard]] const Counters& counters() const { return counters_; }

 private:
  CrcAcceptance accept_;
  std::vector<std::uint8_t> buffer_;
  std::size_t start_ = 0;  // first byte of buffer_ not consumed yet
  Counters counters_;
};

}  // namespace motion::uim342
