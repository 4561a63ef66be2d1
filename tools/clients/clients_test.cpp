// "Any language, any machine": the Python, Java, Lua and C++ clients against the simulated lab of
// config/sim-lab.yaml (motion-sim, the gateway of bus can0, motion-coordinator; each test on its own
// LCM URL and simulation directory). Each language's move example enables x and y, moves them with
// one synchronized request and prints final positions that must equal the targets within one drive
// count. The check_coordinator programs (Python, Java, Lua) and the C++ example get the terminal
// REJECTED reply for an unknown axis (error 2, the reason names the axis) and for a non-finite value
// (error 1); with the coordinator alone (no gateway), the example stops with the coordinator's
// reason. The Python client's own LCM wire format (LC02 and fragmented LC03) is checked both ways
// against liblcm, and lcm-spy's type scanner and lcm-spy itself (under Xvfb) against our types jar.
// With `security: {mode: enforce}` (one lab for the three languages), each client's check_signed
// program moves an axis with a signed request, and its unsigned and wrongly signed requests (a key
// the coordinator does not know; the right key with the signature altered) end REJECTED with
// code 19 and move nothing; it reads the axis's position afterwards from axis states it takes only
// signed by the lab's gateway key (--gateway-keys), none refused.
//
// A missing runtime (/usr/bin/python3, java/javac, lua5.2, xvfb-run) fails the test with that
// reason. Every process is started through ProcessGroup, which kills it at the end of the test.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <lcm/eventlog.h>

#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>

#include "clients_paths.hpp"
#include "motion/config/config.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/security/keys.hpp"
#include "motion/testing/lab_keys.hpp"
#include "motion/testing/process_group.hpp"

namespace motion::testing {
namespace {

namespace paths = motion::clients_test;
using std::chrono::seconds;

bool executable(const std::string& path) { return !path.empty() && ::access(path.c_str(), X_OK) == 0; }
bool readable(const std::string& path) { return !path.empty() && ::access(path.c_str(), R_OK) == 0; }
bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

// How to run a client program of one language; `missing` says why it cannot run.
struct Runtime {
  std::string language;
  std::string missing;
  std::string exe;
  std::vector<std::string> prefix_args;  // before the program's own arguments
  std::vector<std::string> env;

