// CanBusDriver (can_bus_driver.hpp): the kernel's cyclic jobs (CAN_BCM) on a SocketCAN bus.
#include <spdlog/spdlog.h>

#include <algorithm>

#include "motion/can/socketcan.hpp"
#include "motion/gateway/can_bus_driver.hpp"

namespace motion::gateway {

void CanBusDriver::use_cyclic(std::unique_ptr<can::SocketCanCyclic> cyclic) { cyclic_ = std::move(cyclic); }

CanBusDriver::CyclicJob* CanBusDriver::cyclic_job(const can::Frame& frame) {
  const auto it = std::find_if(cyclic_jobs_.begin(), cyclic_jobs_.end(), [&](const CyclicJob& job) {
    return job.frame.id == frame.id && job.frame.extended == frame.extended;
  });
  return it == cyclic_jobs_.end() ? nullptr : &*it;
}

bool CanBusDriver::start_cyclic(const can::Frame& frame, Duration period) {
  if (!cyclic_) return false;
  CyclicJob* job = cyclic_job(frame);
  if (job == nullptr) job = &cyclic_jobs_.emplace_back();
  const std::int64_t before = wall_time_us();
  if (const auto ec = cyclic_->start(frame, std::chrono::duration_cast<std::chrono::microseconds>(period))) {
    spdlog::debug("bus {}: kernel cyclic {} refused: {}", bus_, can::to_cansend(frame), ec.message());
    return false;
  }
  job->frame = frame;
  job->running = true;
  job->started_us = before;
  job->first_pending = true;
  for (const auto id : job->start_commands) cyclic_starts_.erase(id);  // a restart before its frame was seen
  job->start_commands.clear();
  return true;
}

void CanBusDriver::stop_cyclic(const can::Frame& frame) {
  CyclicJob* job = cyclic_job(frame);
  if (!cyclic_ || job == nullptr || !job->running) return;
  if (const auto ec = cyclic_->stop(frame.id, frame.extended))
    spdlog::debug("bus {}: kernel cyclic {} stop: {}", bus_, can::to_cansend(frame), ec.message());
  job->running = false;
  job->stopped_us = wall_time_us();
}

bool CanBusDriver::retime_cyclic(const can::Frame& frame, Duration interval) {
  const CyclicJob* job = cyclic_job(frame);
  if (!cyclic_ || job == nullptr || !job->running) return false;
  return !cyclic_->set_period(frame.id, frame.extended,
                              std::chrono::duration_cast<std::chrono::microseconds>(interval));
}

bool CanBusDriver::take_cyclic(const can::Frame& frame, TimePoint now) {
  CyclicJob* job = nullptr;
  for (auto& j : cyclic_jobs_) {
    // Received frames carry the kernel's receive time (SO_TIMESTAMP, the wall clock).
    if (j.frame == frame && (j.running || frame.timestamp_us <= j.stopped_us)) job = &j;
  }
  if (job == nullptr) return false;
  if (job->first_pending && job->running && frame.timestamp_us >= job->started_us) {
    job->first_pending = false;
    for (const auto id : std::exchange(job->start_commands, {})) {
      cyclic_starts_.erase(id);
      release_started(id, frame.timestamp_us);
    }
  }
  if (tap_) tap_(frame, true);
  for (auto& s : stacks_) call(s.get(), [&](CanStack& stack) { stack.on_cyclic_sent(frame, now); });
  return true;
}

void CanBusDriver::reopen_cyclic_if_recreated() {
  if (!cyclic_) return;
  const auto* socketcan = dynamic_cast<const can::SocketCanTransport*>(transport_.get());
  if (socketcan == nullptr || socketcan->counters().reopens == seen_reopens_) return;
  seen_reopens_ = socketcan->counters().reopens;
  // The interface was removed and created again: the old BCM socket is bound to an index that
  // is gone. Its running jobs restart on the new one (each sends one frame at once).
  const std::int64_t before = wall_time_us();
  if (const auto ec = cyclic_->reopen()) {
    spdlog::warn("bus {}: kernel cyclic sender not reopened ({}); the loop sends the periodic frames", bus_,
                 ec.message());
  }
  for (auto& job : cyclic_jobs_) {
    if (job.running) job.started_us = before;
  }
}

}  // namespace motion::gateway
