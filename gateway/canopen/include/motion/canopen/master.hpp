// The CiA 301 master core as one object: an NMT master / heartbeat consumer, an SDO client, a
// SYNC producer and an EMCY consumer sharing one frame sink, with one frame entry point and one
// deadline. PDO frames (and anything else the services do not consume) go to the PDO handler;
// decode them with unpack_pdo() against the mapping the driver configured.
//
// Thread contract: single-threaded, owned by the poll loop: on_frame() for every received
// frame, process(now) whenever the returned deadline passes or after issuing requests.
#pragma once

#include <functional>
#include <optional>

#include "motion/can_frame/frame.hpp"
#include "motion/canopen/emcy.hpp"
#include "motion/canopen/nmt_master.hpp"
#include "motion/canopen/sdo_client.hpp"
#include "motion/canopen/sync.hpp"
#include "motion/canopen/types.hpp"
#include "motion/core/clock.hpp"

namespace motion::canopen {

class Master {
 public:
  using FrameHandler = std::function<void(const can::Frame&, TimePoint now)>;

  explicit Master(FrameSink sink, SdoClientConfig sdo_defaults = {});

  [[nodiscard]] NmtMaster& nmt() { return nmt_; }
  [[nodiscard]] SdoClient& sdo() { return sdo_; }
  [[nodiscard]] EmcyConsumer& emcy() { return emcy_; }
  // nullptr until configure_sync().
  [[nodiscard]] SyncProducer* sync() { return sync_ ? &*sync_ : nullptr; }
  [[nodiscard]] const SyncProducer* sync() const { return sync_ ? &*sync_ : nullptr; }
  // Replaces the SYNC producer (stopped; call sync()->start(now)).
  void configure_sync(const SyncProducerConfig& config);

  // PDOs and frames no service consumed (TIME, foreign SDO requests, extended frames).
  void on_unhandled(FrameHandler handler) { unhandled_ = std::move(handler); }

  void on_frame(const can::Frame& frame, TimePoint now);
  TimePoint process(TimePoint now);

 private:
  FrameSink sink_;
  NmtMaster nmt_;
  SdoClient sdo_;
  EmcyConsumer emcy_;
  std::optional<SyncProducer> sync_;
  FrameHandler unhandled_;
};

}  // namespace motion::canopen
