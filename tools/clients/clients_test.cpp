// "Any language, any machine": the Python, Java and Lua clients against the real motion-coordinator
// (each on this test's own LCM URL): they hear its heartbeat, get the terminal REJECTED reply for an
// unknown axis (error 2, the reason names the axis) and for a non-finite value (error 1), and their
// move examples stop with the coordinator's reason while the axes' gateways are offline. The Python
// client's own LCM wire format (LC02 and fragmented LC03) is checked both ways against liblcm, and
// lcm-spy's type scanner and lcm-spy itself (under Xvfb) against our types jar.
//
// A missing runtime (/usr/bin/python3, java/javac, lua5.2, xvfb-run) fails the test with that
// reason. Every process is started through ProcessGroup, which kills it at the end of the test.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <string>
#include <vector>

#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>

#include "clients_paths.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/testing/process_group.hpp"

namespace motion::testing {
namespace {

namespace paths = motion::clients_test;
using std::chrono::seconds;

bool executable(const std::string& path) { return !path.empty() && ::access(path.c_str(), X_OK) == 0; }
bool readable(const std::string& path) { return !path.empty() && ::access(path.c_str(), R_OK) == 0; }
bool contains(const std::string& haystack, const std::string& needle) { return haystack.find(needle) != std::string::npos; }

// How to run a client program of one language; `missing` says why it cannot run.
struct Runtime {
  std::string language;
  std::string missing;
  std::string exe;
  std::vector<std::string> prefix_args;  // before the program's own arguments
  std::vector<std::string> env;

