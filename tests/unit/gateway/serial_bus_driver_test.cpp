// gateway::SerialBusDriver, the serial poll-loop shell of AdamBusDriver and Uim242BusDriver, over a
// real pseudo-terminal (serial::PtyLink) with a scripted core: the port is retried until it
// exists (one event per cause), bytes go both ways, the core's deadline drives ONE timer, and a
// hang-up reaches the core as line_lost() before the port is reopened and the core started again.
#include "motion/gateway/serial_bus_driver.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <filesystem>
#include <functional>
#include <string>

#include <motionlcm/event_t.hpp>

#include "motion/gateway/serial_line.hpp"
#include "motion/serial/pty_link.hpp"
#include "motion/testing/pump.hpp"

namespace motion::gateway {
namespace {

using std::chrono::milliseconds;

class ScriptedCore final : public SerialStack {
 public:
  explicit ScriptedCore(SerialBusDriver::Write write) : write_(std::move(write)) {}
  void start(TimePoint) override { ++starts; }
  void on_bytes(std::span<const std::uint8_t> bytes, TimePoint) override {
    received.append(bytes.begin(), bytes.end());
  }
  TimePoint process(TimePoint now) override {
    ++process_calls;
    if (wake_at && now >= *wake_at) {
      woke_at = now;
      wake_at.reset();
    }
    return wake_at.value_or(kNever);
  }
  void execute(const motionlcm::gateway_command_t& c, TimePoint) override { commands.push_back(c.command_id); }
  void fire(std::int64_t id, TimePoint) override { fired.push_back(id); }
  void line_lost(const std::string& why, TimePoint) override { lost.push_back(why); }
  [[nodiscard]] motionlcm::bus_stats_t statistics() const override {
    motionlcm::bus_stats_t s{};
    s.name = "rs232";
    s.state = "open";
    return s;
  }
  [[nodiscard]] bool ready() const override { return true; }
  bool write(const std::string& text) {
    return write_(std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
  }

  int starts = 0;
  int process_calls = 0;
  std::string received;
  std::optional<TimePoint> wake_at;
  std::optional<TimePoint> woke_at;
  std::vector<std::int64_t> commands;
  std::vector<std::int64_t> fired;
  std::vector<std::string> lost;

 private:
  SerialBusDriver::Write write_;
};

struct Recorder : GatewayOutput {
  void axis_status(const std::string&, const DriveStatus&) override {}
  void axis_event(const std::string& axis, const DriveEvent& e) override { events.emplace_back(axis, e); }
  void command_reply(motionlcm::gateway_reply_t r) override { replies.push_back(r); }
  std::vector<std::pair<std::string, DriveEvent>> events;
  std::vector<motionlcm::gateway_reply_t> replies;
};

class SerialBusDriverTest : public ::testing::Test {
 protected:
  SerialBusDriverTest() {
    dir_ = std::filesystem::temp_directory_path() / ("serial-bus-driver-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    path_ = (dir_ / "rs232.tty").string();
    driver_ = std::make_unique<SerialBusDriver>(loop_, "rs232", path_, line_, out_, [this](SerialBusDriver::Write w) {
      auto core = std::make_unique<ScriptedCore>(std::move(w));
      core_ = core.get();
      return core;
    });
    driver_->reopen_period = milliseconds(20);
  }
  ~SerialBusDriverTest() override {
    driver_.reset();
    link_.reset();
    std::filesystem::remove_all(dir_);
  }
  void make_link() {
    std::error_code error;
    link_ = serial::PtyLink::create(path_, line_, error);
    ASSERT_TRUE(link_) << error.message();
  }
  bool run_until(const std::function<bool()>& done, milliseconds limit = milliseconds(2000)) {
    return testing::pump_until(loop_, done, limit);
  }
  std::string read_master() {
    std::array<char, 256> buffer{};
    std::string out;
    for (;;) {
      const ssize_t n = ::read(link_->master_fd(), buffer.data(), buffer.size());
      if (n <= 0) return out;
      out.append(buffer.data(), static_cast<std::size_t>(n));
    }
  }

  EventLoop loop_;
  Recorder out_;
  serial::SerialSettings line_{57600, serial::Parity::kNone, 8, 1};
  std::filesystem::path dir_;
  std::string path_;
  std::unique_ptr<serial::PtyLink> link_;
  std::unique_ptr<SerialBusDriver> driver_;
  ScriptedCore* core_ = nullptr;
};

// Whoever can open a simulated line's pty can write to the line: its device is its owner's alone
// (openpty leaves it 0620, group tty), or also one configured group's (0660).
TEST_F(SerialBusDriverTest, PtyDeviceIsItsOwnersAloneOrAlsoTheConfiguredGroups) {
  make_link();
  struct stat st {};
  ASSERT_EQ(::stat(link_->slave_path().c_str(), &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  EXPECT_EQ(st.st_mode & 07777, 0600U) << link_->slave_path();
  std::error_code error;
  auto grouped = serial::PtyLink::create(path_ + ".grouped", line_, error, FileAccess{::getgid()});
  ASSERT_TRUE(grouped) << error.message();
  ASSERT_EQ(::stat(grouped->slave_path().c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0660U);
  EXPECT_EQ(st.st_gid, ::getgid());
}

TEST_F(SerialBusDriverTest, RetriesUntilThePortExistsWithOneEventPerCause) {
  driver_->start();
  EXPECT_FALSE(driver_->port_open());
  EXPECT_FALSE(driver_->ready());
  // The bus state says why it is closed (the gateway's heartbeat, `motionctl health`).
  EXPECT_EQ(driver_->statistics().at(0).state, "closed: cannot open " + path_ + ": No such file or directory");
  run_until([] { return false; }, milliseconds(100));  // several retries
  ASSERT_EQ(out_.events.size(), 1u);
  EXPECT_EQ(out_.events[0].first, "");
  EXPECT_EQ(out_.events[0].second.kind, std::int16_t{motionlcm::event_t::OFFLINE});
  EXPECT_NE(out_.events[0].second.text.find("cannot open " + path_ + " for bus rs232"), std::string::npos)
      << out_.events[0].second.text;
  EXPECT_EQ(core_->starts, 0);

  make_link();
  ASSERT_TRUE(run_until([&] { return driver_->port_open(); }));
  EXPECT_EQ(core_->starts, 1);
  EXPECT_TRUE(driver_->ready());
  EXPECT_EQ(driver_->statistics().at(0).state, "open");
}

TEST_F(SerialBusDriverTest, BytesBothWaysAndTheCoreDeadlineDrivesOneTimer) {
  make_link();
  driver_->start();
  ASSERT_TRUE(driver_->port_open());
  ASSERT_TRUE(core_->write("ADR 6;"));
  run_until([] { return false; }, milliseconds(20));
  EXPECT_EQ(read_master(), "ADR 6;");

  const std::string reply = "\xAA\x06\xD0\xFF";
  ASSERT_EQ(::write(link_->master_fd(), reply.data(), reply.size()), static_cast<ssize_t>(reply.size()));
  ASSERT_TRUE(run_until([&] { return core_->received.size() == reply.size(); }));
  EXPECT_EQ(core_->received, reply);

  // A deadline set by a command is armed at once (process() after execute) and met, not early.
  core_->wake_at = loop_.now() + milliseconds(30);
  const TimePoint due = *core_->wake_at;
  motionlcm::gateway_command_t command{};
  command.command_id = 41;
  driver_->execute(command);
  driver_->fire(7);
  EXPECT_EQ(core_->commands, std::vector<std::int64_t>{41});
  EXPECT_EQ(core_->fired, std::vector<std::int64_t>{7});
  ASSERT_TRUE(run_until([&] { return core_->woke_at.has_value(); }));
  EXPECT_GE(*core_->woke_at, due);
  // Nothing pending: the loop idles (no timer left, no busy wait).
  const int calls = core_->process_calls;
  run_until([] { return false; }, milliseconds(50));
  EXPECT_EQ(core_->process_calls, calls);
}

TEST_F(SerialBusDriverTest, HangUpIsALostLineThenTheCoreStartsAgain) {
  make_link();
  driver_->start();
  ASSERT_TRUE(driver_->port_open());
  link_.reset();  // motion-sim went away: the slave side reads EIO
  ASSERT_TRUE(run_until([&] { return !core_->lost.empty(); }));
  EXPECT_FALSE(driver_->port_open());
  EXPECT_FALSE(core_->write("FBK;")) << "a write while the port is closed is refused";
  EXPECT_EQ(driver_->statistics().at(0).state.rfind("closed: " + path_ + " lost: ", 0), 0u)
      << driver_->statistics().at(0).state;

  make_link();
  ASSERT_TRUE(run_until([&] { return driver_->port_open(); }));
  EXPECT_EQ(core_->starts, 2);
  EXPECT_EQ(core_->lost.size(), 1u);
}

// Even and odd parity (the Modbus RTU default is even) on a simulated line: a pty may refuse
// PARENB (tcsetattr EINVAL), so both ends open it with the parity modelled, counted in the
// character time (1 start + 8 data + parity + stop = 11 bits at 8E1), and bytes still pass.
TEST_F(SerialBusDriverTest, EvenAndOddParityOpenOnAPtyWithTheParityBitCounted) {
  for (const auto parity : {serial::Parity::kEven, serial::Parity::kOdd}) {
    SCOPED_TRACE(parity == serial::Parity::kEven ? "even" : "odd");
    const serial::SerialSettings line{19200, parity, 8, 1};
    EXPECT_EQ(line.bits_per_character(), 11);
    EXPECT_EQ(line.wire_time(192), milliseconds(110));  // 192 x 11 bits at 19200 bit/s
    std::error_code error;
    auto link = serial::PtyLink::create(path_, line, error);
    ASSERT_TRUE(link) << error.message();
    SerialBusDriver driver(loop_, "rs485", path_, line, out_, [this](SerialBusDriver::Write w) {
      auto core = std::make_unique<ScriptedCore>(std::move(w));
      core_ = core.get();
      return core;
    });
    driver.start();
    ASSERT_TRUE(driver.port_open()) << driver.statistics().at(0).state;
    EXPECT_EQ(driver.statistics().at(0).state, "open");
    ASSERT_TRUE(core_->write("\x01\x03"));
    std::array<char, 16> buffer{};
    ASSERT_TRUE(run_until([&] { return ::read(link->master_fd(), buffer.data(), buffer.size()) == 2; }));
    EXPECT_EQ(std::string(buffer.data(), 2), "\x01\x03");
  }
}

// A configured serial bus in motion::serial's values: the line as configured, the device of
// serial: and uimessage:, motion-sim's link of simserial:, nothing for a CAN bus.
TEST(SerialLine, ConfiguredBusAsSerialValues) {
  config::Config config;
  config.simulation.runtime_dir = "/tmp/lab-sim";
  config::Bus bus;
  bus.name = "rs485";
  bus.baud = 19200;
  bus.parity = 'E';
  bus.stop_bits = 2;
  const serial::SerialSettings line = serial_line_settings(bus);
  EXPECT_EQ(line.baud, 19200);
  EXPECT_EQ(line.parity, serial::Parity::kEven);
  EXPECT_EQ(line.data_bits, 8);
  EXPECT_EQ(line.stop_bits, 2);
  EXPECT_EQ(line.bits_per_character(), 12);
  bus.parity = 'O';
  EXPECT_EQ(serial_line_settings(bus).parity, serial::Parity::kOdd);
  bus.parity = 'N';
  EXPECT_EQ(serial_line_settings(bus).parity, serial::Parity::kNone);

  bus.kind = config::TransportKind::kSimSerial;
  EXPECT_EQ(serial_device_path(config, bus), "/tmp/lab-sim/rs485.tty");
  bus.kind = config::TransportKind::kSerial;
  bus.target = "/dev/ttyUSB0";
  EXPECT_EQ(serial_device_path(config, bus), "/dev/ttyUSB0");
  bus.kind = config::TransportKind::kUiMessage;
  EXPECT_EQ(serial_device_path(config, bus), "/dev/ttyUSB0");
  bus.kind = config::TransportKind::kSimCan;
  EXPECT_EQ(serial_device_path(config, bus), "");
}

}  // namespace
}  // namespace motion::gateway
