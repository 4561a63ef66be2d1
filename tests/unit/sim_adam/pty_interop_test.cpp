// Interoperability over real pseudo-terminals (termios raw, 115200 8N1):
//  * SimSlaveAnswersPymodbusClient: AdamLineSim (our simulated drive) serves pymodbus's
//    ModbusSerialClient: reads, a 32-bit move write, an exception for an undocumented register;
//  * MasterTalksToPymodbusServer: AdamBusDriver (our master, with its SerialPort) sets up and
//    reads/writes registers of a pymodbus RTU server; a null-modem bridge joins the two ptys;
//  * MasterAndSimulatorMoveEndToEnd: our master arms a move on our simulator, starts it with the
//    broadcast, and the simulator reports MOTION_STARTED at the end of that frame.
// pymodbus tests skip (GTEST_SKIP) when /usr/bin/python3 has no pymodbus (Debian python3-pymodbus,
// listed in tools/lib/packages.txt). Every child process is killed by pid in TearDown.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <motionlcm/event_t.hpp>

#include "motion/adam/rtu.hpp"
#include "motion/adam_driver/adam_bus_driver.hpp"
#include "motion/serial/pty_link.hpp"
#include "motion/serial/serial_port.hpp"
#include "motion/sim/adam_line_sim.hpp"

extern char** environ;

namespace motion {
namespace {

using namespace std::chrono_literals;
using Reply = motionlcm::gateway_reply_t;
constexpr const char* kPython = "/usr/bin/python3";

bool pymodbus_available() { return std::system("/usr/bin/python3 -c 'import pymodbus' >/dev/null 2>&1") == 0; }

struct Recorder final : gateway::GatewayOutput {
  std::vector<Reply> replies;
  std::vector<gateway::DriveEvent> events;
  void axis_status(const std::string&, const gateway::DriveStatus&) override {}
  void axis_event(const std::string&, const gateway::DriveEvent& e) override { events.push_back(e); }
  void command_reply(Reply r) override { replies.push_back(std::move(r)); }
  [[nodiscard]] const Reply* terminal(std::int64_t id) const {
    for (const auto& r : replies) {
      if (r.command_id == id && (r.status == std::int8_t{Reply::DONE} || r.status == std::int8_t{Reply::FAILED}))
        return &r;
    }
    return nullptr;
  }
};

class PtyInterop : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("adam-pty-" + std::to_string(::getpid()) + "-" +
                                                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
    const std::string yaml =
        "buses:\n"
        "  - {name: rs485, transport: 'simserial:rs485', baud: 115200, request_timeout_ms: 100, retries: 1, poll_hz: "
        "10}\n"
        "drives:\n"
        "  - {name: c-drive, family: adam-modbus, bus: rs485, node_id: 1}\n"
        "axes:\n"
        "  - {name: c, drive: c-drive, unit: mm, steps_per_unit: 200, limits: {min: -1000, max: 1000, velocity: 100, "
        "acceleration: 1000},\n"
        "     homing: {method: switch, input: 3, velocity: -10}}\n"
        "simulation: {runtime_dir: '" +
        dir_.string() + "', reply_latency_us: 200}\n";
    auto loaded = config::load_string(yaml);
    ASSERT_TRUE(loaded.ok()) << loaded.error_text();
    config_ = *loaded.config;
  }
  void TearDown() override {
    for (const pid_t pid : children_) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
    }
    for (const int fd : pipes_) ::close(fd);
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }

