#include "simbus_bench_links.hpp"

#include <algorithm>

namespace motion::simbus::bench {
namespace {

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

}  // namespace

StreamResult stream(Link& link, const can::Frame& frame, std::uint64_t count, std::uint64_t window,
                    std::chrono::milliseconds timeout) {
  StreamResult r;
  const auto start = Clock::now();
  const auto deadline = start + timeout;
  while (r.received < count && Clock::now() < deadline) {
    bool full = false;
    while (r.sent < count && r.sent - r.received < window) {
      const auto result = link.send(frame);
      if (result == SendResult::kFull) {
        full = true;
        break;
      }
      if (result == SendResult::kError) {
        std::fprintf(stderr, "bench_simbus: send failed\n");
        std::exit(2);
      }
      ++r.sent;
    }
    pollfd p{link.rx_fd(), POLLIN, 0};
    ::poll(&p, 1, full ? 1 : 100);
    while (auto f = link.receive()) {
      if (r.received == 0) r.first_ts_us = f->timestamp_us;
      r.last_ts_us = f->timestamp_us;
      ++r.received;
    }
    link.drain_tx_side();
  }
  r.wall_s = seconds_since(start);
  return r;
}

Percentiles one_way_latency(Link& link, const can::Frame& frame, int samples) {
  std::vector<double> us;
  us.reserve(static_cast<std::size_t>(samples));
  for (int i = 0; i < samples; ++i) {
    const auto t0 = Clock::now();
    if (link.send(frame) != SendResult::kOk) continue;
    bool got = false;
    const auto deadline = t0 + std::chrono::seconds(1);
    while (!got && Clock::now() < deadline) {
      pollfd p{link.rx_fd(), POLLIN, 0};
      ::poll(&p, 1, 100);
      while (link.receive()) got = true;
    }
    if (got) us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    link.drain_tx_side();
  }
  std::sort(us.begin(), us.end());
  Percentiles out;
  out.samples = us.size();
  if (us.empty()) return out;
  auto at = [&us](double q) {
    return us[std::min(us.size() - 1, static_cast<std::size_t>(q * static_cast<double>(us.size())))];
  };
  out.p50 = at(0.50);
  out.p99 = at(0.99);
  return out;
}

}  // namespace motion::simbus::bench
