// What the multi-process benchmarks (bench_e2e, bench_lab) share: starting the lab's processes
// (each killed with this one: PR_SET_PDEATHSIG) and stopping them by pid, percentiles, and a raw
// LCM echo peer for the round-trip floor. Header-only, for the bench_* programs.
// Thread contract: the caller's thread, except Echo, which answers on a thread of its own.
#pragma once

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <lcm/lcm-cpp.hpp>

namespace motion::bench {

using Steady = std::chrono::steady_clock;

inline double us_between(Steady::time_point a, Steady::time_point b) {
  return std::chrono::duration<double, std::micro>(b - a).count();
}

inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double rank = p / 100.0 * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(rank));
  const auto hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (v[hi] - v[lo]) * (rank - static_cast<double>(lo));
}

// ---- child processes ----

struct Child {
  std::string name;
  pid_t pid = -1;
};

// `fifo_priority` > 0: the child (and every thread it creates) runs under SCHED_FIFO at that
// priority where the host permits it, else under normal scheduling (a note in its log).
// `nice_value`: the child's (and its threads') nice value under normal scheduling.
inline pid_t spawn(const std::string& binary, const std::vector<std::string>& args, const std::string& sim_dir,
                   const std::string& log, int fifo_priority = 0, int nice_value = 0) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (nice_value != 0) (void)::setpriority(PRIO_PROCESS, 0, nice_value);
  const bool fifo_refused = [&] {
    if (fifo_priority <= 0) return false;
    sched_param param{};
    param.sched_priority = fifo_priority;
    return ::sched_setscheduler(0, SCHED_FIFO, &param) != 0;
  }();
  ::setenv("MOTION_SIM_DIR", sim_dir.c_str(), 1);
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd >= 0) {
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::close(fd);
  }
  if (fifo_refused) std::fprintf(stderr, "bench: SCHED_FIFO %d refused: normal scheduling\n", fifo_priority);
  std::vector<std::string> all{binary};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  argv.reserve(all.size() + 1);
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  ::execv(argv[0], argv.data());
  std::perror("execv");
  ::_exit(127);
}

inline void stop_all(std::vector<Child>& children) {
  for (const auto& c : children) {
    if (c.pid > 0) ::kill(c.pid, SIGTERM);
  }
  const auto deadline = Steady::now() + std::chrono::seconds(3);
  for (auto& c : children) {
    while (c.pid > 0) {
      int status = 0;
      if (::waitpid(c.pid, &status, WNOHANG) == c.pid) {
        c.pid = -1;
      } else if (Steady::now() > deadline) {
        ::kill(c.pid, SIGKILL);
        ::waitpid(c.pid, &status, 0);
        c.pid = -1;
      } else {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    }
  }
}

// The lab's programs as children: each started from `bin` with the common arguments (the
// configuration, the LCM URL, warn logs; info logs with BENCH_E2E_VERBOSE or BENCH_LAB_VERBOSE,
// e.g. a gateway's late starts), MOTION_SIM_DIR = `sim_dir`, its output in <log_dir>/<name>.log.
// stop_all(children()) ends them.
class LabPrograms {
 public:
  LabPrograms(std::string bin, const std::string& config_path, const std::string& url, std::string sim_dir,
              std::string log_dir)
      : bin_(std::move(bin)),
        common_{"--config",
                config_path,
                "--lcm-url",
                url,
                "--log-level",
                std::getenv("BENCH_E2E_VERBOSE") != nullptr || std::getenv("BENCH_LAB_VERBOSE") != nullptr ? "info"
                                                                                                           : "warn"},
        sim_dir_(std::move(sim_dir)),
        log_dir_(std::move(log_dir)) {}
  void start(const std::string& name, const std::string& program, std::vector<std::string> extra, int fifo_priority = 0,
             int nice_value = 0) {
    extra.insert(extra.begin(), common_.begin(), common_.end());
    children_.push_back({name, spawn(bin_ + "/" + program, extra, sim_dir_, log_dir_ + "/" + name + ".log",
                                     fifo_priority, nice_value)});
  }
  std::vector<Child>& children() { return children_; }

 private:
  std::string bin_;
  std::vector<std::string> common_;
  std::string sim_dir_;
  std::string log_dir_;
  std::vector<Child> children_;
};

// ---- raw LCM echo peer ----

class Echo {
 public:
  Echo(const std::string& url, std::string ping, std::string pong)
      : lcm_(url), ping_(std::move(ping)), pong_(std::move(pong)) {
    lcm_.subscribe(ping_, &Echo::on_ping, this);
    thread_ = std::thread([this] {
      while (!stop_) lcm_.handleTimeout(50);
    });
  }
  ~Echo() {
    stop_ = true;
    thread_.join();
  }
  Echo(const Echo&) = delete;
  Echo& operator=(const Echo&) = delete;
  [[nodiscard]] bool ok() { return lcm_.good(); }

 private:
  void on_ping(const ::lcm::ReceiveBuffer* rbuf, const std::string&) {
    lcm_.publish(pong_, rbuf->data, rbuf->data_size);
  }
  ::lcm::LCM lcm_;
  std::string ping_;
  std::string pong_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace motion::bench