  // Starts /usr/bin/python3 -c `script` args...; its stdout+stderr go to a pipe read by output().
  pid_t python(const std::string& script, const std::vector<std::string>& args) {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) return -1;
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], 1);
    posix_spawn_file_actions_adddup2(&actions, fds[1], 2);
    std::vector<std::string> argv_strings{kPython, "-c", script};
    argv_strings.insert(argv_strings.end(), args.begin(), args.end());
    std::vector<char*> argv;
    argv.reserve(argv_strings.size() + 1);
    for (auto& a : argv_strings) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = -1;
    const int rc = ::posix_spawn(&pid, kPython, &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(fds[1]);
    if (rc != 0) {
      ::close(fds[0]);
      return -1;
    }
    ::fcntl(fds[0], F_SETFL, O_NONBLOCK);
    children_.push_back(pid);
    pipes_.push_back(fds[0]);
    output_fd_ = fds[0];
    return pid;
  }
  std::string drain_output() {
    std::array<char, 4096> buffer{};
    ssize_t n = 0;
    while ((n = ::read(output_fd_, buffer.data(), buffer.size())) > 0)
      output_.append(buffer.data(), static_cast<std::size_t>(n));
    return output_;
  }
  // Pumps the loop until `done()` or the timeout.
  bool pump_until(const std::function<bool()>& done, Duration timeout) {
    const auto end = SteadyClock::now() + timeout;
    while (!done()) {
      if (SteadyClock::now() > end) return false;
      loop_.run_once(5ms);
      drain_output();
    }
    return true;
  }
  bool exited(pid_t pid, int& status) {
    if (::waitpid(pid, &status, WNOHANG) != pid) return false;
    std::erase(children_, pid);
    return true;
  }

  std::filesystem::path dir_;
  config::Config config_;
  EventLoop loop_;
  std::vector<pid_t> children_;
  std::vector<int> pipes_;
  int output_fd_ = -1;
  std::string output_;
};

TEST_F(PtyInterop, SimSlaveAnswersPymodbusClient) {
  if (!pymodbus_available()) GTEST_SKIP() << "/usr/bin/python3 has no pymodbus (apt-get install python3-pymodbus)";
  std::vector<motionlcm::sim_report_t> reports;
  std::error_code error;
  auto host = sim::open_adam_line(
      loop_, config_, config_.buses[0], [&](const motionlcm::sim_report_t& r) { reports.push_back(r); }, error);
  ASSERT_TRUE(host) << error.message();
  EXPECT_EQ(host->link_path(), (dir_ / "rs485.tty").string());
  const std::string script = R"PY(
import sys
from pymodbus.client import ModbusSerialClient
c = ModbusSerialClient(port=sys.argv[1], baudrate=115200, timeout=2)
assert c.connect()
r = c.read_holding_registers(0, 2, slave=1); print("version", r.registers, flush=True)
w = c.write_registers(0x00D0, [0x0FA0, 0x0000], slave=1); print("write", w.address, w.count, flush=True)
r = c.read_holding_registers(0x0014, 1, slave=1); print("hole", r.isError(), getattr(r, "exception_code", None), flush=True)
r = c.read_holding_registers(0x0024, 2, slave=1); print("subdivision", r.registers, flush=True)
c.close()
print("end", flush=True)
)PY";
  const pid_t pid = python(script, {host->link_path()});
  ASSERT_GT(pid, 0);
  int status = 0;
  ASSERT_TRUE(pump_until([&] { return exited(pid, status); }, 30s)) << drain_output();
  drain_output();
  EXPECT_EQ(WEXITSTATUS(status), 0) << output_;
  EXPECT_NE(output_.find("version [14129, 48]"), std::string::npos) << output_;  // 0x3731, 0x0030 (§8.1)
  EXPECT_NE(output_.find("write 208 2"), std::string::npos) << output_;          // FC 0x10 ack of 0x00D0
  EXPECT_NE(output_.find("hole True 2"), std::string::npos) << output_;          // exception 0x02
  EXPECT_NE(output_.find("subdivision [4000, 0]"), std::string::npos) << output_;
  ASSERT_FALSE(reports.empty());
  const auto started = std::find_if(reports.begin(), reports.end(), [](const auto& r) {
    return r.kind == std::int8_t{motionlcm::sim_report_t::MOTION_STARTED};
  });
  ASSERT_NE(started, reports.end()) << "the absolute move written by pymodbus started no motion";
  EXPECT_EQ(started->target_counts, 4000);
  EXPECT_GT(started->frame_utime, 0);
}

