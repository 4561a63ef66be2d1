#include "motion/can/transport.hpp"

namespace motion::can {

bool passes(const std::vector<Filter>& filters, const Frame& frame) {
  if (filters.empty()) return true;
  for (const auto& f : filters) {
    if (f.match_format && f.extended != frame.extended) continue;
    if ((frame.id & f.mask) == (f.id & f.mask)) return true;
  }
  return false;
}

std::size_t Transport::send_batch(std::span<const Frame> frames, std::error_code& error) {
  error = {};
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if ((error = send(frames[i]))) return i;
  }
  return frames.size();
}

const char* to_string(BusState state) {
  switch (state) {
    case BusState::kErrorActive: return "error-active";
    case BusState::kErrorWarning: return "error-warning";
    case BusState::kErrorPassive: return "error-passive";
    case BusState::kBusOff: return "bus-off";
    case BusState::kDisconnected: return "disconnected";
  }
  return "unknown";
}

}  // namespace motion::can
