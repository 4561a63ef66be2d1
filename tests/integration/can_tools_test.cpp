// motionctl dump / send against a real motion-sim hub (bit-timed simulated CAN bus), and the
// dump read back by an independent parser: python-can's candump -L reader (Debian python3-can,
// run with /usr/bin/python3).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "motion/can_frame/bit_timing.hpp"
#include "motion/can_frame/frame.hpp"
#include "motion/core/clock.hpp"
#include "motion/testing/process_group.hpp"

namespace motion::testing {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;

// Bus name (the candump interface) differs from the simbus name, so the test sees which is used.
constexpr const char* kBus = "can7";
constexpr std::uint32_t kBitrate = 125'000;
constexpr const char* kListening = "motionctl dump: listening on can7";

std::string write_config(const ProcessGroup& group) {
  std::string path = group.work_dir() + "/can-tools.yaml";
  std::ofstream(path) << "lcm:\n  channel_prefix: \"MOTION_\"\n"
                         "buses:\n"
                         "  - name: can7\n    transport: simcan:simlab7\n    bitrate: 125000\n    bus_timing: true\n"
                         "  - name: rs485\n    transport: simserial:rs485\n    baud: 115200\n"
                         "  - name: hw0\n    transport: socketcan:can0\n    bitrate: 500000\n";
  return path;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty()) out.push_back(line);
  }
  return out;
}

std::vector<std::string> sorted_cansend(const std::vector<can::Frame>& frames) {
  std::vector<std::string> out;
  out.reserve(frames.size());
  for (const auto& f : frames) out.push_back(can::to_cansend(f));
  std::sort(out.begin(), out.end());
  return out;
}

// Starts motion-sim on `config` and waits for its heartbeat (DEGRADED is fine: no drives).
void start_sim(ProcessGroup& group, const std::string& config) {
  group.start({"sim", "motion-sim", {"--config", config}, {}});
  ASSERT_TRUE(group.wait_for_heartbeat("sim", seconds(15), /*accept_degraded=*/true));
}

// Starts `motionctl dump` and waits for its "listening" line (attached to the bus: every frame
// sent from then on is dumped).
pid_t start_dump(ProcessGroup& group, const std::string& config, const std::vector<std::string>& extra) {
  std::vector<std::string> args{"--config", config, "dump", kBus};
  args.insert(args.end(), extra.begin(), extra.end());
  const pid_t pid = group.start({"dump", "motionctl", args, {}});
  EXPECT_TRUE(group.pump_until(
      [&] { return group.log_of("dump").find(kListening) != std::string::npos || group.exit_status(pid); },
      seconds(10)))
      << "dump never said it was listening:\n"
      << group.log_of("dump");
  return pid;
}

// The frames the test sends: every format corner (standard/extended, the same numeric id in both,
// the largest ids, RTR with and without a DLC, empty and full payloads, '.' separators), then a
// burst to check that nothing is lost.
std::vector<std::string> frames_to_send() {
  std::vector<std::string> out{"04280095#01", "123#DEADBEEF", "7FF#R", "1FFFFFFF#0011223344556677", "000#",
                               "00000123#R4", "701#05",       "080#",  "12345678#11.22.33",         "123#"};
  for (int i = 0; i < 40; ++i) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%03X#", 0x200 + i);
    std::string text = buf;
    for (int b = 0; b < i % 9; ++b) {
      std::snprintf(buf, sizeof buf, "%02X", (i * 17 + b) & 0xFF);
      text += buf;
    }
    out.push_back(text);
  }
  return out;
}