TEST_F(PtyInterop, MasterTalksToPymodbusServer) {
  if (!pymodbus_available()) GTEST_SKIP() << "/usr/bin/python3 has no pymodbus (apt-get install python3-pymodbus)";
  // Null modem: the master opens link A, pymodbus opens link B, the test copies between masters.
  std::error_code error;
  const serial::SerialSettings line{};
  auto a = serial::PtyLink::create((dir_ / "master.tty").string(), line, error);
  ASSERT_TRUE(a) << error.message();
  auto b = serial::PtyLink::create((dir_ / "server.tty").string(), line, error);
  ASSERT_TRUE(b) << error.message();
  const auto bridge = [](int from, int to) {
    std::array<std::uint8_t, 512> buffer{};
    ssize_t n = 0;
    while ((n = ::read(from, buffer.data(), buffer.size())) > 0) {
      if (::write(to, buffer.data(), static_cast<std::size_t>(n)) != n) break;
    }
  };
  loop_.watch(a->master_fd(), [&] { bridge(a->master_fd(), b->master_fd()); });
  loop_.watch(b->master_fd(), [&] { bridge(b->master_fd(), a->master_fd()); });

  const std::string script = R"PY(
import sys
from pymodbus.server import StartSerialServer
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusSlaveContext, ModbusServerContext
from pymodbus.transaction import ModbusRtuFramer
block = ModbusSequentialDataBlock(0, [0] * 0x200)
block.setValues(0x24, [4000, 0])
block.setValues(0x06, [0x1000, 0])
ctx = ModbusServerContext(slaves={1: ModbusSlaveContext(hr=block, zero_mode=True)}, single=False)
print("serving", flush=True)
StartSerialServer(context=ctx, framer=ModbusRtuFramer, port=sys.argv[1], baudrate=115200)
)PY";
  ASSERT_GT(python(script, {b->link_path()}), 0);

  Recorder out;
  adam_driver::MasterSettings settings = adam_driver::settings_from_config(config_, config_.buses[0]);
  adam_driver::AdamBusDriver driver(loop_, settings, a->link_path(), line, out);
  driver.start();
  ASSERT_TRUE(pump_until([&] { return driver.ready(); }, 30s)) << "pymodbus server never answered; its output:\n"
                                                               << drain_output();

  motionlcm::gateway_command_t write{};
  write.command_id = 1;
  write.kind = std::int8_t{motionlcm::gateway_command_t::PARAM_WRITE};
  write.axes.push_back(motionlcm::axis_command_t{});
  write.axes[0].axis = "c";
  write.num_axes = 1;
  write.param.space = std::int8_t{motionlcm::param_t::MODBUS_REGISTER};
  write.param.index = 0x00D8;  // target speed, INT32 low word first (§8.64)
  write.param.value = 123456;
  driver.execute(write);
  ASSERT_TRUE(pump_until([&] { return out.terminal(1) != nullptr; }, 5s));
  EXPECT_EQ(out.terminal(1)->status, std::int8_t{Reply::DONE}) << out.terminal(1)->reason;

  motionlcm::gateway_command_t read = write;
  read.command_id = 2;
  read.kind = std::int8_t{motionlcm::gateway_command_t::PARAM_READ};
  read.param.value = 0;
  driver.execute(read);
  ASSERT_TRUE(pump_until([&] { return out.terminal(2) != nullptr; }, 5s));
  ASSERT_EQ(out.terminal(2)->status, std::int8_t{Reply::DONE}) << out.terminal(2)->reason;
  EXPECT_EQ(out.terminal(2)->param.value, 123456);
  // Commands go before queued polls; polling goes on after them.
  EXPECT_TRUE(pump_until([&] { return driver.statistics().at(0).rx_frames > 4; }, 5s))
      << "rx " << driver.statistics().at(0).rx_frames << " tx " << driver.statistics().at(0).tx_frames;
  const auto stats = driver.statistics().at(0);
  EXPECT_EQ(stats.state, "open");
  loop_.unwatch(a->master_fd());
  loop_.unwatch(b->master_fd());
}

TEST_F(PtyInterop, AReplyCrossesTheSimulatedLineAtItsBaudRate) {
  // At 9600 baud a read of 4 registers is 8 request and 13 reply bytes, 10 bits each: the reply
  // cannot be complete before 21 characters' wire time (21.9 ms) after the request was written,
  // however fast the host. Before, the simulated line delayed only the request (8.3 ms).
  config_.buses[0].baud = 9600;
  std::error_code error;
  auto host = sim::open_adam_line(
      loop_, config_, config_.buses[0], [](const motionlcm::sim_report_t&) {}, error);
  ASSERT_TRUE(host) << error.message();
  auto port = serial::SerialPort::open(host->link_path(), serial::line_settings(9600, 'N', 1), error);
  ASSERT_TRUE(port) << error.message();
  const auto request = adam::rtu::encode_request({1, adam::rtu::ReadRegisters{0x0004, 4}});
  ASSERT_TRUE(request.ok());
  const auto written = SteadyClock::now();
  ASSERT_FALSE(port->write(request.value()));
  std::vector<std::uint8_t> reply;
  ASSERT_TRUE(pump_until(
      [&] {
        std::array<std::uint8_t, 64> buffer{};
        const std::size_t n = port->read(buffer, error);
        reply.insert(reply.end(), buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(n));
        return reply.size() >= 13;
      },
      2s));
  const auto took = SteadyClock::now() - written;
  EXPECT_EQ(reply.size(), 13U);
  const auto wire = serial::line_settings(9600, 'N', 1).wire_time(8 + 13);
  EXPECT_GE(took, wire) << "the reply arrived faster than the line carries it";
}

