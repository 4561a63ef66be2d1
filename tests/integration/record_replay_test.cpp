// Record and replay with LCM's own tools: lcm-logger records the simulated lab's traffic on the
// test's LCM URL while a client enables and moves axes; `motionctl log` reads the file back
// (requests, replies, trajectories, as CSV); lcm-logplayer replays it onto a fresh URL, where a
// subscriber must receive exactly the recorded axis states. Also: motionctl log's errors on a
// missing, foreign, corrupt and truncated file.
#include <gtest/gtest.h>

#include <lcm/eventlog.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <motionlcm/axis_state_t.hpp>

#include "motion/lcm/channels.hpp"
#include "motion/testing/lcm_url.hpp"
#include "sim_lab.hpp"

namespace motion::testing {
namespace {

using motionlcm::axis_state_t;
using Clock = std::chrono::steady_clock;

constexpr const char* kLogger = "/usr/bin/lcm-logger";
constexpr const char* kLogPlayer = "/usr/bin/lcm-logplayer";
constexpr double kPositionTolerance = 1.0 / 640.0;  // one micro-step of x/y, mm

std::int8_t status(std::int8_t s) { return s; }

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// One CSV line into fields ("" quoting as motionctl writes it).
std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        out.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        out.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

// CSV rows as column-name -> value maps.
std::vector<std::map<std::string, std::string>> read_csv(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::vector<std::map<std::string, std::string>> rows;
  if (!std::getline(in, line)) return rows;
  const auto header = split_csv(line);
  while (std::getline(in, line)) {
    const auto fields = split_csv(line);
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < header.size() && i < fields.size(); ++i) row[header[i]] = fields[i];
    rows.push_back(std::move(row));
  }
  return rows;
}

// Raw payloads of `channel` in an LCM log, read with LCM's eventlog API.
std::vector<std::vector<std::uint8_t>> recorded(const std::string& path, const std::string& channel) {
  std::vector<std::vector<std::uint8_t>> out;
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "r");
  if (log == nullptr) return out;
  while (lcm_eventlog_event_t* e = lcm_eventlog_read_next_event(log)) {
    if (std::string(e->channel, static_cast<std::size_t>(e->channellen)) == channel) {
      const auto* p = static_cast<const std::uint8_t*>(e->data);
      out.emplace_back(p, p + e->datalen);
    }
    lcm_eventlog_free_event(e);
  }
  lcm_eventlog_destroy(log);
  return out;
}

axis_state_t decode_state(const std::vector<std::uint8_t>& bytes) {
  axis_state_t s{};
  s.decode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return s;
}

std::uintmax_t size_of(const std::string& path) {
  std::error_code ec;
  const auto n = std::filesystem::file_size(path, ec);
  return ec ? 0 : n;
}

