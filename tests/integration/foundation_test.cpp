// The foundation's promise: every process of the simulated lab starts on its own LCM URL, is seen
// by `motionctl health`, refuses bad configurations with a clear error, and stops cleanly.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <sched.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "motion/config/config.hpp"
#include "motion/testing/process_group.hpp"

namespace motion::testing {
namespace {

using std::chrono::seconds;

TEST(Foundation, AllProcessesOfTheSimLabHeartbeatAndMotionctlSeesThem) {
  ProcessGroup group;
  const std::string config = source_path("config/sim-lab.yaml");
  const auto lab = config::load_file(config);
  ASSERT_TRUE(lab.ok()) << lab.error_text();

  std::vector<pid_t> pids;
  pids.push_back(group.start({"sim", "motion-sim", {"--config", config}, {}}));
  std::vector<std::string> expected{"sim", "coordinator"};
  for (const auto& bus : lab.config->buses) {
    pids.push_back(group.start({"gateway:" + bus.name, "motion-gateway", {"--config", config, "--bus", bus.name}, {}}));
    expected.push_back("gateway:" + bus.name);
  }
  pids.push_back(group.start({"coordinator", "motion-coordinator", {"--config", config}, {}}));
  // Until every family has its simulator and driver, sim and gateways may report DEGRADED.
  for (const auto& name : expected) ASSERT_TRUE(group.wait_for_heartbeat(name, std::chrono::seconds(15), true)) << name;

  std::vector<std::string> args{"--config", config, "health", "--listen", "5"};
  for (const auto& name : expected) {
    args.push_back("--expect");
    args.push_back(name);
  }
  std::string out;
  EXPECT_EQ(group.run_to_completion({"motionctl-health", "motionctl", args, {}}, &out), 0) << out;
  for (const auto& name : expected) EXPECT_NE(out.find(name), std::string::npos) << name << " missing in:\n" << out;

  // SIGTERM stops each process cleanly with exit code 0.
  for (pid_t pid : pids) {
    group.stop(pid);
    EXPECT_EQ(group.exit_status(pid), 0);
  }
}

// --json is honoured by every command that has a JSON form (config: its summary, the lists and
// values) and refused, naming why, by those that speak another format (dump, send).
TEST(Foundation, MotionctlConfigAnswersInJsonAndDumpRefusesIt) {
  ProcessGroup group;
  const std::string config = source_path("config/sim-lab.yaml");
  std::string out;
  ASSERT_EQ(group.run_to_completion({"config-json", "motionctl", {"--config", config, "--json", "config"}, {}}, &out),
            0)
      << out;
  const auto doc = nlohmann::json::parse(out.substr(std::min(out.find('{'), out.size())), nullptr, false);
  ASSERT_TRUE(doc.is_object()) << out;
  EXPECT_EQ(doc["valid"], true);
  const auto loaded = config::load_file(config);
  ASSERT_TRUE(loaded.ok());
  ASSERT_EQ(doc["axes"].size(), loaded.config->axes.size());
  ASSERT_EQ(doc["buses"].size(), loaded.config->buses.size());
  const auto& first = loaded.config->axes.front();
  EXPECT_EQ(doc["axes"][0]["name"], first.name);
  EXPECT_EQ(doc["axes"][0]["limits"]["max"].get<double>(), first.limits.max_position);
  EXPECT_EQ(doc["axes"][0]["invert"].is_boolean(), true);

  ASSERT_EQ(group.run_to_completion(
                {"config-axes-json", "motionctl", {"--config", config, "--json", "config", "axes"}, {}}, &out),
            0)
      << out;
  const auto names = nlohmann::json::parse(out.substr(std::min(out.find('['), out.size())), nullptr, false);
  ASSERT_TRUE(names.is_array()) << out;
  EXPECT_EQ(names.size(), loaded.config->axes.size());
  EXPECT_EQ(names[0], first.name);

  EXPECT_EQ(group.run_to_completion(
                {"dump-json", "motionctl", {"--config", config, "--json", "dump", "can0", "--for", "0.2"}, {}}, &out),
            2)
      << out;
  EXPECT_NE(out.find("motionctl dump: --json is not supported"), std::string::npos) << out;
}

TEST(Foundation, MotionctlHealthFailsWhenAnExpectedProcessIsMissing) {
  ProcessGroup group;
  std::string out;
  const int rc = group.run_to_completion(
      {"motionctl-health",
       "motionctl",
       {"--config", source_path("config/sim-lab.yaml"), "health", "--listen", "0.5", "--expect", "coordinator"},
       {}},
      &out);
  EXPECT_EQ(rc, 4) << out;
  EXPECT_NE(out.find("no heartbeat from 'coordinator'"), std::string::npos) << out;
}

TEST(Foundation, EveryProgramRefusesABrokenConfigBeforeDoingAnything) {
  ProcessGroup group;
  const std::string bad = group.work_dir() + "/bad.yaml";
  std::ofstream(bad) << "buses:\n  - name: can0\n    transport: simcan:can0\n    bitrate: 7\n";
  for (const auto& [binary, extra] :
       std::vector<std::pair<std::string, std::vector<std::string>>>{{"motion-gateway", {"--bus", "can0"}},
                                                                     {"motion-coordinator", {}},
                                                                     {"motion-sim", {}},
                                                                     {"motionctl", {"health"}}}) {
    std::vector<std::string> args{"--config", bad};
    args.insert(args.end(), extra.begin(), extra.end());
    std::string out;
    EXPECT_EQ(group.run_to_completion({binary, binary, args, {}}, &out), 3) << binary << ": " << out;
    EXPECT_NE(out.find("bad.yaml:4:14: buses[0].bitrate: not a CAN bit rate: 7"), std::string::npos)
        << binary << ": " << out;
  }
}

TEST(Foundation, ProgramsAnswerHelpAndVersion) {
  ProcessGroup group;
  for (const std::string binary : {"motion-gateway", "motion-coordinator", "motion-sim", "motionctl"}) {
    std::string out;
    EXPECT_EQ(group.run_to_completion({binary + "-version", binary, {"--version"}, {}}, &out), 0) << out;
    EXPECT_NE(out.find("0.1.0"), std::string::npos) << binary << ": " << out;
    EXPECT_EQ(group.run_to_completion({binary + "-help", binary, {"--help"}, {}}, &out), 0) << out;
    EXPECT_NE(out.find("--config"), std::string::npos) << binary << ": " << out;
  }
}

// Whether this host lets a process take SCHED_FIFO at `priority` (a child tries, so this test's
// own thread keeps its scheduling).
bool host_permits_fifo(int priority) {
  const pid_t child = ::fork();
  if (child == 0) {
    sched_param param{};
    param.sched_priority = priority;
    ::_exit(::sched_setscheduler(0, SCHED_FIFO, &param) == 0 ? 0 : 1);
  }
  int status = 0;
  return child > 0 && ::waitpid(child, &status, 0) == child && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

// The simulated lab's configuration with `line` (a key of the first bus, can0) added, written in
// the group's folder as `name`: its path ("" when the lab file has no such bus).
std::string lab_with_can0_key(ProcessGroup& group, const std::string& line, const std::string& name) {
  std::ifstream in(source_path("config/sim-lab.yaml"));
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  const std::string anchor = "    poll_hz: 20\n";  // the first bus, can0
  if (yaml.find(anchor) == std::string::npos) return "";
  yaml.insert(yaml.find(anchor) + anchor.size(), line);
  const std::string config = group.work_dir() + "/" + name;
  std::ofstream(config) << yaml;
  return config;
}

// realtime_priority: the gateway's loop thread runs under SCHED_FIFO where the host permits it,
// and says why not where it does not; its position-record writer, which waits on the disk, never
// runs under it.
TEST(Foundation, AGatewayAskedForRealtimeRunsItsLoopUnderSchedFifoOrSaysWhyNot) {
  ProcessGroup group;
  const std::string config = lab_with_can0_key(group, "    realtime_priority: 20\n", "realtime.yaml");
  ASSERT_FALSE(config.empty());

  const bool permitted = host_permits_fifo(20);
  const pid_t gateway = group.start({"gateway:can0", "motion-gateway", {"--config", config, "--bus", "can0"}, {}});
  ASSERT_TRUE(group.wait_for_heartbeat("gateway:can0", seconds(15), true)) << group.log_of("gateway:can0");
  const std::string said = permitted ? "running under SCHED_FIFO at priority 20" : "realtime_priority 20 refused";
  EXPECT_TRUE(group.pump_until([&] { return group.log_of("gateway:can0").find(said) != std::string::npos; },
                               std::chrono::milliseconds(5000)))
      << group.log_of("gateway:can0");

  // Every thread of the gateway: the loop (tid = pid) and the record writer.
  std::map<pid_t, int> policies;
  for (const auto& task : std::filesystem::directory_iterator("/proc/" + std::to_string(gateway) + "/task")) {
    const pid_t tid = std::stoi(task.path().filename().string());
    policies[tid] = ::sched_getscheduler(tid);
  }
  ASSERT_GE(policies.size(), 2u) << "the loop and the position record's writer";
  EXPECT_EQ(policies.at(gateway), permitted ? SCHED_FIFO : SCHED_OTHER);
  if (permitted) {
    sched_param param{};
    ASSERT_EQ(::sched_getparam(gateway, &param), 0);
    EXPECT_EQ(param.sched_priority, 20);
  }
  for (const auto& [tid, policy] : policies) {
    if (tid != gateway) { EXPECT_EQ(policy, SCHED_OTHER) << "thread " << tid; }
  }
  group.stop(gateway);
  EXPECT_EQ(group.exit_status(gateway), 0);
}

// sched_slice_us: under normal scheduling the gateway's loop runs with the slice it asked for,
// where the kernel takes one (Linux 6.12 and later); an older kernel's refusal is said.
TEST(Foundation, AGatewayAskedForASliceRunsItsLoopWithItOrSaysTheKernelTakesNone) {
  ProcessGroup group;
  const std::string config = lab_with_can0_key(group, "    sched_slice_us: 500\n", "slice.yaml");
  ASSERT_FALSE(config.empty());
  const pid_t gateway = group.start({"gateway:can0", "motion-gateway", {"--config", config, "--bus", "can0"}, {}});
  ASSERT_TRUE(group.wait_for_heartbeat("gateway:can0", seconds(15), true)) << group.log_of("gateway:can0");
  const std::string taken = "the loop's slice is 500 us";
  const std::string none = "this kernel takes no slice of a thread's own";
  ASSERT_TRUE(group.pump_until(
      [&] {
        const std::string log = group.log_of("gateway:can0");
        return log.find(taken) != std::string::npos || log.find(none) != std::string::npos;
      },
      std::chrono::milliseconds(5000)))
      << group.log_of("gateway:can0");
  // The loop thread's sched_attr (tid = pid), its first version: sched_runtime at bytes 24..31.
  std::array<std::uint64_t, 6> attr{};
  ASSERT_EQ(::syscall(SYS_sched_getattr, gateway, attr.data(), sizeof attr, 0), 0) << std::strerror(errno);
  const std::uint64_t runtime_ns = attr[3];
  if (group.log_of("gateway:can0").find(taken) != std::string::npos) {
    EXPECT_EQ(runtime_ns, 500'000u);
  } else {
    EXPECT_EQ(runtime_ns, 0u);
  }
  EXPECT_EQ(::sched_getscheduler(gateway), SCHED_OTHER);
  group.stop(gateway);
  EXPECT_EQ(group.exit_status(gateway), 0);
}

}  // namespace
}  // namespace motion::testing
