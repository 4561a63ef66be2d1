// Across machines, with security enforced: three "hosts" are network namespaces (motion-<pid>-a/b/c), each with one veth
// port on a Linux bridge in a fourth namespace (motion-<pid>-br) and a multicast route, set up by
// tools/netns/motion-netns. LCM runs over UDP multicast with TTL 1, as on a real lab network:
// motion-sim and the gateways in host A (they share MOTION_SIM_DIR: unix sockets are file-system
// objects and work across network namespaces), the coordinator in host B, motionctl in host C.
// Programs start as `ip netns exec NS prog`, which execs prog in place, so the ProcessGroup's pid
// is the program's own and its teardown kills the real process; the namespaces are deleted after
// the processes, also when the test fails. Without root / CAP_NET_ADMIN the tests are skipped with
// the reason.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "motion/config/config.hpp"
#include "motion/security/keys.hpp"
#include "motion/testing/lab_keys.hpp"
#include "motion/testing/lcm_url.hpp"
#include "motion/testing/process_group.hpp"

namespace motion::testing {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::seconds;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Runs a shell command; its exit code, stdout+stderr in `out`.
int shell(const std::string& command, std::string* out = nullptr) {
  std::FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return -1;
  std::string text;
  char buf[512];
  while (std::fgets(buf, sizeof buf, p) != nullptr) text += buf;
  const int st = ::pclose(p);
  if (out != nullptr) *out = text;
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

std::string ip_binary() {
  for (const char* p : {"/usr/sbin/ip", "/sbin/ip", "/usr/bin/ip", "/bin/ip"}) {
    if (::access(p, X_OK) == 0) return p;
  }
  return {};
}

// Why network namespaces cannot be used here, or nullopt when they can.
std::optional<std::string> netns_unavailable() {
  if (ip_binary().empty()) return "iproute2's `ip` is not installed";
  if (::geteuid() != 0)
    return "creating network namespaces needs root (CAP_NET_ADMIN + CAP_SYS_ADMIN); uid is " +
           std::to_string(::geteuid());
  const std::string probe = "motion-" + std::to_string(::getpid()) + "-probe";
  std::string out;
  if (shell(ip_binary() + " netns add " + probe, &out) != 0)
    return "`ip netns add` failed (no CAP_NET_ADMIN / CAP_SYS_ADMIN?): " + out;
  shell(ip_binary() + " netns del " + probe);
  return std::nullopt;
}

// A process that exists and is not a zombie (a killed test stays one until it is reaped).
bool alive(pid_t pid) {
  if (::kill(pid, 0) != 0 && errno == ESRCH) return false;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
  const auto paren = text.rfind(')');
  return paren == std::string::npos || paren + 2 >= text.size() || text[paren + 2] != 'Z';
}

// Namespaces left by an earlier run of this test that was killed (its pid is gone).
void delete_stale_namespaces() {
  std::string list;
  if (shell(ip_binary() + " netns list", &list) != 0) return;
  const std::regex name(R"(^motion-([0-9]+)-(a|b|c|d|br|probe)\b)");
  std::istringstream lines(list);
  for (std::string line; std::getline(lines, line);) {
    std::smatch m;
    if (!std::regex_search(line, m, name)) continue;
    const auto pid = static_cast<pid_t>(std::stol(m[1]));
    if (pid == ::getpid() || !alive(pid)) shell(ip_binary() + " netns del " + m[0].str());
  }
}

// The lab network; deleted in the destructor whatever happened.
class NetnsLab {
 public:
  explicit NetnsLab(std::string prefix) : prefix_(std::move(prefix)) {}
  ~NetnsLab() {
    if (!created_) return;
    std::string out;
    if (shell(script() + " down " + prefix_, &out) != 0)
      ADD_FAILURE() << "could not delete the namespaces " << prefix_ << "-*: " << out;
  }
  NetnsLab(const NetnsLab&) = delete;
  NetnsLab& operator=(const NetnsLab&) = delete;

  ::testing::AssertionResult up(const std::vector<std::string>& hosts) {
    created_ = true;  // a half-made lab is deleted too
    std::string cmd = script() + " up " + prefix_;
    for (const auto& h : hosts) cmd += " " + h;
    std::string out;
    if (shell(cmd, &out) != 0) return ::testing::AssertionFailure() << cmd << " failed:\n" << out;
    return ::testing::AssertionSuccess();
  }
  [[nodiscard]] std::string ns(const std::string& host) const { return prefix_ + "-" + host; }
  [[nodiscard]] const std::string& prefix() const { return prefix_; }
  // `ip netns exec NS program args...` (the group appends --lcm-url).
  [[nodiscard]] ProcessSpec in(const std::string& host, const std::string& name, const std::string& program,
                               std::vector<std::string> args) const {
    std::vector<std::string> argv{"netns", "exec", ns(host), bin_path(program)};
    argv.insert(argv.end(), args.begin(), args.end());
    return {name, ip_binary(), argv, {}};
  }
  [[nodiscard]] bool exists(const std::string& host) const {
    std::string list;
    shell(ip_binary() + " netns list", &list);
    return std::regex_search(list, std::regex("(^|\n)" + ns(host) + "( |\n|$)"));
  }

 private:
  static std::string script() { return source_path("tools/netns/motion-netns"); }
  std::string prefix_;
  bool created_ = false;
};

// The test's own multicast port, TTL 1: one hop, the lab's L2 segment.
std::string lab_url(int ttl) {
  std::string url = unique_lcm_url(2);
  return url.substr(0, url.find('?')) + "?ttl=" + std::to_string(ttl);
}

class MultiHost : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto reason = netns_unavailable()) GTEST_SKIP() << "network namespaces unavailable: " << *reason;
    delete_stale_namespaces();
    config_path_ = source_path("config/sim-lab.yaml");
    auto loaded = config::load_file(config_path_);
    ASSERT_TRUE(loaded.ok()) << loaded.error_text();
    config_ = *loaded.config;
  }

  // Runs motionctl in `host` to completion.
  int motionctl(ProcessGroup& group, const std::string& host, std::vector<std::string> args, std::string* out,
                seconds timeout = seconds(40)) {
    std::vector<std::string> argv{"--config", config_path_};
    argv.insert(argv.end(), args.begin(), args.end());
    return group.run_to_completion(
        net_.in(host, "motionctl-" + host + "-" + std::to_string(++runs_), "motionctl", argv), out, timeout);
  }

  // Security enforced, as a lab network should run: the coordinator's key pair (gateways verify
  // its commands and triggers with the public half), and the operator key of host C's motionctl
  // (`*key`). Host A: the simulated drives and one gateway per bus; host B: the coordinator, whose
  // pid is returned. `*expect`: every process name that heartbeats.
  pid_t start_enforced_lab(ProcessGroup& group, std::vector<std::string>* expect, std::string* key) {
    const std::string dir = group.work_dir();
    const auto op = security::KeyPair::generate("op");
    {
      std::ifstream base(config_path_);
      std::ofstream config(dir + "/lab.yaml");
      config << base.rdbuf() << motion::testing::enforced_security();
    }
    EXPECT_EQ(motion::testing::write_lab_keys(dir, {op.authorized_line("operate")}), std::nullopt);
    EXPECT_EQ(security::write_key_pair(op, dir, "operate"), std::nullopt);
    config_path_ = dir + "/lab.yaml";
    *key = dir + "/op.key";
    *expect = {"sim", "coordinator"};
    group.start(net_.in("a", "sim", "motion-sim", {"--config", config_path_}));
    for (const auto& bus : config_.buses) {
      group.start(net_.in("a", "gateway:" + bus.name, "motion-gateway", {"--config", config_path_, "--bus", bus.name}));
      expect->push_back("gateway:" + bus.name);
    }
    return group.start(net_.in("b", "coordinator", "motion-coordinator", {"--config", config_path_}));
  }

  // Members are destroyed in reverse: the processes (group) before the namespaces (net_).
  NetnsLab net_{"motion-" + std::to_string(::getpid())};
  std::string config_path_;
  config::Config config_;
  int runs_ = 0;
};