TEST(RecordReplay, LoggedMoveIsReadByMotionctlLogAndReplayedByLogplayer) {
  const auto t0 = Clock::now();
  SimLab lab;
  auto& group = lab.group();
  ASSERT_TRUE(lab.start({"x", "y"}));
  const double t_lab = seconds_since(t0);

  // Record everything on the lab's URL. The log grows with every axis state (poll rate), so its
  // first bytes on disk prove the logger is subscribed.
  const std::string log_path = group.work_dir() + "/session.lcmlog";
  const pid_t logger =
      group.start({"lcm-logger", kLogger, {"--quiet", "--force", "--flush-interval=50", log_path}, {}});
  ASSERT_TRUE(group.pump_until([&] { return size_of(log_path) > 0; }, seconds(10))) << "lcm-logger wrote nothing:\n"
                                                                                    << group.log_of("lcm-logger");

  const auto enabled = lab.call(Client::make(request_t::ENABLE, std::vector<std::string>{"x", "y"}));
  ASSERT_EQ(enabled.status, status(reply_t::DONE)) << enabled.reason;
  std::vector<reply_t> replies;
  const auto moved = lab.call(
      Client::make(request_t::MOVE_ABSOLUTE, std::map<std::string, double>{{"x", 10.0}, {"y", 5.0}}), &replies);
  ASSERT_EQ(moved.status, status(reply_t::DONE)) << moved.reason;
  // A few more samples of the axes at rest, then stop the logger (SIGTERM: it flushes and exits 0).
  group.pump_until([] { return false; }, milliseconds(500));
  group.stop(logger);
  EXPECT_EQ(group.exit_status(logger), 0) << group.log_of("lcm-logger");
  const double t_recorded = seconds_since(t0);

  // motionctl move on the simulated lab puts the simulated drives' own start times (SIM_REPORT)
  // beside the coordinator's measured skew, in all and per axis: x and y start on one group BG
  // frame, so the ground truth is 0 µs.
  {
    std::string moved_out;
    ASSERT_EQ(group.run_to_completion(
                  {"motionctl-move",
                   "motionctl",
                   {"--config", source_path("config/sim-lab.yaml"), "--json", "move", "x=2", "y=1", "--wait"},
                   {}},
                  &moved_out),
              0)
        << moved_out;
    const auto j =
        nlohmann::json::parse(moved_out.substr(std::min(moved_out.find('{'), moved_out.size())), nullptr, false);
    ASSERT_TRUE(j.is_object()) << moved_out;
    ASSERT_TRUE(j["ground_truth_start_skew_us"].is_number()) << moved_out;
    EXPECT_EQ(j["ground_truth_start_skew_us"].get<double>(), 0.0) << moved_out;
    // And each axis's own: the same instant for both (the text's SIM START column).
    ASSERT_TRUE(j["axes"]["x"]["ground_truth_start_utime"].is_number()) << moved_out;
    EXPECT_GT(j["axes"]["x"]["ground_truth_start_utime"].get<std::int64_t>(), 0) << moved_out;
    EXPECT_EQ(j["axes"]["x"]["ground_truth_start_utime"], j["axes"]["y"]["ground_truth_start_utime"]) << moved_out;
  }

  const std::string prefix = lab.config().lcm.channel_prefix;
  const auto states = recorded(log_path, prefix + std::string(lcm::channels::kAxisState));
  ASSERT_FALSE(states.empty()) << "no axis state in the log (" << size_of(log_path) << " bytes)";
  EXPECT_FALSE(recorded(log_path, prefix + std::string(lcm::channels::kRequest)).empty());

  // (a) motionctl log --csv: the request, its DONE reply with the skew, trajectories ending at the targets.
  const std::string config = source_path("config/sim-lab.yaml");
  const std::string csv = group.work_dir() + "/session.csv";
  const std::string svg = group.work_dir() + "/session.svg";
  std::string out;
  ASSERT_EQ(
      group.run_to_completion({"motionctl-log-csv",
                               "motionctl",
                               {"--config", config, "log", log_path, "--csv", csv, "--plot", svg, "--axis", "x", "y"},
                               {}},
                              &out),
      0)
      << out;
  const auto rows = read_csv(csv);
  ASSERT_FALSE(rows.empty()) << out;
  std::string move_id;
  std::map<std::string, std::map<std::string, std::string>> last_state;
  std::map<std::string, std::size_t> states_of;
  std::size_t state_rows = 0;
  bool saw_moving = false;
  for (const auto& row : rows) {
    if (row.at("record") == "request" && row.at("kind") == "MOVE_ABSOLUTE") {
      EXPECT_EQ(row.at("detail"), "x=10;y=5");
      move_id = row.at("request_id");
    }
    if (row.at("record") == "state") {
      ++state_rows;
      ++states_of[row.at("axis")];
      EXPECT_TRUE(row.at("axis") == "x" || row.at("axis") == "y")
          << "--axis filter let " << row.at("axis") << " through";
      last_state[row.at("axis")] = row;
      if (row.at("moving") == "1") saw_moving = true;
    }
  }
  ASSERT_FALSE(move_id.empty()) << "no MOVE_ABSOLUTE request in the CSV";
  bool done_seen = false;
  for (const auto& row : rows) {
    if (row.at("record") == "reply" && row.at("request_id") == move_id && row.at("status") == "DONE") {
      done_seen = true;
      EXPECT_NEAR(std::stod(row.at("measured_skew_us")), moved.measured_start_skew_us, 0.1);
    }
  }
  EXPECT_TRUE(done_seen) << "no DONE reply for the move in the CSV";
  EXPECT_TRUE(saw_moving) << "the recorded trajectory never shows the axes moving";
  ASSERT_TRUE(last_state.contains("x") && last_state.contains("y"));
  EXPECT_NEAR(std::stod(last_state["x"].at("position")), 10.0, kPositionTolerance);
  EXPECT_NEAR(std::stod(last_state["y"].at("position")), 5.0, kPositionTolerance);
  EXPECT_EQ(last_state["x"].at("moving"), "0");

  // --plot: one panel per selected axis, each with every state of its axis.
  std::ifstream svg_file(svg);
  const std::string svg_text((std::istreambuf_iterator<char>(svg_file)), std::istreambuf_iterator<char>());
  std::size_t panels = 0;
  for (auto at = svg_text.find("<g class=\"panel\""); at != std::string::npos;
       at = svg_text.find("<g class=\"panel\"", at + 1))
    ++panels;
  EXPECT_EQ(panels, 2u) << out;
  for (const std::string axis : {"x", "y"}) {
    const std::string panel =
        "<g class=\"panel\" data-axis=\"" + axis + "\" data-samples=\"" + std::to_string(states_of[axis]) + "\"";
    EXPECT_NE(svg_text.find(panel), std::string::npos) << "no " << panel << " in " << svg;
  }
  EXPECT_NE(svg_text.find("move done"), std::string::npos) << "the move's end is not marked";
  EXPECT_NE(svg_text.find("move planned arrival"), std::string::npos) << "the move's planned arrival is not marked";

  // The same as tables.
  ASSERT_EQ(group.run_to_completion(
                {"motionctl-log", "motionctl", {"--config", config, "log", log_path, "--axis", "x"}, {}}, &out),
            0)
      << out;
  EXPECT_NE(out.find("MOVE_ABSOLUTE  x=10 y=5"), std::string::npos) << out;
  EXPECT_NE(out.find("DONE"), std::string::npos) << out;
  EXPECT_NE(out.find("start skew"), std::string::npos) << out;
  EXPECT_NE(out.find("axis x (uim342 on can0"), std::string::npos) << out;
  EXPECT_EQ(out.find("axis y ("), std::string::npos) << "--axis x printed y:\n" << out;

  // --json: the same content for scripts: the move with its replies, every sample of x and y.
  ASSERT_EQ(
      group.run_to_completion(
          {"motionctl-log-json", "motionctl", {"--config", config, "--json", "log", log_path, "--axis", "x", "y"}, {}},
          &out),
      0)
      << out;
  const auto doc = nlohmann::json::parse(out.substr(std::min(out.find('{'), out.size())), nullptr, false);
  ASSERT_TRUE(doc.is_object()) << out;
  bool json_move = false;
  for (const auto& r : doc["requests"]) {
    if (r.value("kind", "") != "MOVE_ABSOLUTE") continue;
    json_move = true;
    EXPECT_EQ(r["values"], nlohmann::json({10.0, 5.0}));
    EXPECT_EQ(r["terminal"], true);
    ASSERT_FALSE(r["replies"].empty());
    const auto& last = r["replies"].back();
    EXPECT_EQ(last["status"], "DONE");
    EXPECT_NEAR(last["positions"]["x"].get<double>(), 10.0, kPositionTolerance);
  }
  EXPECT_TRUE(json_move) << "no MOVE_ABSOLUTE in the JSON";
  ASSERT_EQ(doc["axes"].size(), 2u) << "--axis x y let others through";
  bool json_moving = false;
  for (const auto& [axis, target] : {std::pair{"x", 10.0}, std::pair{"y", 5.0}}) {
    const auto& samples = doc["axes"][axis]["samples"];
    ASSERT_EQ(samples.size(), states_of[axis]) << axis;
    EXPECT_NEAR(samples.back()["position"].get<double>(), target, kPositionTolerance) << axis;
    EXPECT_TRUE(samples.back()["moving"].is_boolean()) << axis;
    for (const auto& sample : samples) json_moving = json_moving || sample["moving"] == true;
  }
  EXPECT_EQ(json_moving, saw_moving);
  EXPECT_EQ(
      group.run_to_completion(
          {"motionctl-log-json-csv", "motionctl", {"--config", config, "--json", "log", log_path, "--csv", "-"}, {}},
          &out),
      2)
      << out;
  EXPECT_NE(out.find("--json and --csv both choose the output"), std::string::npos) << out;

  // status --json on the running lab: real booleans and each sample's age.
  ASSERT_EQ(group.run_to_completion(
                {"motionctl-status-json", "motionctl", {"--config", config, "--json", "status"}, {}}, &out),
            0)
      << out;
  const auto status_doc = nlohmann::json::parse(out.substr(std::min(out.find('{'), out.size())), nullptr, false);
  ASSERT_TRUE(status_doc.is_object()) << out;
  EXPECT_TRUE(status_doc["x"]["moving"].is_boolean()) << status_doc["x"];
  EXPECT_TRUE(status_doc["x"]["online"].is_boolean()) << status_doc["x"];
  ASSERT_TRUE(status_doc["x"]["age_s"].is_number()) << status_doc["x"];
  EXPECT_GE(status_doc["x"]["age_s"].get<double>(), 0.0);
  EXPECT_LT(status_doc["x"]["age_s"].get<double>(), 5.0) << "a live axis's last state is seconds old";

  // (b) lcm-logplayer onto a fresh URL: the subscriber receives the recorded axis states, in order.
  ProcessGroup replay(unique_lcm_url(1));
  ASSERT_NE(replay.lcm_url(), group.lcm_url());
  std::vector<std::vector<std::uint8_t>> received;
  replay.node().subscribe_raw(prefix + std::string(lcm::channels::kAxisState),
                              [&](const void* data, int size, const std::string&) {
                                const auto* p = static_cast<const std::uint8_t*>(data);
                                received.emplace_back(p, p + size);
                              });
  const auto replay_start = Clock::now();
  const pid_t player = replay.start({"lcm-logplayer", kLogPlayer, {"--speed=2", log_path}, {}});
  ASSERT_TRUE(replay.pump_until([&] { return replay.exit_status(player).has_value(); }, seconds(60)))
      << "lcm-logplayer did not finish";
  const double replay_s = seconds_since(replay_start);
  EXPECT_EQ(replay.exit_status(player), 0) << replay.log_of("lcm-logplayer");
  replay.pump_until([&] { return received.size() >= states.size(); }, seconds(2));
  EXPECT_EQ(received.size(), states.size());
  std::size_t mismatches = 0;
  for (std::size_t i = 0; i < std::min(received.size(), states.size()); ++i) {
    if (received[i] != states[i]) ++mismatches;
  }
  EXPECT_EQ(mismatches, 0u) << "replayed axis states differ from the recorded ones";
  ASSERT_FALSE(received.empty());
  const auto last_x = [&] {
    axis_state_t found{};
    for (const auto& bytes : received) {
      auto s = decode_state(bytes);
      if (s.axis == "x") found = s;
    }
    return found;
  }();
  EXPECT_NEAR(last_x.position, 10.0, kPositionTolerance);

  std::printf(
      "[ timing ] lab up %.2f s; recorded %.2f s; log %ju bytes, %zu axis states (%zu rows x/y in CSV); replay at 2x "
      "took %.2f s, %zu received\n",
      t_lab, t_recorded - t_lab, size_of(log_path), states.size(), state_rows, replay_s, received.size());
}

