#include "motion/canopen/master.hpp"

#include <algorithm>

namespace motion::canopen {

Master::Master(FrameSink sink, SdoClientConfig sdo_defaults)
    : sink_(std::move(sink)), nmt_(sink_), sdo_(sink_, sdo_defaults) {}

void Master::configure_sync(const SyncProducerConfig& config) { sync_.emplace(sink_, config); }

void Master::on_frame(const can::Frame& frame, TimePoint now) {
  if (sdo_.on_frame(frame, now) || nmt_.on_frame(frame, now) || emcy_.on_frame(frame, now)) return;
  if (unhandled_) unhandled_(frame, now);
}

TimePoint Master::process(TimePoint now) {
  TimePoint next = std::min(nmt_.process(now), sdo_.process(now));
  if (sync_) next = std::min(next, sync_->process(now));
  return next;
}

}  // namespace motion::canopen
