#include "motion/testing/process_group.hpp"

#include "motion/testing/pump.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "motion/lcm/channels.hpp"
#include "motion/testing/lcm_url.hpp"

namespace motion::testing {

std::string bin_path(const std::string& name) {
  const char* dir = std::getenv("MOTION_BIN_DIR");
  return std::string(dir != nullptr ? dir : ".") + "/" + name;
}

std::string source_path(const std::string& relative) {
  const char* dir = std::getenv("MOTION_SOURCE_DIR");
  return std::string(dir != nullptr ? dir : ".") + "/" + relative;
}

ProcessGroup::ProcessGroup(std::string lcm_url, std::string prefix)
    : url_(lcm_url.empty() ? unique_lcm_url() : std::move(lcm_url)) {
  char tmpl[] = "/tmp/motion-test-XXXXXX";
  const char* made = ::mkdtemp(tmpl);
  dir_ = made != nullptr ? made : "/tmp";
  node_ = std::make_unique<lcm::Node>(loop_, lcm::NodeOptions{url_, std::move(prefix)});
  node_->subscribe<motionlcm::health_t>(
      lcm::channels::kHealth, [this](const motionlcm::health_t& h, const std::string&) { heartbeats_[h.process] = h; });
}

ProcessGroup::~ProcessGroup() {
  for (auto& c : children_) stop(c.pid);
  if (::testing::Test::HasFailure()) print_logs();
  std::error_code ec;
  std::filesystem::remove_all(dir_, ec);
}

pid_t ProcessGroup::start(const ProcessSpec& spec) {
  Child child{spec, -1, dir_ + "/" + spec.name + ".log", std::nullopt};
  for (char& ch : child.log_path)
    if (ch == ':') ch = '_';
  std::vector<std::string> argv_s{spec.binary.find('/') == std::string::npos ? bin_path(spec.binary) : spec.binary};
  argv_s.insert(argv_s.end(), spec.args.begin(), spec.args.end());
  argv_s.push_back("--lcm-url");
  argv_s.push_back(url_);
  std::vector<char*> argv;
  argv.reserve(argv_s.size() + 1);
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_s = spec.env;
  env_s.push_back("MOTION_SIM_DIR=" + dir_ + "/sim");
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);
    const int fd = ::open(child.log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
    }
    for (auto& e : env_s) ::putenv(e.data());
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    ::execv(argv[0], argv.data());
    std::fprintf(stderr, "exec %s failed: %s\n", argv[0], std::strerror(errno));
    ::_exit(127);
  }
  EXPECT_GT(pid, 0) << "fork failed for " << spec.name;
  child.pid = pid;
  children_.push_back(std::move(child));
  return pid;
}

int ProcessGroup::run_to_completion(const ProcessSpec& spec, std::string* output, std::chrono::milliseconds timeout) {
  const pid_t pid = start(spec);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::optional<int> status;
  while (!(status = exit_status(pid)) && std::chrono::steady_clock::now() < deadline) {
    loop_.run_once(std::chrono::milliseconds(10));
  }
  if (!status) {
    ADD_FAILURE() << spec.name << " did not finish within " << timeout.count() << " ms";
    stop(pid);
    status = -1;
  }
  if (output != nullptr) *output = log_of(spec.name);
  return *status;
}

bool ProcessGroup::pump_until(const std::function<bool()>& done, std::chrono::milliseconds timeout) {
  return testing::pump_until(loop_, done, timeout, std::chrono::milliseconds(10));
}

std::optional<motionlcm::health_t> ProcessGroup::heartbeat(const std::string& process) const {
  auto it = heartbeats_.find(process);
  if (it == heartbeats_.end()) return std::nullopt;
  return it->second;
}

bool ProcessGroup::wait_for_heartbeat(const std::string& process, std::chrono::milliseconds timeout,
                                      bool accept_degraded) {
  const bool ok = pump_until(
      [&] {
        auto it = heartbeats_.find(process);
        if (it == heartbeats_.end()) return false;
        return it->second.state == motionlcm::health_t::OK ||
               (accept_degraded && it->second.state == motionlcm::health_t::DEGRADED);
      },
      timeout);
  if (!ok) ADD_FAILURE() << "no OK heartbeat from '" << process << "' within " << timeout.count() << " ms on " << url_;
  return ok;
}

std::optional<int> ProcessGroup::exit_status(pid_t pid) {
  for (auto& c : children_) {
    if (c.pid != pid) continue;
    if (c.status) return c.status;
    int st = 0;
    if (::waitpid(pid, &st, WNOHANG) == pid) { c.status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st); }
    return c.status;
  }
  return std::nullopt;
}

void ProcessGroup::stop(pid_t pid) {
  if (exit_status(pid)) return;
  ::kill(pid, SIGTERM);
  for (int i = 0; i < 300 && !exit_status(pid); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  if (!exit_status(pid)) {
    ::kill(pid, SIGKILL);
    int st = 0;
    ::waitpid(pid, &st, 0);
    for (auto& c : children_)
      if (c.pid == pid) c.status = 128 + SIGKILL;
  }
}

std::string ProcessGroup::log_of(const std::string& name) const {
  for (const auto& c : children_) {
    if (c.spec.name != name) continue;
    std::ifstream in(c.log_path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  return {};
}

void ProcessGroup::print_logs() const {
  for (const auto& c : children_) {
    std::cout << "----- log of " << c.spec.name << " (pid " << c.pid << ") -----\n"
              << log_of(c.spec.name) << "----- end of " << c.spec.name << " -----\n";
  }
}

}  // namespace motion::testing
