// Transport::send_batch over a datagram socket where each frame is one message (SocketCAN):
// sendmmsg() calls of up to kFramesPerCall messages of at most kMaxBatchedMessage bytes.
// Thread contract: the caller's (the transport's) thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <system_error>

#include "motion/can_frame/frame.hpp"

namespace motion::can {

inline constexpr std::size_t kFramesPerCall = 32;
inline constexpr std::size_t kMaxBatchedMessage = 256;

struct BatchedSend {
  // The socket; < 0: closed, every frame goes to `single`.
  int fd = -1;
  int flags = 0;  // sendmmsg flags (MSG_DONTWAIT is added)
  // `frame` as its message in `out`: its size, 0 when it cannot go in a batch (invalid, ...).
  std::function<std::size_t(const Frame& frame, std::span<std::uint8_t, kMaxBatchedMessage> out)> encode;
  // The transport's send(): a frame nothing of a batch took goes through it, which says why it
  // was refused (and counts it) or sends it after all.
  std::function<std::error_code(const Frame& frame)> single;
  // A frame a batch took: counted as the transport's send() counts it.
  std::function<void(const Frame& frame)> taken;
};

// Sends `frames` in order; returns how many were taken, the first refusal in `error` (the frames
// after it are not sent).
std::size_t send_batched(const BatchedSend& how, std::span<const Frame> frames, std::error_code& error);

}  // namespace motion::can