// A small log written with LCM's eventlog API: `count` axis states of axis "x".
void write_log(const std::string& path, int count) {
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
  ASSERT_NE(log, nullptr);
  for (int i = 0; i < count; ++i) {
    axis_state_t s{};
    s.utime = 1'700'000'000'000'000 + std::int64_t{i} * 50'000;
    s.sample_utime = s.utime;
    s.axis = "x";
    s.family = "uim342";
    s.bus = "can0";
    s.position = 0.5 * i;
    s.velocity = 10.0;
    s.moving = i + 1 < count;
    s.online = true;
    s.enabled = true;
    std::vector<std::uint8_t> data(static_cast<std::size_t>(s.getEncodedSize()));
    s.encode(data.data(), 0, static_cast<int>(data.size()));
    std::string channel = "MOTION_AXIS_STATE";
    lcm_eventlog_event_t e{};
    e.timestamp = s.utime;
    e.channellen = static_cast<std::int32_t>(channel.size());
    e.datalen = static_cast<std::int32_t>(data.size());
    e.channel = channel.data();
    e.data = data.data();
    ASSERT_EQ(lcm_eventlog_write_event(log, &e), 0);
  }
  lcm_eventlog_destroy(log);
}

class MotionctlLogFiles : public ::testing::Test {
 protected:
  int log(const std::string& file, std::string* out, std::vector<std::string> extra = {}) {
    std::vector<std::string> args{"--config", source_path("config/sim-lab.yaml"), "log", file};
    args.insert(args.end(), extra.begin(), extra.end());
    return group.run_to_completion({"motionctl-log-" + std::to_string(++runs), "motionctl", args, {}}, out);
  }
  std::size_t state_rows(const std::string& csv_text) {
    std::size_t n = 0;
    for (std::size_t at = 0; (at = csv_text.find("\nstate,", at)) != std::string::npos; ++at) ++n;
    return n;
  }
  ProcessGroup group;
  int runs = 0;
};

