#include "motion/can/batched_send.hpp"

#include <sys/socket.h>

#include <array>
#include <cerrno>

namespace motion::can {

std::size_t send_batched(const BatchedSend& how, std::span<const Frame> frames, std::error_code& error) {
  error = {};
  std::size_t done = 0;
  while (done < frames.size()) {
    std::array<std::array<std::uint8_t, kMaxBatchedMessage>, kFramesPerCall> buffers{};
    std::array<iovec, kFramesPerCall> io{};
    std::array<mmsghdr, kFramesPerCall> messages{};
    unsigned ready = 0;
    for (; how.fd >= 0 && ready < kFramesPerCall && done + ready < frames.size(); ++ready) {
      const std::size_t size = how.encode(frames[done + ready], buffers[ready]);
      if (size == 0) break;
      io[ready] = {buffers[ready].data(), size};
      messages[ready].msg_hdr.msg_iov = &io[ready];
      messages[ready].msg_hdr.msg_iovlen = 1;
    }
    int sent = 0;
    if (ready > 0) {
      do {
        sent = ::sendmmsg(how.fd, messages.data(), ready, how.flags | MSG_DONTWAIT);
      } while (sent < 0 && errno == EINTR);
    }
    if (sent <= 0) {
      // Nothing taken: the single send says why (and counts it), or takes it after all.
      if ((error = how.single(frames[done]))) return done;
      ++done;
      continue;
    }
    for (int i = 0; i < sent; ++i) how.taken(frames[done + static_cast<std::size_t>(i)]);
    done += static_cast<std::size_t>(sent);
  }
  return done;
}

}  // namespace motion::can
