// CiA 301 §7.2.4 SDO server, passive, for one node's default SDO channel (requests on 600h + n,
// responses on 580h + n). It runs the transfer protocol (expedited and segmented download and
// upload, toggle checking, stall timeout, client aborts) and hands whole values to the owner's
// object access handlers, which decide the abort codes of the object dictionary.
//  - Uploads of 1..4 bytes are answered expedited, longer ones segmented (or always segmented
//    with `segmented_uploads`, as the test vector D-27 expects).
//  - A segmented transfer that stalls longer than `segment_timeout` is aborted with 05040000h.
//  - Unknown or block-transfer command specifiers abort with 05040001h; a segment outside a
//    transfer too. A wrong toggle aborts with 05030000h. A segmented download whose byte count
//    differs from the announced size aborts with 06070010h.
//  - Block transfer is not supported (the UC57 does not offer it).
//
// Thread contract: single-threaded (the owner's loop); handlers run inside on_request().
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "motion/can_frame/frame.hpp"
#include "motion/canopen/errors.hpp"
#include "motion/canopen/sdo.hpp"
#include "motion/canopen/types.hpp"
#include "motion/core/clock.hpp"

namespace motion::canopen {

struct SdoReadResult {
  std::vector<std::uint8_t> data;     // the object's value, little-endian
  std::optional<SdoAbortCode> abort;  // set: refuse the upload with this code
};

struct SdoWrite {
  ObjectAddress object;
  std::span<const std::uint8_t> data;
  // False for an expedited download without size (0x22): `data` holds 4 bytes and the object's
  // type tells how many are meaningful.
  bool size_indicated = true;
};

struct SdoServerHandlers {
  std::function<SdoReadResult(ObjectAddress)> read;
  // nullopt = written; otherwise the abort code to answer.
  std::function<std::optional<SdoAbortCode>(const SdoWrite&)> write;
};

struct SdoServerConfig {
  Duration segment_timeout = std::chrono::seconds(1);
  bool segmented_uploads = false;  // answer every upload segmented (test vector D-27)
};

class SdoServer {
 public:
  SdoServer(NodeId node, FrameSink sink, SdoServerHandlers handlers, SdoServerConfig config = {});

  // True when `frame` is an SDO request to this node (600h + n) and was handled.
  bool on_request(const can::Frame& frame, TimePoint now);
  // Aborts a stalled segmented transfer; returns the next deadline (kNever when idle).
  TimePoint process(TimePoint now);
  [[nodiscard]] TimePoint next_deadline() const { return transfer_ ? transfer_->deadline : kNever; }
  // Drops any transfer in progress without a frame (NMT reset communication, power loss).
  void reset() { transfer_.reset(); }
  [[nodiscard]] bool in_transfer() const { return transfer_.has_value(); }

 private:
  enum class Direction : std::uint8_t { kUpload, kDownload };
  struct Transfer {
    Direction direction = Direction::kUpload;
    ObjectAddress object;
    std::vector<std::uint8_t> data;          // upload: the value; download: bytes so far
    std::optional<std::uint32_t> announced;  // download: size from the initiate
    std::size_t offset = 0;                  // upload: bytes already sent
    bool toggle = false;                     // expected in the next segment
    TimePoint deadline = kNever;
  };

  void abort(ObjectAddress object, SdoAbortCode code);
  void on_initiate_download(const SdoInitiateDownloadRequest& request, TimePoint now);
  void on_download_segment(const SdoDownloadSegmentRequest& request, TimePoint now);
  void on_initiate_upload(ObjectAddress object, TimePoint now);
  void on_upload_segment(bool toggle, TimePoint now);

  NodeId node_;
  FrameSink sink_;
  SdoServerHandlers handlers_;
  SdoServerConfig config_;
  std::optional<Transfer> transfer_;
};

}  // namespace motion::canopen