TEST_F(MultiHost, GatewaysCoordinatorAndClientOnThreeHostsCompleteASynchronizedMove) {
  const auto t0 = Clock::now();
  ASSERT_TRUE(net_.up({"a", "b", "c"}));
  const double t_net = seconds_since(t0);
  ProcessGroup group(lab_url(1));
  std::vector<std::string> expect;
  std::string key;
  const pid_t coordinator = start_enforced_lab(group, &expect, &key);

  // Host C hears every process's heartbeat over the bridge.
  std::vector<std::string> health{"--json", "health", "--listen", "30"};
  for (const auto& name : expect) {
    health.push_back("--expect");
    health.push_back(name);
  }
  std::string out;
  const auto t_start = Clock::now();
  ASSERT_EQ(motionctl(group, "c", health, &out), 0) << out;
  const double t_heard = seconds_since(t_start);
  const auto seen = nlohmann::json::parse(out.substr(out.find('[')), nullptr, false);
  ASSERT_FALSE(seen.is_discarded()) << out;
  bool coordinator_is_ours = false;
  for (const auto& p : seen) {
    if (p.at("process") == "coordinator") coordinator_is_ours = p.at("pid").get<int>() == coordinator;
  }
  EXPECT_TRUE(coordinator_is_ours) << "the coordinator heard in host C is not the process the group started (pid "
                                   << coordinator << "):\n"
                                   << out;

  // The coordinator takes requests once it has heard the gateways: retry enable until then.
  int rc = -1;
  const auto t_enable = Clock::now();
  while (seconds_since(t_enable) < 30) {
    rc = motionctl(group, "c", {"--key", key, "enable", "x", "y", "z", "--timeout", "10"}, &out);
    if (rc == 0) break;
    group.pump_until([] { return false; }, std::chrono::milliseconds(500));
  }
  ASSERT_EQ(rc, 0) << "enable from host C failed:\n" << out;
  const double t_enabled = seconds_since(t_enable);

  // Unsigned, the same move from host C moves nothing: the coordinator refuses it.
  EXPECT_NE(motionctl(group, "c", {"move", "x=10", "--wait", "--timeout", "10"}, &out), 0) << out;
  EXPECT_NE(out.find("unsigned"), std::string::npos) << out;

  const auto t_move = Clock::now();
  ASSERT_EQ(
      motionctl(group, "c", {"--key", key, "--json", "move", "x=10", "y=5", "z=-2", "--wait", "--timeout", "30"}, &out),
      0)
      << out;
  const double move_s = seconds_since(t_move);
  const auto result = nlohmann::json::parse(out.substr(out.find('{')), nullptr, false);
  ASSERT_FALSE(result.is_discarded()) << out;
  EXPECT_EQ(result.at("status"), "done") << out;
  for (const auto& [axis, target] : std::vector<std::pair<std::string, double>>{{"x", 10.0}, {"y", 5.0}, {"z", -2.0}}) {
    EXPECT_NEAR(result.at("axes").at(axis).at("position").get<double>(), target, 1.0 / 640.0) << axis << "\n" << out;
  }
  std::printf(
      "[ timing ] namespaces up %.2f s; all %zu heartbeats heard in host C after %.2f s; enable ok after %.2f s; "
      "move x/y/z from host C %.2f s, start skew %.0f us (predicted arrival spread %.0f us)\n",
      t_net, expect.size(), t_heard, t_enabled, move_s, result.value("measured_start_skew_us", -1.0),
      result.value("predicted_skew_us", -1.0));

  // SIGTERM by the group's pid reaches the real coordinator in host B: it stops cleanly.
  group.stop(coordinator);
  EXPECT_EQ(group.exit_status(coordinator), 0) << group.log_of("coordinator");
}