  // `program` empty: `exe` is the program itself (C++).
  [[nodiscard]] ProcessSpec spec(const std::string& name, const std::string& program,
                                 std::vector<std::string> args) const {
    std::vector<std::string> all = prefix_args;
    if (!program.empty()) all.push_back(program);
    all.insert(all.end(), args.begin(), args.end());
    return ProcessSpec{name, exe, all, env};
  }
};

Runtime python() {
  Runtime r{"Python", "", paths::kPython, {"-B"}, {}};
  r.env = {std::string("PYTHONPATH=") + paths::kPythonTypes + ":" + paths::kPythonDir, "PYTHONDONTWRITEBYTECODE=1"};
  if (!executable(r.exe))
    r.missing = "/usr/bin/python3 not found (apt-get install python3): the Python client cannot be tested";
  else if (!readable(std::string(paths::kPythonTypes) + "/motionlcm/reply_t.py"))
    r.missing =
        std::string("generated Python types missing in ") + paths::kPythonTypes + " (build motion_lcmtypes_scripts)";
  return r;
}

Runtime java() {
  const std::string cp = std::string(paths::kLcmJar) + ":" + paths::kTypesJar + ":" + paths::kJavaClasses;
  Runtime r{"Java", "", paths::kJava, {"-Djava.net.preferIPv4Stack=true", "-cp", cp}, {}};
  if (!executable(paths::kJavac) || !executable(r.exe))
    r.missing =
        "javac/java not found at configure time (apt-get install default-jdk-headless): the Java client cannot be "
        "tested";
  else if (!readable(paths::kLcmJar))
    r.missing = "lcm.jar not found (apt-get install liblcm-java)";
  else if (!readable(paths::kTypesJar))
    r.missing = std::string("types jar ") + paths::kTypesJar + " missing (build motion_lcmtypes_java)";
  else if (!readable(std::string(paths::kJavaClasses) + "/MotionClient.class"))
    r.missing = "Java client classes missing (build motion_clients_java)";
  return r;
}

Runtime lua() {
  Runtime r{"Lua",
            "",
            paths::kLua,
            {},
            {std::string("LUA_PATH=") + paths::kLuaPath, std::string("LUA_CPATH=") + paths::kLuaCpath}};
  if (!executable(r.exe))
    r.missing = "lua5.2 not found (apt-get install lua5.2 liblcm-lua): the Lua client cannot be tested";
  else if (!readable("/usr/lib/lua/5.2/lcm.so") && !readable("/usr/lib/x86_64-linux-gnu/lua/5.2/lcm.so"))
    r.missing = "Debian's LCM Lua binding (lcm.so for Lua 5.2) not found (apt-get install liblcm-lua)";
  else if (std::string(paths::kLuaCpath).empty())
    r.missing = "the Lua signing module motionsodium was not built (apt-get install liblua5.2-dev, then reconfigure)";
  return r;
}

Runtime cpp() {
  Runtime r{"C++", "", paths::kCppExample, {}, {}};
  if (!executable(r.exe))
    r.missing = std::string("C++ example ") + paths::kCppExample + " not built (build example_move_cpp)";
  return r;
}

std::string program(const Runtime& r, const std::string& base) {
  if (r.language == "Python") return std::string(paths::kPythonDir) + "/" + base + ".py";
  if (r.language == "Lua") return std::string(paths::kLuaDir) + "/" + base + ".lua";
  if (r.language == "C++") return "";                // the example itself (there is no C++ check_coordinator)
  if (base == "check_signed") return "CheckSigned";  // Java class names
  return base == "check_coordinator" ? "CheckCoordinator" : "ExampleMove";
}

// Starts the real coordinator on the group's URL and waits for its heartbeat (DEGRADED is fine:
// no gateway runs).
void start_coordinator(ProcessGroup& group) {
  group.start({"coordinator", "motion-coordinator", {"--config", source_path("config/sim-lab.yaml")}, {}});
  ASSERT_TRUE(group.wait_for_heartbeat("coordinator", seconds(15), true));
}

// The part of the simulated lab (config/sim-lab.yaml) that the examples move: motion-sim, the
// gateway of bus can0 (axes x and y) and the coordinator, on the group's LCM URL and simulation
// directory. Waits for their heartbeats (the coordinator stays DEGRADED: the gateways of the other
// buses are not started) and for x and y to be online.
::testing::AssertionResult start_lab(ProcessGroup& group,
                                     const std::string& config = source_path("config/sim-lab.yaml")) {
  auto online = std::make_shared<std::map<std::string, bool>>();  // outlives this function in the subscription
  group.node().subscribe<motionlcm::axis_state_t>(
      lcm::channels::kAxisState,
      [online](const motionlcm::axis_state_t& s, const std::string&) { (*online)[s.axis] = s.online; });
  group.start({"sim", "motion-sim", {"--config", config}, {}});
  group.start({"gateway:can0", "motion-gateway", {"--config", config, "--bus", "can0"}, {}});
  group.start({"coordinator", "motion-coordinator", {"--config", config}, {}});
  for (const char* name : {"sim", "gateway:can0", "coordinator"}) {
    if (!group.wait_for_heartbeat(name, seconds(20), true))
      return ::testing::AssertionFailure() << "no heartbeat from " << name;
  }
  if (!group.pump_until([&] { return (*online)["x"] && (*online)["y"]; }, seconds(20))) {
    return ::testing::AssertionFailure() << "axes x and y not online within 20 s (x "
                                         << ((*online)["x"] ? "online" : "not online") << ", y "
                                         << ((*online)["y"] ? "online" : "not online") << ")";
  }
  return ::testing::AssertionSuccess();
}

// The "<axis> = <position>" lines of an example's output.
std::map<std::string, double> printed_positions(const std::string& out) {
  std::map<std::string, double> positions;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    const auto eq = line.find(" = ");
    if (eq == std::string::npos || eq == 0 || line.find(' ') < eq) continue;
    const std::string value = line.substr(eq + 3);
    char* end = nullptr;
    const double v = std::strtod(value.c_str(), &end);
    if (end != value.c_str() && *end == '\0') positions[line.substr(0, eq)] = v;
  }
  return positions;
}

// One drive count of `axis` in user units (config/sim-lab.yaml).
double one_count(const std::string& axis) {
  static const config::LoadResult loaded = config::load_file(source_path("config/sim-lab.yaml"));
  if (!loaded.ok()) {
    ADD_FAILURE() << loaded.error_text();
    return 0;
  }
  const config::Axis* a = loaded.config->find_axis(axis);
  if (a == nullptr || a->steps_per_unit <= 0) {
    ADD_FAILURE() << "axis " << axis << " without steps_per_unit in config/sim-lab.yaml";
    return 0;
  }
  return 1.0 / a->steps_per_unit;
}

std::string number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

// The client of `r` against the simulated lab: its check_coordinator (heartbeat, unknown axis,
// malformed value; for C++ the example itself is refused both), then its move example, which must
// end with x and y at the targets.
void check_client_against_lab(const Runtime& r, double target_x, double target_y) {
  ASSERT_TRUE(r.missing.empty()) << r.language << ": " << r.missing;
  ProcessGroup group;
  const auto started = start_lab(group);
  ASSERT_TRUE(started) << r.language;

  std::string out;
  if (r.language == "C++") {
    int rc =
        group.run_to_completion(r.spec("example-unknown-axis", "", {"--axes", "x", "no_such_axis"}), &out, seconds(60));
    EXPECT_EQ(rc, 1) << out;
    EXPECT_TRUE(contains(out, "rejected (error 2): unknown axis 'no_such_axis' (axes: x, y, z, a, b, c, u)")) << out;
    rc = group.run_to_completion(r.spec("example-malformed", "", {"--axes", "x", "y", "--targets", "nan", "1"}), &out,
                                 seconds(60));
    EXPECT_EQ(rc, 1) << out;
    EXPECT_TRUE(contains(out, "rejected (error 1): value for axis x is not a finite number")) << out;
  } else {
    const int rc =
        group.run_to_completion(r.spec("check-" + r.language, program(r, "check_coordinator"), {}), &out, seconds(60));
    EXPECT_EQ(rc, 0) << out;
    EXPECT_TRUE(contains(out, "health: process=coordinator role=coordinator state=")) << out;
    EXPECT_TRUE(contains(
        out,
        "unknown-axis: status=rejected error_code=2 reason=unknown axis 'no_such_axis' (axes: x, y, z, a, b, c, u)"))
        << out;
    EXPECT_TRUE(contains(out, "malformed: status=rejected error_code=1 reason=value for axis x is not a finite number"))
        << out;
  }

  const int example_rc =
      group.run_to_completion(r.spec("example-" + r.language, program(r, "example_move"),
                                     {"--axes", "x", "y", "--targets", number(target_x), number(target_y)}),
                              &out, seconds(60));
  EXPECT_EQ(example_rc, 0) << out;
  EXPECT_TRUE(contains(out, "enabled x y")) << out;
  const auto positions = printed_positions(out);
  ASSERT_TRUE(positions.contains("x") && positions.contains("y")) << "no 'x = ...' and 'y = ...' lines\n" << out;
  EXPECT_NEAR(positions.at("x"), target_x, one_count("x")) << out;
  EXPECT_NEAR(positions.at("y"), target_y, one_count("y")) << out;
}

// Targets differ per language, and most are not a whole number of drive counts (640 per mm).
TEST(Clients, PythonExampleMovesTheSimulatedLab) { check_client_against_lab(python(), 12.3456, -3.25); }
TEST(Clients, JavaExampleMovesTheSimulatedLab) { check_client_against_lab(java(), 7.75, 4.0001); }
TEST(Clients, LuaExampleMovesTheSimulatedLab) { check_client_against_lab(lua(), 3.3333, 9.5); }
TEST(Clients, CppExampleMovesTheSimulatedLab) { check_client_against_lab(cpp(), 20.125, 1.2345); }

// With the coordinator alone (no gateway), a move example stops with the coordinator's reason
// (one language is enough: they all print the terminal reply the same way).
TEST(Clients, ExampleStopsWithTheCoordinatorsReasonWhenTheGatewayIsOffline) {
  const Runtime r = cpp();
  ASSERT_TRUE(r.missing.empty()) << r.missing;
  ProcessGroup group;
  start_coordinator(group);
  if (HasFatalFailure()) return;
  std::string out;
  const int rc = group.run_to_completion(r.spec("example-offline", program(r, "example_move"), {"--axes", "x", "y"}),
                                         &out, seconds(60));
  EXPECT_EQ(rc, 1) << out;
  EXPECT_TRUE(contains(out, "rejected (error 7): gateway of bus can0 (axis x) is offline")) << out;
}

// One simulated lab with `security: {mode: enforce}` for the three languages' check_signed
// programs: config/sim-lab.yaml plus a security section, an authorized_keys file with the key "op"
// (role operate), the coordinator's key pair; "op.key" is what the clients sign with and
// "stranger.key" a key the coordinator does not know.
// How often `part` occurs in `text`.
int occurrences(const std::string& text, const std::string& part) {
  int n = 0;
  for (auto at = text.find(part); at != std::string::npos; at = text.find(part, at + part.size())) ++n;
  return n;
}

class SignedClients : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    group_ = new ProcessGroup;
    const std::string dir = group_->work_dir();
    {
      std::ifstream base(source_path("config/sim-lab.yaml"));
      std::ofstream config(dir + "/lab.yaml");
      config << base.rdbuf() << motion::testing::enforced_security();
    }
    const auto op = security::KeyPair::generate("op");
    ASSERT_EQ(motion::testing::write_lab_keys(dir, {op.authorized_line("operate")}), std::nullopt);
    ASSERT_EQ(security::write_key_pair(op, dir, "operate"), std::nullopt);
    ASSERT_EQ(security::write_key_pair(security::KeyPair::generate("stranger"), dir, "operate"), std::nullopt);
    stranger_id_ = new std::string(
        security::to_hex(std::get<security::KeyPair>(security::load_private_key(dir + "/stranger.key")).id()));
    started_ = new ::testing::AssertionResult(start_lab(*group_, dir + "/lab.yaml"));
  }
  static void TearDownTestSuite() {
    delete group_;  // kills every process of the lab
    group_ = nullptr;
    delete started_;
    delete stranger_id_;
  }
  void TearDown() override {
    if (HasFailure()) group_->print_logs();
  }

  // `r`'s check_signed against the lab: the signed move ends DONE at `target`; the unsigned, the
  // stranger's and the forged move (to target + 5) end REJECTED with code 19 and the coordinator's reason,
  // and the axis is still at `target` half a second later. The key comes from $MOTION_KEY or from
  // --key (`key_option`). With `verify` the clients take only the coordinator's signed replies and
  // SECURITY events (--coordinator-key coordinator.pub), so all of the above came signed by it.
  // Every client takes the axis's "after" state only signed by the lab's gateway key
  // (--gateway-keys authorized_keys): the gateway's real signatures verify in each language. The
  // only states it may refuse are ones signed before it began verifying (in flight then; a state
  // signed before the verifier started is refused in every client, as in C++), each printed.
  void check_signed(const Runtime& r, double target, bool key_option, bool verify = false) {
    ASSERT_TRUE(r.missing.empty()) << r.language << ": " << r.missing;
    ASSERT_TRUE(*started_) << r.language;
    const std::string dir = group_->work_dir();
    Runtime runtime = r;
    std::vector<std::string> args{"--stranger-key", dir + "/stranger.key", "--axis", "x", "--target", number(target)};
    args.insert(args.end(), {"--gateway-keys", dir + "/authorized_keys"});
    if (key_option) {
      args.insert(args.end(), {"--key", dir + "/op.key"});
    } else {
      runtime.env.push_back("MOTION_KEY=" + dir + "/op.key");
    }
    if (verify) args.insert(args.end(), {"--coordinator-key", dir + "/coordinator.pub"});
    std::string out;
    const auto started = std::chrono::steady_clock::now();
    const int rc = group_->run_to_completion(runtime.spec("signed-" + r.language, program(r, "check_signed"), args),
                                             &out, seconds(60));
    const auto took = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - started);
    std::printf("check_signed (%s): %lld ms\n", r.language.c_str(), static_cast<long long>(took.count()));
    EXPECT_EQ(rc, 0) << out;
    if (verify) { EXPECT_TRUE(contains(out, "verifying the coordinator's replies")) << out; }
    EXPECT_TRUE(contains(out, "signed: status=done error_code=0")) << out;
    EXPECT_TRUE(contains(
        out,
        "unsigned: status=rejected error_code=19 reason=refused by the coordinator's security (SECURITY event, no "
        "reply): unsigned request refused: security is enforced"))
        << out;
    EXPECT_TRUE(contains(
        out,
        "stranger: status=rejected error_code=19 reason=refused by the coordinator's security (SECURITY event, no "
        "reply): signed request refused: unknown key " +
            *stranger_id_ + " (not in authorized_keys)"))
        << out;
    EXPECT_TRUE(contains(
        out,
        "forged: status=rejected error_code=19 reason=refused by the coordinator's security (SECURITY event, no "
        "reply): signed request refused: bad signature from key 'op'"))
        << out;
    const auto positions = printed_positions(out);
    ASSERT_TRUE(positions.contains("x")) << out;
    EXPECT_NEAR(positions.at("x"), target, one_count("x")) << out;
    // Nothing of the refused moves (to target + 5) happened.
    const auto after = out.find("after: x = ");
    ASSERT_NE(after, std::string::npos) << out;
    char* end = nullptr;
    EXPECT_NEAR(std::strtod(out.c_str() + after + 11, &end), target, one_count("x")) << out;
    int refused = -1;
    EXPECT_EQ(std::sscanf(end, " (signed by a gateway, %d refused)", &refused), 1) << out;
    EXPECT_EQ(refused, occurrences(out, "an axis state is ignored: signed AXIS_STATE refused: "));
    EXPECT_EQ(refused, occurrences(out,
                                   "an axis state is ignored: signed AXIS_STATE refused: stale timestamp: signed "
                                   "before this client started"))
        << out;
    EXPECT_LE(refused, 3) << out;
  }

  static ProcessGroup* group_;
  static ::testing::AssertionResult* started_;
  static std::string* stranger_id_;
};

