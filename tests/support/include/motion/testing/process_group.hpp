// Integration-test harness: starts motion-* processes on the test's own LCM URL, waits for their
// readiness by heartbeat (never by sleeping), prints their logs into the test output when the test
// failed, and always kills them (SIGTERM, then SIGKILL) in its destructor. Children also get
// PR_SET_PDEATHSIG so a crashed test cannot leave them behind.
//
// Thread contract: single-threaded (the test's thread); the LCM node runs on an internal loop
// pumped by the wait functions.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <motionlcm/health_t.hpp>

#include "motion/core/event_loop.hpp"
#include "motion/lcm/node.hpp"

namespace motion::testing {

struct ProcessSpec {
  std::string name;               // for logs, e.g. "gateway:can0"
  std::string binary;             // file name in $MOTION_BIN_DIR, or an absolute path
  std::vector<std::string> args;  // --lcm-url is appended by the group
  std::vector<std::string> env;   // extra NAME=VALUE entries
};

class ProcessGroup {
 public:
  // `lcm_url` empty: unique_lcm_url(). `prefix`: the channel prefix of the config in use.
  explicit ProcessGroup(std::string lcm_url = {}, std::string prefix = "MOTION_");
  ~ProcessGroup();
  ProcessGroup(const ProcessGroup&) = delete;
  ProcessGroup& operator=(const ProcessGroup&) = delete;

  [[nodiscard]] const std::string& lcm_url() const { return url_; }
  [[nodiscard]] const std::string& work_dir() const { return dir_; }  // per-test temp dir
  EventLoop& loop() { return loop_; }
  lcm::Node& node() { return *node_; }

  // Starts a process; returns its pid (the test fails on exec errors).
  pid_t start(const ProcessSpec& spec);
  // Runs a command to completion (e.g. motionctl), capturing stdout+stderr. Returns exit code.
  int run_to_completion(const ProcessSpec& spec, std::string* output,
                        std::chrono::milliseconds timeout = std::chrono::seconds(30));

  // Pumps LCM until `process` heartbeats with state OK (or also DEGRADED when `accept_degraded`),
  // or the timeout. False on timeout (the test fails, and the logs are printed at teardown).
  bool wait_for_heartbeat(const std::string& process, std::chrono::milliseconds timeout = std::chrono::seconds(15),
                          bool accept_degraded = false);
  // The latest heartbeat heard from `process`, if any.
  [[nodiscard]] std::optional<motionlcm::health_t> heartbeat(const std::string& process) const;
  // Pumps the loop until `done()` or the timeout.
  bool pump_until(const std::function<bool()>& done, std::chrono::milliseconds timeout);

  void stop(pid_t pid);                                     // SIGTERM, wait up to 3 s, then SIGKILL
  [[nodiscard]] std::optional<int> exit_status(pid_t pid);  // nullopt while running
  [[nodiscard]] std::string log_of(const std::string& name) const;
  void print_logs() const;

 private:
  struct Child {
    ProcessSpec spec;
    pid_t pid;
    std::string log_path;
    std::optional<int> status;
  };
  std::string url_;
  std::string dir_;
  EventLoop loop_;
  std::unique_ptr<lcm::Node> node_;
  std::map<std::string, motionlcm::health_t> heartbeats_;
  std::vector<Child> children_;
};

// Path of a built program: $MOTION_BIN_DIR/<name>.
std::string bin_path(const std::string& name);
// Path under the source tree: $MOTION_SOURCE_DIR/<relative>.
std::string source_path(const std::string& relative);

}  // namespace motion::testing
