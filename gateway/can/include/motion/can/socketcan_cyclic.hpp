// Periodic frames sent by the kernel (SocketCAN broadcast manager, CAN_BCM): CANopen SYNC,
// heartbeats, cyclic RPDOs. The kernel's hrtimer sends them, so their timing does not depend on
// how busy the poll loop is.
//
// Threading/blocking: owned by one thread; no method blocks (each is one write to the BCM
// socket). Jobs are keyed by identifier (id + format), one frame per job. The jobs survive the
// interface going down and up; if the interface is removed and recreated (adapter replugged),
// call reopen(), which restarts every job on the new interface.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>

#include "motion/can_frame/frame.hpp"

namespace motion::can {

class SocketCanCyclic {
 public:
  SocketCanCyclic() = default;
  ~SocketCanCyclic();
  SocketCanCyclic(const SocketCanCyclic&) = delete;
  SocketCanCyclic& operator=(const SocketCanCyclic&) = delete;

  // Errors as SocketCanTransport::open() (they name the interface). Forgets previous jobs.
  std::error_code open(std::string_view interface);
  // Stops every job (closing the BCM socket deletes them in the kernel).
  void close();
  [[nodiscard]] bool is_open() const { return fd_ >= 0; }
  [[nodiscard]] std::string name() const { return interface_; }

  // Sends `frame` now and then every `period` (> 0) until stop(); replaces a job with the
  // same identifier (new period, new phase).
  std::error_code start(const Frame& frame, std::chrono::microseconds period);
  // New payload for a running job from its next transmission on; period and phase unchanged.
  // no_such_file_or_directory when no job has this frame's identifier.
  std::error_code update(const Frame& frame);
  std::error_code stop(std::uint32_t id, bool extended);
  // New interval (> 0) for a running job from its next timer run on: nothing sent now, the
  // phase kept. no_such_file_or_directory when no job has this identifier.
  std::error_code set_period(std::uint32_t id, bool extended, std::chrono::microseconds period);
  // Reopens the socket on the interface (after it was recreated) and restarts every job.
  std::error_code reopen();

  [[nodiscard]] std::size_t job_count() const { return jobs_.size(); }

 private:
  struct Job {
    Frame frame;
    std::chrono::microseconds period;
  };
  using JobKey = std::pair<std::uint32_t, bool>;  // id, extended

  enum class Timer : std::uint8_t { kKeep, kSet, kRestart };  // payload only / new interval / restart now
  std::error_code setup(const Frame& frame, std::chrono::microseconds period, Timer timer);

  std::string interface_;
  int fd_ = -1;
  std::map<JobKey, Job> jobs_;
};

}  // namespace motion::can