TEST(CanTools, DumpShowsWhatSendSentWithBitTimedTimestampsAndPythonCanReadsTheDump) {
  ProcessGroup group;
  const std::string config = write_config(group);
  start_sim(group, config);
  if (HasFatalFailure()) return;

  const auto texts = frames_to_send();
  std::vector<can::Frame> sent;
  for (const auto& t : texts) {
    auto f = can::parse_cansend(t);
    ASSERT_TRUE(f) << t;
    sent.push_back(*f);
  }
  // A few expectations written out by hand, independent of parse_cansend.
  EXPECT_TRUE(sent[0].extended && sent[0].id == 0x04280095 && sent[0].dlc == 1 && sent[0].data[0] == 0x01);
  EXPECT_TRUE(!sent[1].extended && sent[1].id == 0x123 && sent[1].dlc == 4 && sent[1].data[3] == 0xEF);
  EXPECT_TRUE(!sent[2].extended && sent[2].rtr && sent[2].dlc == 0);
  EXPECT_TRUE(sent[5].extended && sent[5].id == 0x123 && sent[5].rtr && sent[5].dlc == 4);

  const pid_t dump = start_dump(group, config, {"--count", std::to_string(sent.size()), "--for", "30"});
  if (HasFailure()) return;

  const std::int64_t before_us = wall_time_us();
  std::vector<std::string> args{"--config", config, "send", kBus};
  args.insert(args.end(), texts.begin(), texts.end());
  std::string send_out;
  ASSERT_EQ(group.run_to_completion({"send", "motionctl", args, {}}, &send_out, seconds(20)), 0) << send_out;
  EXPECT_EQ(send_out, "") << "send prints nothing on success";

  // --count: dump stops by itself once it has every frame.
  ASSERT_TRUE(group.pump_until([&] { return group.exit_status(dump).has_value(); }, seconds(15)))
      << group.log_of("dump");
  EXPECT_EQ(group.exit_status(dump), 0);
  const std::int64_t after_us = wall_time_us();

  // Everything dump wrote, apart from its one "listening" line on stderr, is a candump -L line.
  std::vector<std::string> dumped_lines;
  std::vector<can::LogLine> dumped;
  for (const auto& line : lines_of(group.log_of("dump"))) {
    if (line.rfind(kListening, 0) == 0) continue;
    auto parsed = can::parse_candump_line(line);
    ASSERT_TRUE(parsed) << "not a candump -L line: '" << line << "'";
    EXPECT_EQ(can::to_candump_line(parsed->frame, parsed->interface), line) << "not in canonical candump -L form";
    dumped_lines.push_back(line);
    dumped.push_back(*parsed);
  }
  ASSERT_EQ(dumped.size(), sent.size());

  std::vector<can::Frame> dumped_frames;
  for (const auto& d : dumped) {
    EXPECT_EQ(d.interface, kBus) << "interface must be the configured bus name";
    dumped_frames.push_back(d.frame);
  }
  // The simulated wire arbitrates between queued frames (lowest id first), so the order on the
  // bus may differ from the command line; the frames themselves must not.
  EXPECT_EQ(sorted_cansend(dumped_frames), sorted_cansend(sent));
  // Format flags survive (to_cansend encodes them, but check the fields directly too).
  const auto count_if = [](const std::vector<can::Frame>& v, auto pred) {
    return std::count_if(v.begin(), v.end(), pred);
  };
  EXPECT_EQ(count_if(dumped_frames, [](const can::Frame& f) { return f.extended; }), 4);
  EXPECT_EQ(count_if(dumped_frames, [](const can::Frame& f) { return f.rtr; }), 2);

  // Timestamps: wall-clock end-of-frame times within the send, strictly increasing, and at least
  // one frame length (bit-timing model at 125 kbit/s) plus the interframe space apart.
  std::size_t back_to_back = 0;  // gaps of exactly one frame: the frame waited for the wire
  for (std::size_t i = 0; i < dumped.size(); ++i) {
    const auto ts = dumped[i].timestamp_us;
    EXPECT_GE(ts, before_us - 1000) << dumped_lines[i];
    EXPECT_LE(ts, after_us + 1000) << dumped_lines[i];
    if (i == 0) continue;
    const auto bits = can::frame_bits(dumped[i].frame).to_end_of_frame() + can::kInterframeBits;
    const auto min_gap_us =
        std::chrono::duration_cast<std::chrono::microseconds>(can::bits_duration(bits, kBitrate)).count();
    EXPECT_GT(ts, dumped[i - 1].timestamp_us) << dumped_lines[i - 1] << " / " << dumped_lines[i];
    EXPECT_GE(ts - dumped[i - 1].timestamp_us, min_gap_us - 1)
        << "frames closer than the wire allows: " << dumped_lines[i - 1] << " / " << dumped_lines[i];
    if (std::abs(ts - dumped[i - 1].timestamp_us - min_gap_us) <= 1) ++back_to_back;
  }
  // send queues the frames at once, so the wire runs them back to back (most of them at least:
  // the hub reads a connection in batches).
  EXPECT_GE(back_to_back, dumped.size() / 2) << "the bit-timed wire did not serialize the frames back to back";

  // python-can reads the dump.
  const std::string python = "/usr/bin/python3";
  ASSERT_EQ(::access(python.c_str(), X_OK), 0)
      << python
      << " is missing: install Debian's python3 and python3-can "
         "(tools/lib/packages.txt); this test needs python-can as an independent "
         "candump -L parser";
  const std::string log_file = group.work_dir() + "/dump.log";
  {
    std::ofstream out(log_file);
    for (const auto& line : dumped_lines) out << line << "\n";
  }
  const std::string script = group.work_dir() + "/read_dump.py";
  std::ofstream(script) << R"(import sys
try:
    import can
except ImportError as e:
    print("PYTHON-CAN-MISSING", e)
    sys.exit(3)
# argv[1]: the log file (the harness appends --lcm-url URL, ignored)
print("python-can", can.__version__)
for m in can.CanutilsLogReader(sys.argv[1]):
    data = bytes(m.data).hex().upper() if m.data is not None else ""
    print("MSG %X %d %d %d %s %.6f %s" % (m.arbitration_id, m.dlc, int(m.is_extended_id), int(m.is_remote_frame),
                                          data or "-", m.timestamp, m.channel))
)";
  std::string py_out;
  const int py_rc = group.run_to_completion({"python-can", python, {script, log_file}, {}}, &py_out, seconds(30));
  ASSERT_NE(py_rc, 3) << "python-can is not installed for " << python << " (apt-get install python3-can): " << py_out;
  ASSERT_EQ(py_rc, 0) << py_out;
  std::vector<std::string> msgs;
  for (const auto& line : lines_of(py_out)) {
    if (line.rfind("MSG ", 0) == 0) msgs.push_back(line);
  }
  ASSERT_EQ(msgs.size(), dumped.size()) << py_out;
  for (std::size_t i = 0; i < msgs.size(); ++i) {
    std::istringstream in(msgs[i].substr(4));
    std::string id_hex;
    std::string data_hex;
    std::string channel;
    int dlc = -1;
    int extended = -1;
    int rtr = -1;
    double timestamp = 0;
    in >> id_hex >> dlc >> extended >> rtr >> data_hex >> timestamp >> channel;
    ASSERT_FALSE(in.fail()) << msgs[i];
    const can::Frame& f = dumped[i].frame;
    EXPECT_EQ(std::stoul(id_hex, nullptr, 16), f.id) << msgs[i] << " vs " << dumped_lines[i];
    EXPECT_EQ(dlc, f.dlc) << msgs[i] << " vs " << dumped_lines[i];
    EXPECT_EQ(extended == 1, f.extended) << msgs[i] << " vs " << dumped_lines[i];
    EXPECT_EQ(rtr == 1, f.rtr) << msgs[i] << " vs " << dumped_lines[i];
    std::string expected_data;
    if (!f.rtr) {
      for (std::size_t b = 0; b < f.dlc; ++b) {
        char buf[4];
        std::snprintf(buf, sizeof buf, "%02X", f.data[b]);
        expected_data += buf;
      }
    }
    EXPECT_EQ(data_hex, expected_data.empty() ? "-" : expected_data) << msgs[i] << " vs " << dumped_lines[i];
    EXPECT_NEAR(timestamp * 1e6, static_cast<double>(dumped[i].timestamp_us), 2.0)
        << msgs[i] << " vs " << dumped_lines[i];
    EXPECT_EQ(channel, kBus) << msgs[i];
  }
}