TEST_F(PtyInterop, MasterAndSimulatorMoveEndToEnd) {
  std::vector<motionlcm::sim_report_t> reports;
  std::error_code error;
  auto host = sim::open_adam_line(
      loop_, config_, config_.buses[0], [&](const motionlcm::sim_report_t& r) { reports.push_back(r); }, error);
  ASSERT_TRUE(host) << error.message();
  Recorder out;
  auto driver = adam_driver::AdamBusDriver::create(loop_, config_, config_.buses[0], out);
  driver->start();
  ASSERT_TRUE(pump_until([&] { return driver->ready(); }, 5s));

  motionlcm::gateway_command_t move{};
  move.command_id = 7;
  move.kind = std::int8_t{motionlcm::gateway_command_t::ARM_MOVE};
  move.trigger_id = 0;  // start as soon as armed
  move.axes.push_back(motionlcm::axis_command_t{});
  move.axes[0].axis = "c";
  move.axes[0].target_counts = 2000;
  move.axes[0].velocity = 8000;  // 120 rpm at the default 4000 pulses/rev
  move.axes[0].acceleration = 40000;
  move.axes[0].deceleration = 40000;
  move.num_axes = 1;
  driver->execute(move);
  ASSERT_TRUE(pump_until([&] { return out.terminal(7) != nullptr; }, 10s));
  ASSERT_EQ(out.terminal(7)->status, std::int8_t{Reply::DONE}) << out.terminal(7)->reason;
  const auto started = std::find_if(out.replies.begin(), out.replies.end(),
                                    [](const Reply& r) { return r.status == std::int8_t{Reply::STARTED}; });
  ASSERT_NE(started, out.replies.end());
  EXPECT_EQ(started->start_mechanism, "broadcast");
  const auto report = std::find_if(reports.begin(), reports.end(), [](const auto& r) {
    return r.kind == std::int8_t{motionlcm::sim_report_t::MOTION_STARTED};
  });
  ASSERT_NE(report, reports.end());
  EXPECT_EQ(report->target_counts, 2000);
  // The start frame's end on the master's side and its arrival at the simulator: same frame.
  EXPECT_LT(std::abs(report->frame_utime - started->trigger_utime), 20'000);

  // Homing (the simulated switch is where the drive powered up: position 0).
  motionlcm::gateway_command_t home = move;
  home.command_id = 8;
  home.kind = std::int8_t{motionlcm::gateway_command_t::HOME};
  home.axes[0].target_counts = 0;
  home.axes[0].velocity = -8000;
  driver->execute(home);
  ASSERT_TRUE(pump_until([&] { return out.terminal(8) != nullptr; }, 10s));
  EXPECT_EQ(out.terminal(8)->status, std::int8_t{Reply::DONE}) << out.terminal(8)->reason;

  // A silent drive: the command fails naming the drive, its slave id and the register.
  motionlcm::sim_control_t silence{};
  silence.drive = "c-drive";
  silence.action = std::int8_t{motionlcm::sim_control_t::SILENCE};
  silence.value = 1;
  ASSERT_TRUE(host->control(silence));
  motionlcm::gateway_command_t enable = move;
  enable.command_id = 9;
  enable.kind = std::int8_t{motionlcm::gateway_command_t::ENABLE};
  driver->execute(enable);
  ASSERT_TRUE(pump_until([&] { return out.terminal(9) != nullptr; }, 5s));
  EXPECT_EQ(out.terminal(9)->status, std::int8_t{Reply::FAILED});
  EXPECT_NE(out.terminal(9)->reason.find("c-drive (slave 1)"), std::string::npos) << out.terminal(9)->reason;
  EXPECT_NE(out.terminal(9)->reason.find("0x00D4"), std::string::npos) << out.terminal(9)->reason;
}

}  // namespace
}  // namespace motion
