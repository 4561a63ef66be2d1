#include "motion/testing/pump.hpp"

namespace motion::testing {

bool pump_until(EventLoop& loop, const std::function<bool()>& done, std::chrono::milliseconds timeout,
                std::chrono::milliseconds round) {
  const auto deadline = loop.now() + timeout;
  while (!done()) {
    if (loop.now() >= deadline) return false;
    loop.run_once(round);
  }
  return true;
}

}  // namespace motion::testing