TEST(CanTools, SendRefusesBadCansendSyntaxWithTheReason) {
  ProcessGroup group;
  const std::string config = write_config(group);
  const std::vector<std::pair<std::string, std::string>> cases{
      {"12#34", "the id needs 3 hex digits (11-bit) or 8 (29-bit), not 2"},
      {"12345#00", "not 5"},
      {"800#00", "an 11-bit id is at most 7FF"},
      {"20000000#00", "a 29-bit id is at most 1FFFFFFF"},
      {"12G#00", "the id is not hexadecimal"},
      {"123#123", "the data must be up to 8 bytes"},
      {"123#001122334455667788", "the data must be up to 8 bytes"},
      {"123#R9", "R0..R8"},
      {"123DEADBEEF", "no '#' between id and data"},
  };
  for (const auto& [text, reason] : cases) {
    std::string out;
    // A good frame first: one bad frame anywhere refuses the whole command before anything is sent.
    EXPECT_EQ(group.run_to_completion({"send-bad", "motionctl", {"--config", config, "send", kBus, "123#00", text}, {}},
                                      &out),
              2)
        << text << ": " << out;
    EXPECT_NE(out.find("'" + text + "' is not cansend syntax ID#DATA"), std::string::npos) << text << ": " << out;
    EXPECT_NE(out.find(reason), std::string::npos) << text << ": " << out;
  }
}