  [[nodiscard]] ProcessSpec spec(const std::string& name, const std::string& program, std::vector<std::string> args) const {
    std::vector<std::string> all = prefix_args;
    all.push_back(program);
    all.insert(all.end(), args.begin(), args.end());
    return ProcessSpec{name, exe, all, env};
  }
};

Runtime python() {
  Runtime r{"Python", "", paths::kPython, {"-B"}, {}};
  r.env = {std::string("PYTHONPATH=") + paths::kPythonTypes + ":" + paths::kPythonDir, "PYTHONDONTWRITEBYTECODE=1"};
  if (!executable(r.exe)) r.missing = "/usr/bin/python3 not found (apt-get install python3): the Python client cannot be tested";
  else if (!readable(std::string(paths::kPythonTypes) + "/motionlcm/reply_t.py")) r.missing = std::string("generated Python types missing in ") + paths::kPythonTypes + " (build motion_lcmtypes_scripts)";
  return r;
}

Runtime java() {
  const std::string cp = std::string(paths::kLcmJar) + ":" + paths::kTypesJar + ":" + paths::kJavaClasses;
  Runtime r{"Java", "", paths::kJava, {"-Djava.net.preferIPv4Stack=true", "-cp", cp}, {}};
  if (!executable(paths::kJavac) || !executable(r.exe)) r.missing = "javac/java not found at configure time (apt-get install default-jdk-headless): the Java client cannot be tested";
  else if (!readable(paths::kLcmJar)) r.missing = "lcm.jar not found (apt-get install liblcm-java)";
  else if (!readable(paths::kTypesJar)) r.missing = std::string("types jar ") + paths::kTypesJar + " missing (build motion_lcmtypes_java)";
  else if (!readable(std::string(paths::kJavaClasses) + "/MotionClient.class")) r.missing = "Java client classes missing (build motion_clients_java)";
  return r;
}

Runtime lua() {
  Runtime r{"Lua", "", paths::kLua, {}, {std::string("LUA_PATH=") + paths::kLuaPath}};
  if (!executable(r.exe)) r.missing = "lua5.2 not found (apt-get install lua5.2 liblcm-lua): the Lua client cannot be tested";
  else if (!readable("/usr/lib/lua/5.2/lcm.so") && !readable("/usr/lib/x86_64-linux-gnu/lua/5.2/lcm.so")) r.missing = "Debian's LCM Lua binding (lcm.so for Lua 5.2) not found (apt-get install liblcm-lua)";
  return r;
}

std::string program(const Runtime& r, const std::string& base) {
  if (r.language == "Python") return std::string(paths::kPythonDir) + "/" + base + ".py";
  if (r.language == "Lua") return std::string(paths::kLuaDir) + "/" + base + ".lua";
  return base == "check_coordinator" ? "CheckCoordinator" : "ExampleMove";  // Java class names
}

// Starts the real coordinator on the group's URL and waits for its heartbeat (DEGRADED is fine:
// no gateway runs).
void start_coordinator(ProcessGroup& group) {
  group.start({"coordinator", "motion-coordinator", {"--config", source_path("config/sim-lab.yaml")}, {}});
  ASSERT_TRUE(group.wait_for_heartbeat("coordinator", seconds(15), true));
}

// The client of `r` against the real coordinator: heartbeat, unknown axis, malformed value, and the
// move example stopping with the coordinator's reason (the axes' gateways are offline).
void check_client_against_coordinator(const Runtime& r) {
  ASSERT_TRUE(r.missing.empty()) << r.language << ": " << r.missing;
  ProcessGroup group;
  start_coordinator(group);
  if (::testing::Test::HasFatalFailure()) return;

  std::string out;
  const int rc = group.run_to_completion(r.spec("check-" + r.language, program(r, "check_coordinator"), {}), &out, seconds(60));
  EXPECT_EQ(rc, 0) << out;
  EXPECT_TRUE(contains(out, "health: process=coordinator role=coordinator state=")) << out;
  EXPECT_TRUE(contains(out, "unknown-axis: status=rejected error_code=2 reason=unknown axis 'no_such_axis' (axes: x, y, z, a, b, c, u)")) << out;
  EXPECT_TRUE(contains(out, "malformed: status=rejected error_code=1 reason=value for axis x is not a finite number")) << out;

  const int example_rc = group.run_to_completion(r.spec("example-" + r.language, program(r, "example_move"), {"--axes", "x", "y"}), &out, seconds(60));
  EXPECT_EQ(example_rc, 1) << out;
  EXPECT_TRUE(contains(out, "rejected (error 7): gateway of bus can0 (axis x) is offline")) << out;
}

TEST(Clients, PythonClientAgainstTheRealCoordinator) { check_client_against_coordinator(python()); }
TEST(Clients, JavaClientAgainstTheRealCoordinator) { check_client_against_coordinator(java()); }
TEST(Clients, LuaClientAgainstTheRealCoordinator) { check_client_against_coordinator(lua()); }

// loopback.py publishes a small (LC02) and a large (LC03) request_t; liblcm must decode both. This
// side answers with a small and a large reply_t (liblcm fragments the latter); Python must decode both.
TEST(Clients, PythonWireFormatInteroperatesWithLiblcm) {
  const Runtime r = python();
  ASSERT_TRUE(r.missing.empty()) << r.missing;
  ProcessGroup group;
  constexpr int kLarge = 300;
  bool small_ok = false;
  bool large_ok = false;
  int bad = 0;
  group.node().subscribe<motionlcm::request_t>(lcm::channels::kRequest, [&](const motionlcm::request_t& m, const std::string&) {
    if (m.client_id != "py-loopback") return;
    if (m.request_id == 1) {
      const bool ok = m.num_axes == 1 && m.axes == std::vector<std::string>{"small"} && m.values == std::vector<double>{1.5};
      small_ok = small_ok || ok;
      if (!ok) ++bad;
    } else if (m.request_id == 2) {
      bool ok = m.num_axes == kLarge && m.axes.size() == kLarge && m.values.size() == kLarge;
      for (int i = 0; ok && i < kLarge; ++i) {
        char name[8];
        std::snprintf(name, sizeof name, "a%03d", i);
        const auto index = static_cast<std::size_t>(i);
        ok = m.axes[index] == name && m.values[index] == i / 4.0;
      }
      large_ok = large_ok || ok;
      if (!ok) ++bad;
    }
    if (!small_ok || !large_ok) return;
    motionlcm::reply_t small{};
    small.client_id = "py-loopback";
    small.request_id = 1;
    small.status = motionlcm::reply_t::DONE;
    small.reason = "small ok";
    group.node().publish(lcm::channels::kReply, small);
    motionlcm::reply_t large{};
    large.client_id = "py-loopback";
    large.request_id = 2;
    large.status = motionlcm::reply_t::DONE;
    large.reason = "large ok";
    large.num_axes = kLarge;
    for (int i = 0; i < kLarge; ++i) {
      char name[8];
      std::snprintf(name, sizeof name, "a%03d", i);
      large.axes.emplace_back(name);
      large.targets.push_back(0.0);
      large.positions.push_back(i / 2.0);
      large.start_utime.push_back(0);
    }
    group.node().publish(lcm::channels::kReply, large);
  });
  std::string out;
  const int rc = group.run_to_completion(r.spec("py-loopback", std::string(paths::kPythonDir) + "/loopback.py", {}), &out, seconds(40));
  EXPECT_TRUE(small_ok) << "liblcm did not decode Python's LC02 request_t\n" << out;
  EXPECT_TRUE(large_ok) << "liblcm did not decode Python's fragmented (LC03) request_t\n" << out;
  EXPECT_EQ(bad, 0) << "requests from Python with wrong contents\n" << out;
  EXPECT_EQ(rc, 0) << out;
  EXPECT_TRUE(contains(out, "loopback ok")) << out;
}

// lcm-spy's own type scanner (lcm.spy.LCMTypeDatabase) finds every class of our jar by its
// LCM_FINGERPRINT. No display needed.
TEST(Spy, TypeScannerFindsEveryMotionlcmType) {
  const Runtime r = java();
  ASSERT_TRUE(r.missing.empty()) << r.missing;
  ProcessGroup group;
  std::string out;
  const int rc = group.run_to_completion(r.spec("spy-types", "SpyTypes", {paths::kTypesJar}), &out, seconds(60));
  EXPECT_EQ(rc, 0) << out;
  EXPECT_TRUE(contains(out, "lcm-spy finds all " + std::to_string(paths::kTypeCount) + " types")) << out;
}

// tools/spy under Xvfb against a live coordinator: loads our types and is still running after 15 s
// (`timeout` then stops it: exit 124; xvfb-run stops its X server).
TEST(Spy, RunsUnderXvfbAgainstALiveCoordinator) {
  const Runtime r = java();
  ASSERT_TRUE(r.missing.empty()) << r.missing;
  ASSERT_TRUE(executable(paths::kXvfbRun)) << "xvfb-run not found (apt-get install xvfb): lcm-spy cannot be started without a display";
  ASSERT_TRUE(executable(paths::kTimeout)) << "timeout (coreutils) not found";
  ProcessGroup group;
  start_coordinator(group);
  if (HasFatalFailure()) return;
  std::string out;
  // ProcessGroup appends --lcm-url URL, which xvfb-run and timeout pass on to tools/spy.
  const int rc = group.run_to_completion(
      {"spy", paths::kXvfbRun, {"-a", paths::kTimeout, "-k", "3", "15", paths::kSpy, "--jar", paths::kTypesJar},
       {std::string("JAVA=") + paths::kJava, std::string("LCM_JAR=") + paths::kLcmJar}},
      &out, seconds(60));
  EXPECT_EQ(rc, 124) << "lcm-spy was not running any more after 15 s (124 = stopped by timeout)\n" << out;
  EXPECT_TRUE(contains(out, "Found " + std::to_string(paths::kTypeCount) + " LCM types")) << out;
  EXPECT_FALSE(contains(out, "Exception")) << out;
}

}  // namespace
}  // namespace motion::testing