TEST_F(MotionctlLogFiles, AWholeLogIsReadCompletely) {
  const std::string path = group.work_dir() + "/ok.lcmlog";
  write_log(path, 5);
  std::string out;
  EXPECT_EQ(log(path, &out, {"--csv", "-"}), 0) << out;
  EXPECT_EQ(state_rows(out), 5u) << out;
  EXPECT_NE(out.find("state,0.200000,1700000000200000,x,2.000000,10.000000,0,1,1,0"), std::string::npos) << out;
}

TEST_F(MotionctlLogFiles, AMissingFileFailsWithExitCode1) {
  std::string out;
  EXPECT_EQ(log(group.work_dir() + "/nothing-here.lcmlog", &out), 1) << out;
  EXPECT_NE(out.find("cannot open log"), std::string::npos) << out;
  EXPECT_NE(out.find("No such file or directory"), std::string::npos) << out;
}

TEST_F(MotionctlLogFiles, AFileThatIsNotAnLcmLogFailsWithExitCode1) {
  const std::string path = group.work_dir() + "/notes.txt";
  std::ofstream(path) << "this is not an LCM event log\n";
  std::string out;
  EXPECT_EQ(log(path, &out), 1) << out;
  EXPECT_NE(out.find("not an LCM event log"), std::string::npos) << out;
}