TEST(CanTools, BusErrorsNameTheBusAndTransport) {
  ProcessGroup group;
  const std::string config = write_config(group);
  std::string out;
  // No motion-sim: no hub for the simulated bus.
  EXPECT_EQ(
      group.run_to_completion({"dump-nosim", "motionctl", {"--config", config, "dump", kBus, "--for", "1"}, {}}, &out),
      4)
      << out;
  EXPECT_NE(out.find("bus can7 (simcan:simlab7): no simulated bus 'simlab7' at " + group.work_dir() +
                     "/sim/motion-simbus-simlab7.sock"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("is motion-sim running"), std::string::npos) << out;
  EXPECT_EQ(
      group.run_to_completion({"send-nosim", "motionctl", {"--config", config, "send", kBus, "123#00"}, {}}, &out), 4)
      << out;
  EXPECT_NE(out.find("bus can7 (simcan:simlab7): no simulated bus"), std::string::npos) << out;
  // A serial bus is not CAN; an unknown bus lists the CAN buses.
  EXPECT_EQ(
      group.run_to_completion({"send-serial", "motionctl", {"--config", config, "send", "rs485", "123#00"}, {}}, &out),
      2)
      << out;
  EXPECT_NE(out.find("bus rs485 (simserial:rs485) is not a CAN bus"), std::string::npos) << out;
  EXPECT_EQ(group.run_to_completion({"dump-unknown", "motionctl", {"--config", config, "dump", "nope"}, {}}, &out), 2)
      << out;
  EXPECT_NE(out.find("bus 'nope' is not in " + config + " (CAN buses: can7, hw0)"), std::string::npos) << out;
  // SocketCAN: no AF_CAN in this kernel, or no can0 interface on a machine with one: either way it
  // fails and names the bus and interface.
  EXPECT_NE(group.run_to_completion(
                {"dump-socketcan", "motionctl", {"--config", config, "dump", "hw0", "--for", "0.5"}, {}}, &out),
            0)
      << out;
  EXPECT_NE(out.find("bus hw0 (socketcan:can0)"), std::string::npos) << out;
}

TEST(CanTools, DumpForStopsOnTimeAndDumpsNothingOnAQuietBus) {
  ProcessGroup group;
  const std::string config = write_config(group);
  start_sim(group, config);
  if (HasFatalFailure()) return;
  const auto start = std::chrono::steady_clock::now();
  std::string out;
  EXPECT_EQ(group.run_to_completion({"dump", "motionctl", {"--config", config, "dump", kBus, "--for", "0.7"}, {}}, &out,
                                    seconds(10)),
            0)
      << out;
  const auto elapsed = std::chrono::steady_clock::now() - start;
  EXPECT_GE(elapsed, milliseconds(700));
  EXPECT_LT(elapsed, seconds(5));
  EXPECT_EQ(lines_of(out), std::vector<std::string>{std::string(kListening) + " (simcan:simlab7)"}) << out;
}

}  // namespace
}  // namespace motion::testing
