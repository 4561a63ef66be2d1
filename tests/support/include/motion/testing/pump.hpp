// Driving an EventLoop from a test: runs it until a condition holds or a timeout passes.
// Thread contract: the loop's thread (the test's).
#pragma once

#include <chrono>
#include <functional>

#include "motion/core/event_loop.hpp"

namespace motion::testing {

// Runs `loop` in rounds of at most `round` until `done()` or `timeout`; false on timeout.
bool pump_until(EventLoop& loop, const std::function<bool()>& done, std::chrono::milliseconds timeout,
                std::chrono::milliseconds round = std::chrono::milliseconds(5));

}  // namespace motion::testing