TEST_F(MotionctlLogFiles, DamageInTheMiddleIsReportedWithItsOffsetAfterTheEventsBeforeIt) {
  const std::string path = group.work_dir() + "/damaged.lcmlog";
  write_log(path, 5);
  const auto record = size_of(path) / 5;  // every record has the same size here
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(2 * record));
    f.write("JUNK", 4);  // the third record's marker
  }
  std::string out;
  EXPECT_EQ(log(path, &out, {"--csv", "-"}), 1) << out;
  EXPECT_EQ(state_rows(out), 2u) << out;
  EXPECT_NE(out.find("is corrupt"), std::string::npos) << out;
  EXPECT_NE(out.find("offset " + std::to_string(2 * record)), std::string::npos) << out;
}

TEST_F(MotionctlLogFiles, ATruncatedFinalRecordIsOnlyAWarning) {
  const std::string path = group.work_dir() + "/cut.lcmlog";
  write_log(path, 5);
  std::filesystem::resize_file(path, size_of(path) - 7);
  std::string out;
  EXPECT_EQ(log(path, &out, {"--csv", "-"}), 0) << out;
  EXPECT_EQ(state_rows(out), 4u) << out;
  EXPECT_NE(out.find("truncated final record"), std::string::npos) << out;
}

TEST_F(MotionctlLogFiles, ABrokenConfigurationIsExitCode3) {
  const std::string path = group.work_dir() + "/ok.lcmlog";
  write_log(path, 1);
  const std::string bad = group.work_dir() + "/bad.yaml";
  std::ofstream(bad) << "lcm: {url: 3, nonsense: true}\n";
  std::string out;
  EXPECT_EQ(group.run_to_completion({"motionctl-log-badconfig", "motionctl", {"--config", bad, "log", path}, {}}, &out),
            3)
      << out;
}

}  // namespace
}  // namespace motion::testing