// LCM loss: host B (the coordinator) loses 10 % of its UDP datagrams, incoming and outgoing, with
// an nftables rule (`numgen random mod 100 < 10 drop`; this kernel has no netem), so every request,
// reply, gateway command, gateway reply, trigger and axis state of the coordinator can be lost.
// What the system guarantees then: every client request ends within its timeout with one result
// (DONE, or a failure naming why: no reply heard, or the coordinator's FAILED/ABORTED), no axis is
// left moving or outside its limits, and once the loss stops the same processes take a new move to
// its exact target. The counts of each outcome are printed: loss is expected to fail some requests.
TEST_F(MultiHost, TenPercentLcmLossAtTheCoordinatorLosesNoAxisAndTheLabRecovers) {
  ASSERT_TRUE(net_.up({"a", "b", "c"}));
  std::string out;
  if (shell("command -v nft", &out) != 0) GTEST_SKIP() << "nftables' `nft` is not installed (tools/test installs it)";
  ProcessGroup group(lab_url(1));
  std::vector<std::string> expect;
  std::string key;
  start_enforced_lab(group, &expect, &key);
  std::vector<std::string> health{"health", "--listen", "30"};
  for (const auto& name : expect) {
    health.push_back("--expect");
    health.push_back(name);
  }
  ASSERT_EQ(motionctl(group, "c", health, &out), 0) << out;
  int rc = -1;
  const auto t_enable = Clock::now();
  while (seconds_since(t_enable) < 30) {
    rc = motionctl(group, "c", {"--key", key, "enable", "x", "y", "--timeout", "10"}, &out);
    if (rc == 0) break;
    group.pump_until([] { return false; }, std::chrono::milliseconds(500));
  }
  ASSERT_EQ(rc, 0) << "enable failed before any loss:\n" << out;

  const std::string nft = "ip netns exec " + net_.ns("b") + " nft ";
  ASSERT_EQ(shell(nft + "add table inet loss", &out), 0) << out;
  for (const char* hook : {"input", "output"}) {
    ASSERT_EQ(shell(nft + "'add chain inet loss " + hook + " { type filter hook " + hook + " priority 0; }'", &out), 0)
        << out;
    ASSERT_EQ(
        shell(nft + "add rule inet loss " + hook + " meta l4proto udp numgen random mod 100 '<' 10 counter drop", &out),
        0)
        << out;
  }

  constexpr int kRequests = 12;
  int done = 0;
  std::map<std::string, int> failures;  // the first line of each failure, counted
  const auto t_loss = Clock::now();
  for (int i = 0; i < kRequests; ++i) {
    const std::string x = std::to_string(i % 2 == 0 ? 10 : 0), y = std::to_string(i % 3);
    rc = motionctl(group, "c", {"--key", key, "--json", "move", "x=" + x, "y=" + y, "--wait", "--timeout", "15"}, &out,
                   seconds(40));
    ASSERT_NE(rc, -1) << "request " << i << ": motionctl did not end within its own timeout:\n" << out;
    // The JSON result, then (on a failure) motionctl's own line on stderr.
    const auto brace = out.find('{'), end = out.rfind('}');
    const auto result = brace == std::string::npos || end < brace
                            ? nlohmann::json()
                            : nlohmann::json::parse(out.substr(brace, end - brace + 1), nullptr, false);
    if (rc == 0) {
      ASSERT_TRUE(result.is_object()) << out;
      EXPECT_EQ(result.at("status"), "done") << out;
      EXPECT_NEAR(result.at("axes").at("x").at("position").get<double>(), std::stod(x), 1.0 / 640.0) << out;
      ++done;
    } else {
      std::string why = result.is_object()
                            ? result.value("status", std::string()) + ": " + result.value("reason", std::string())
                            : out.substr(0, out.find('\n'));
      EXPECT_GT(why.size(), 2u) << "request " << i << " failed (exit " << rc << ") without saying why:\n" << out;
      ++failures[why.substr(0, 160)];
    }
  }
  const double loss_s = seconds_since(t_loss);
  ASSERT_EQ(shell(nft + "list table inet loss", &out), 0) << out;
  const std::string counters = out;
  ASSERT_EQ(shell(nft + "delete table inet loss", &out), 0) << out;
  long dropped = 0;
  const std::regex packets(R"(counter packets ([0-9]+))");
  for (auto it = std::sregex_iterator(counters.begin(), counters.end(), packets); it != std::sregex_iterator(); ++it)
    dropped += std::stol((*it)[1]);
  EXPECT_GT(dropped, 0) << "the loss rule dropped nothing:\n" << counters;

  // No axis runs away: within a few seconds every axis is at rest, online and within its limits.
  bool settled = false;
  nlohmann::json status;
  const auto t_settle = Clock::now();
  while (!settled && seconds_since(t_settle) < 15) {
    if (motionctl(group, "c", {"--json", "status"}, &out) == 0 && out.find('{') != std::string::npos) {
      status = nlohmann::json::parse(out.substr(out.find('{')), nullptr, false);
      settled = status.is_object();
      for (const auto& a : config_.axes) {
        const auto& s = status.is_object() && status.contains(a.name) ? status.at(a.name) : nlohmann::json();
        if (!s.is_object() || s.value("moving", true) || !s.value("online", false)) {
          settled = false;
          continue;
        }
        const double pos = s.at("position").get<double>();
        EXPECT_GE(pos, a.limits.min_position - 1e-9) << a.name;
        EXPECT_LE(pos, a.limits.max_position + 1e-9) << a.name;
      }
    }
    if (!settled) group.pump_until([] { return false; }, std::chrono::milliseconds(500));
  }
  EXPECT_TRUE(settled) << "axes still moving or offline 15 s after the loss ended:\n" << out;

  // The same processes take a new move to its exact target.
  rc = motionctl(group, "c", {"--key", key, "enable", "x", "y", "--timeout", "10"}, &out);
  EXPECT_EQ(rc, 0) << out;
  rc = motionctl(group, "c", {"--key", key, "--json", "move", "x=3", "y=2", "--wait", "--timeout", "20"}, &out);
  ASSERT_EQ(rc, 0) << "a move after the loss failed:\n" << out;
  const auto after = nlohmann::json::parse(out.substr(out.find('{')), nullptr, false);
  ASSERT_TRUE(after.is_object()) << out;
  EXPECT_NEAR(after.at("axes").at("x").at("position").get<double>(), 3.0, 1.0 / 640.0) << out;
  EXPECT_NEAR(after.at("axes").at("y").at("position").get<double>(), 2.0, 1.0 / 640.0) << out;

  std::printf(
      "[ measured ] 10 %% LCM loss at the coordinator's host: %d requests in %.1f s, %d done, %ld datagrams "
      "dropped; failures:\n",
      kRequests, loss_s, done, dropped);
  for (const auto& [text, n] : failures) std::printf("  %d x %s\n", n, text.c_str());
}