ProcessGroup* SignedClients::group_ = nullptr;
::testing::AssertionResult* SignedClients::started_ = nullptr;
std::string* SignedClients::stranger_id_ = nullptr;

TEST_F(SignedClients, PythonSignsAndUnsignedOrWronglySignedRequestsAreRefused) { check_signed(python(), 6.25, false); }
TEST_F(SignedClients, JavaSignsAndUnsignedOrWronglySignedRequestsAreRefused) { check_signed(java(), -2.5, true, true); }
TEST_F(SignedClients, LuaSignsAndUnsignedOrWronglySignedRequestsAreRefused) { check_signed(lua(), 4.125, false); }

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
  group.node().subscribe<motionlcm::request_t>(
      lcm::channels::kRequest, [&](const motionlcm::request_t& m, const std::string&) {
        if (m.client_id != "py-loopback") return;
        if (m.request_id == 1) {
          const bool ok =
              m.num_axes == 1 && m.axes == std::vector<std::string>{"small"} && m.values == std::vector<double>{1.5};
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
  const int rc = group.run_to_completion(r.spec("py-loopback", std::string(paths::kPythonDir) + "/loopback.py", {}),
                                         &out, seconds(40));
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
// (`timeout` then stops the whole process group, xvfb-run and its X server included: exit 124,
// whatever xvfb-run's own clean-up of its temporary folder then says).
TEST(Spy, RunsUnderXvfbAgainstALiveCoordinator) {
  const Runtime r = java();
  ASSERT_TRUE(r.missing.empty()) << r.missing;
  ASSERT_TRUE(executable(paths::kXvfbRun))
      << "xvfb-run not found (apt-get install xvfb): lcm-spy cannot be started without a display";
  ASSERT_TRUE(executable(paths::kTimeout)) << "timeout (coreutils) not found";
  ProcessGroup group;
  start_coordinator(group);
  if (HasFatalFailure()) return;
  std::string out;
  // ProcessGroup appends --lcm-url URL, which timeout and xvfb-run pass on to tools/spy.
  const int rc =
      group.run_to_completion({"spy",
                               paths::kTimeout,
                               {"-k", "3", "15", paths::kXvfbRun, "-a", paths::kSpy, "--jar", paths::kTypesJar},
                               {std::string("JAVA=") + paths::kJava, std::string("LCM_JAR=") + paths::kLcmJar}},
                              &out, seconds(60));
  EXPECT_EQ(rc, 124) << "lcm-spy was not running any more after 15 s (124 = stopped by timeout)\n" << out;
  EXPECT_TRUE(contains(out, "Found " + std::to_string(paths::kTypeCount) + " LCM types")) << out;
  EXPECT_FALSE(contains(out, "Exception")) << out;
}

// tools/logplayer (Debian's lcm-logplayer-gui fails on Java 17 like lcm-spy) under Xvfb replays a
// recording onto the test's URL: every recorded message arrives, in order, byte for byte.
TEST(LogPlayer, ReplaysARecordingOntoItsUrlUnderXvfb) {
  const Runtime r = java();
  ASSERT_TRUE(r.missing.empty()) << r.missing;
  ASSERT_TRUE(executable(paths::kXvfbRun)) << "xvfb-run not found (apt-get install xvfb)";
  ASSERT_TRUE(executable(paths::kTimeout)) << "timeout (coreutils) not found";
  ProcessGroup group;
  std::string channel = "LOGPLAYER_TEST";  // lcm_eventlog_event_t takes char*
  const std::string path = group.work_dir() + "/recording.lcmlog";
  constexpr int kEvents = 20;
  {
    lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
    ASSERT_NE(log, nullptr);
    for (int i = 0; i < kEvents; ++i) {
      std::string payload = "message " + std::to_string(i);
      lcm_eventlog_event_t event{};
      event.eventnum = i;
      event.timestamp = 1'000'000 + 20'000 * i;  // 20 ms apart: the player keeps the pace
      event.channellen = static_cast<int32_t>(channel.size());
      event.datalen = static_cast<int32_t>(payload.size());
      event.channel = channel.data();
      event.data = payload.data();
      ASSERT_EQ(lcm_eventlog_write_event(log, &event), 0);
    }
    lcm_eventlog_destroy(log);
  }
  std::vector<std::string> received;
  group.node().subscribe_raw(channel, [&](const void* data, int size, const std::string&) {
    received.emplace_back(static_cast<const char*>(data), static_cast<std::size_t>(size));
  });
  std::string out;
  // ProcessGroup appends --lcm-url URL, which xvfb-run and timeout pass on to tools/logplayer.
  const int rc =
      group.run_to_completion({"logplayer",
                               paths::kXvfbRun,
                               {"-a", paths::kTimeout, "-k", "3", "10", paths::kLogPlayer, path},
                               {std::string("JAVA=") + paths::kJava, std::string("LCM_JAR=") + paths::kLcmJar}},
                              &out, seconds(60));
  EXPECT_EQ(rc, 124) << "the log player was not running any more after 10 s (124 = stopped by timeout)\n" << out;
  EXPECT_FALSE(contains(out, "Exception")) << out;
  ASSERT_EQ(received.size(), static_cast<std::size_t>(kEvents)) << out;
  for (int i = 0; i < kEvents; ++i) EXPECT_EQ(received[static_cast<std::size_t>(i)], "message " + std::to_string(i));
}

}  // namespace
}  // namespace motion::testing
