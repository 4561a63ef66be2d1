// CiA 301 §7.2.4 SDO client, passive (no I/O, no clock, no threads), for the default SDO channel
// of each node (requests on 600h + n, responses on 580h + n).
//
// Per node: one transfer on the wire at a time, the others wait in a FIFO queue. Expedited and
// segmented upload and download, toggle-bit checking, a per-node response timeout and bounded
// retries.
//  - A request goes out on the next process(now) call, or at once when a previous transfer of
//    the same node completes inside on_frame()/process() (so callbacks can chain requests).
//  - Timeout: the client aborts the attempt on the wire (05040000h) and, while retries remain,
//    restarts the transfer from its initiate request; the abort resets any half-done segmented
//    state in the server. After the last attempt the callback gets SdoAbortCode::kTimeout.
//  - Server abort: completes with that abort code, no retry. Protocol errors (wrong toggle,
//    unexpected command specifier, length errors) abort on the wire with the CiA 301 code and
//    complete with it, no retry. A reply naming another object than requested aborts with
//    General error and completes with CanopenError::kMismatchedReply, unless it names an object
//    whose request was given up (timed out, cancelled) since the node's channel was last idle:
//    that is the late answer to it (a busy server), dropped.
//
// Thread contract: single-threaded, owned by the poll loop. Callbacks run inside on_frame(),
// process() or cancel(); they may issue new requests or cancel, but must not destroy the client.
#pragma once

#include <concepts>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <system_error>
#include <vector>

#include "motion/can_frame/frame.hpp"
#include "motion/canopen/sdo.hpp"
#include "motion/canopen/types.hpp"
#include "motion/core/bytes.hpp"
#include "motion/core/clock.hpp"

namespace motion::canopen {

struct SdoClientConfig {
  Duration timeout = std::chrono::milliseconds(500);     // per request frame
  unsigned max_retries = 1;                              // extra attempts after a timeout
  std::size_t max_upload_size = std::size_t{64} * 1024;  // larger uploads abort with 05040005h
};

// Completion: error (empty on success) and, for uploads, the object's bytes.
using SdoCallback = std::function<void(std::error_code, std::span<const std::uint8_t> data)>;

enum class SdoDownloadMode : std::uint8_t {
  kAuto,       // expedited for 1..4 bytes, segmented otherwise
  kSegmented,  // always segmented (servers that want it, tests of the segmented path)
};

class SdoClient {
 public:
  explicit SdoClient(FrameSink sink, SdoClientConfig defaults = {});

  // Timeout/retries for one node (others use the defaults given to the constructor).
  void configure_node(NodeId node, const SdoClientConfig& config);

  // Queue a read of `object`. An invalid node-ID completes at once with kInvalidArgument.
  void upload(NodeId node, ObjectAddress object, SdoCallback done);
  // Queue a write of `data` to `object`.
  void download(NodeId node, ObjectAddress object, std::vector<std::uint8_t> data, SdoCallback done,
                SdoDownloadMode mode = SdoDownloadMode::kAuto);

  // Drops every transfer of `node`: the one on the wire is aborted (General error) and all
  // callbacks get CanopenError::kCancelled, in queue order.
  void cancel(NodeId node);

  // Feed every received frame; true when it was an SDO response (580h + n) and was consumed.
  bool on_frame(const can::Frame& frame, TimePoint now);
  // Starts queued transfers and handles timeouts; returns the next deadline (kNever if idle).
  TimePoint process(TimePoint now);
  // TimePoint::min() when a queued transfer waits for process(); else as process() returns.
  [[nodiscard]] TimePoint next_deadline() const;

  [[nodiscard]] bool busy(NodeId node) const;            // a transfer is on the wire
  [[nodiscard]] std::size_t pending(NodeId node) const;  // on the wire + queued

 private:
  enum class Direction : std::uint8_t { kUpload, kDownload };
  enum class Phase : std::uint8_t { kInitiate, kSegments };

  struct Transfer {
    Direction direction = Direction::kUpload;
    ObjectAddress object;
    std::vector<std::uint8_t> data;  // download: the value; upload: bytes received so far
    SdoCallback done;
    SdoDownloadMode mode = SdoDownloadMode::kAuto;
    Phase phase = Phase::kInitiate;
    bool toggle = false;
    std::size_t offset = 0;                 // download: bytes already sent
    std::optional<std::uint32_t> expected;  // upload: size the server announced
    unsigned attempt = 0;
    TimePoint deadline = kNever;
  };

  struct Channel {
    std::optional<SdoClientConfig> config;
    std::optional<Transfer> active;
    std::deque<Transfer> queue;
    std::vector<ObjectAddress> abandoned;  // requests given up since the channel was last idle
  };

  void enqueue(NodeId node, Transfer transfer);
  void start_next(NodeId node, Channel& channel, TimePoint now);
  void send_initiate(NodeId node, Channel& channel, TimePoint now);
  void send_request(NodeId node, Channel& channel, const SdoRequest& request, TimePoint now);
  void send_next_download_segment(NodeId node, Channel& channel, TimePoint now);
  void handle_response(NodeId node, Channel& channel, const SdoResponse& response, TimePoint now);
  void handle_timeout(NodeId node, Channel& channel, TimePoint now);
  [[nodiscard]] static bool is_late_answer(const Channel& channel, const SdoResponse& response);
  static void abandon(Channel& channel, ObjectAddress object);
  // Aborts on the wire (when `wire_code` is set) and completes the active transfer.
  void fail(NodeId node, Channel& channel, std::error_code error, std::optional<std::uint32_t> wire_code,
            TimePoint now);
  void succeed(NodeId node, Channel& channel, TimePoint now);
  void complete(NodeId node, Channel& channel, std::error_code error, TimePoint now);
  [[nodiscard]] const SdoClientConfig& config_of(const Channel& channel) const;

  FrameSink sink_;
  SdoClientConfig defaults_;
  std::map<NodeId, Channel> channels_;  // node-stable addresses: callbacks may add channels
};

// Typed helpers: the little-endian bytes of an integer object value, and back (exact size).
template <std::integral T>
[[nodiscard]] std::vector<std::uint8_t> encode_value(T value) {
  std::vector<std::uint8_t> out(sizeof(T));
  bytes::write_le<T>(out, 0, value);
  return out;
}
template <std::integral T>
[[nodiscard]] std::optional<T> decode_value(std::span<const std::uint8_t> data) {
  if (data.size() != sizeof(T)) return std::nullopt;
  return bytes::read_le<T>(data);
}

}  // namespace motion::canopen