// The two set-up mistakes the documentation warns about, measured: TTL 0 keeps multicast on one
// host, and a host without a multicast route (and no default route) cannot open LCM at all.
TEST_F(MultiHost, Ttl0StaysOnOneHostAndAHostWithoutAMulticastRouteCannotOpenLcm) {
  ASSERT_TRUE(net_.up({"a", "c", "d"}));
  std::string out;
  ASSERT_EQ(shell(ip_binary() + " -n " + net_.ns("d") + " route del 224.0.0.0/4", &out), 0) << out;

  ProcessGroup group(lab_url(0));
  group.start(net_.in("a", "coordinator", "motion-coordinator", {"--config", config_path_}));
  // Same host: heard. Other host: not heard, with TTL 0.
  EXPECT_EQ(motionctl(group, "a", {"health", "--listen", "10", "--expect", "coordinator"}, &out), 0) << out;
  EXPECT_EQ(motionctl(group, "c", {"health", "--listen", "3", "--expect", "coordinator"}, &out), 4) << out;
  EXPECT_NE(out.find("no heartbeat from 'coordinator'"), std::string::npos) << out;

  // No route for 224.0.0.0/4 and no default route: LCM's udpm provider cannot join the group.
  const int rc = motionctl(group, "d", {"health", "--listen", "2"}, &out);
  EXPECT_EQ(rc, 4) << out;
  std::printf("[ measured ] motionctl health in a host without a multicast route: exit %d:\n%s", rc, out.c_str());
}

TEST_F(MultiHost, NamespacesAreDeletedWithTheLab) {
  {
    NetnsLab lab("motion-" + std::to_string(::getpid()) + "x");
    ASSERT_TRUE(lab.up({"a"}));
    EXPECT_TRUE(lab.exists("a"));
    EXPECT_TRUE(lab.exists("br"));
  }
  NetnsLab after("motion-" + std::to_string(::getpid()) + "x");
  EXPECT_FALSE(after.exists("a"));
  EXPECT_FALSE(after.exists("br"));
}

}  // namespace
}  // namespace motion::testing
