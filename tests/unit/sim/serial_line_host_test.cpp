// motion-sim's simulated serial line (sim::SerialLineHost) over each kind of link
// (`simulation.serial_link`: a real pseudo-terminal, a Unix socket), opened by the gateway's
// serial::SerialPort, with a device that records what reached it and when: what the host adds to
// its devices (dating, wire time, order), whatever the family and the link.
#include "motion/sim/serial_line_host.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "motion/serial/serial_port.hpp"
#include "motion/serial/socket_link.hpp"
#include "motion/testing/pump.hpp"
#include "motion/testing/temp_dir.hpp"

namespace motion::sim {
namespace {

using std::chrono::milliseconds;

// A socket line's send stamp is wall-clock time, put on the steady clock by reading both: the
// two reads are this far apart at most, either way.
constexpr Duration kClocksApart = std::chrono::microseconds(20);

struct Received {
  TimePoint arrival;
  std::vector<std::uint8_t> bytes;
};

class RecordingDevice final : public SerialDeviceSim {
 public:
  RecordingDevice(std::vector<Received>& got, bool full_duplex, SerialDeviceContext context)
      : got_(got), full_duplex_(full_duplex), context_(std::move(context)) {}
  // Bytes onto the line now (a reply, a notification).
  void say(const std::vector<std::uint8_t>& bytes) { context_.send(bytes, Duration::zero()); }
  // What it answers to whatever reaches it next (a drive's reply to the gateway's request).
  void answer_with(std::vector<std::uint8_t> bytes) { answer_ = std::move(bytes); }
  [[nodiscard]] bool full_duplex() const override { return full_duplex_; }
  void power_up(TimePoint /*now*/) override {}
  TimePoint receive(std::span<const std::uint8_t> bytes, TimePoint now) override {
    got_.push_back({now, {bytes.begin(), bytes.end()}});
    if (!answer_.empty()) say(answer_);
    answer_.clear();
    return kNever;
  }
  TimePoint process(TimePoint /*now*/) override { return kNever; }
  bool control(const motionlcm::sim_control_t& /*control*/, TimePoint /*now*/) override { return false; }

 private:
  std::vector<Received>& got_;
  bool full_duplex_;
  SerialDeviceContext context_;
  std::vector<std::uint8_t> answer_;
};

using SerialLink = config::SimulationSettings::SerialLink;

class SerialLineHostTest : public ::testing::TestWithParam<SerialLink> {
 protected:
  void SetUp() override { open_line(false); }
  [[nodiscard]] bool socket() const { return GetParam() == SerialLink::kSocket; }
  void open_line(bool full_duplex) {
    port_.reset();
    host_.reset();
    const std::string yaml =
        "buses:\n"
        "  - {name: rs485, transport: 'simserial:rs485', baud: 115200, parity: none}\n"
        "drives:\n"
        "  - {name: c-drive, family: adam-modbus, bus: rs485, node_id: 1}\n"
        "axes:\n"
        "  - {name: c, drive: c-drive, unit: mm, steps_per_unit: 640, limits: {min: -100, max: 100, velocity: 30, "
        "acceleration: 150}}\n"
        "simulation: {serial_link: " +
        std::string(socket() ? "socket" : "pty") + ", runtime_dir: '" + dir_.path().string() + "'}\n";
    auto loaded = config::load_string(yaml);
    ASSERT_TRUE(loaded.ok()) << loaded.error_text();
    config_ = *loaded.config;
    std::error_code error;
    const SerialDeviceFactory factory = [this, full_duplex](const config::Config&, const config::Bus&,
                                                            SerialDeviceContext context) {
      auto device = std::make_unique<RecordingDevice>(got_, full_duplex, std::move(context));
      device_ = device.get();
      return device;
    };
    host_ = SerialLineHost::open(loop_, config_, config_.buses[0], {{config::Family::kAdamModbus, factory}}, {}, error);
    ASSERT_TRUE(host_) << error.message();
    port_ = open_port(error);
    ASSERT_TRUE(port_) << host_->link_path() << ": " << error.message();
    ASSERT_EQ(port_->is_socket(), socket());
  }
  // The line opened as the gateway opens it.
  std::unique_ptr<serial::SerialPort> open_port(std::error_code& error) {
    return serial::SerialPort::open(host_->link_path(), line(), error);
  }
  void TearDown() override {
    port_.reset();
    host_.reset();
  }
  [[nodiscard]] serial::SerialSettings line() const {
    return serial::line_settings(config_.buses[0].baud, config_.buses[0].parity, config_.buses[0].stop_bits);
  }
  void write(const std::vector<std::uint8_t>& bytes) { ASSERT_FALSE(port_->write(bytes)); }
  // What `port` reads within 2 s (the loop runs meanwhile), until it has `count` bytes.
  std::vector<std::uint8_t> read_from(serial::SerialPort& port, std::size_t count) {
    std::vector<std::uint8_t> bytes;
    (void)testing::pump_until(
        loop_,
        [&] {
          std::array<std::uint8_t, 10> buffer{};  // shorter than a message: the port keeps the rest
          std::error_code error;
          for (std::size_t n = port.read(buffer, error); n > 0 && !error; n = port.read(buffer, error))
            bytes.insert(bytes.end(), buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(n));
          return bytes.size() >= count;
        },
        milliseconds(2000));
    return bytes;
  }
  // Runs the loop until the device has `count` bytes (or 2 s have passed): every byte it got.
  std::vector<std::uint8_t> received(std::size_t count) {
    std::vector<std::uint8_t> bytes;
    (void)testing::pump_until(
        loop_,
        [&] {
          bytes.clear();
          for (const auto& r : got_) bytes.insert(bytes.end(), r.bytes.begin(), r.bytes.end());
          return bytes.size() >= count;
        },
        milliseconds(2000));
    return bytes;
  }
  [[nodiscard]] Duration wire_time(std::size_t bytes) const { return line().wire_time(bytes); }

  testing::TempDir dir_{"serial-line-host"};
  EventLoop loop_;
  config::Config config_;
  std::vector<Received> got_;
  std::unique_ptr<SerialLineHost> host_;
  RecordingDevice* device_ = nullptr;  // host_'s
  std::unique_ptr<serial::SerialPort> port_;
};

// What the gateway writes reaches the device one wire time after it was written, though
// motion-sim's loop was busy meanwhile (with the CAN buses it also serves): the frame's time is
// the ground truth of a serial drive's start (SIM_REPORT). Dated by the loop's read, a write made
// while the loop was busy for 100 ms arrived 100 ms late.
TEST_P(SerialLineHostTest, AWriteArrivesOneWireTimeAfterItWasWrittenThoughTheLoopWasBusy) {
  const std::vector<std::uint8_t> frame{0x01, 0x06, 0x00, 0x10, 0x00, 0x01, 0x49, 0xCF};
  const TimePoint written = loop_.now();
  write(frame);
  std::this_thread::sleep_for(milliseconds(100));  // the loop is busy elsewhere
  EXPECT_EQ(received(frame.size()), frame);
  ASSERT_FALSE(got_.empty());
  const Duration late = got_.back().arrival - written - wire_time(frame.size());
  EXPECT_GE(late, -kClocksApart) << "before its wire time";
  EXPECT_LT(late, milliseconds(50)) << "dated by the busy loop's read";
}

// Reads keep their order, and the device's time never goes back, however the reads were dated.
TEST_P(SerialLineHostTest, WritesArriveInOrderAndTheDevicesTimeNeverGoesBack) {
  std::vector<std::uint8_t> all;
  for (std::uint8_t i = 0; i < 20; ++i) {
    const std::vector<std::uint8_t> piece{i, static_cast<std::uint8_t>(i + 100)};
    write(piece);
    all.insert(all.end(), piece.begin(), piece.end());
    if (i % 5 == 0) std::this_thread::sleep_for(milliseconds(3));
    if (i % 3 == 0) loop_.run_once(milliseconds(1));
  }
  EXPECT_EQ(received(all.size()), all);
  for (std::size_t i = 1; i < got_.size(); ++i) EXPECT_GE(got_[i].arrival, got_[i - 1].arrival) << "read " << i;
}

// While the device sends (a reply, a notification), what the gateway writes crosses a
// full-duplex line (RS232) at once, and on a half-duplex one (RS485) only after the device's
// bytes: one pair of wires carries one direction at a time.
TEST_P(SerialLineHostTest, AWriteWaitsForTheDevicesBytesOnAHalfDuplexLineOnly) {
  const std::vector<std::uint8_t> notification(1000, 0x55);  // 87 ms at 115200 baud
  const std::vector<std::uint8_t> frame{0x01, 0x06, 0x00, 0x10, 0x00, 0x01, 0x49, 0xCF};
  for (const bool full_duplex : {true, false}) {
    SCOPED_TRACE(full_duplex ? "full duplex" : "half duplex");
    open_line(full_duplex);
    ASSERT_NE(device_, nullptr);
    got_.clear();
    device_->answer_with(notification);  // the device's answer to a one-byte request
    write({0x00});
    ASSERT_EQ(received(1).size(), 1U);
    const TimePoint said = got_.back().arrival;  // it begins when the request has arrived
    got_.clear();
    const TimePoint written = loop_.now();
    write(frame);
    EXPECT_EQ(received(frame.size()), frame);
    ASSERT_FALSE(got_.empty());
    if (full_duplex) {
      const Duration late = got_.back().arrival - written - wire_time(frame.size());
      EXPECT_GE(late, -kClocksApart) << "before its wire time";
      EXPECT_LT(late, wire_time(notification.size()) / 2) << "waited for the device's bytes";
    } else {
      EXPECT_GE(got_.back().arrival - said, wire_time(notification.size()) + wire_time(frame.size()))
          << "crossed the line while the device's bytes were on it";
    }
  }
}

// A device's answer crosses the line from the arrival of the request it answers, though
// motion-sim's loop got to it late: on a half-duplex line the gateway's next frame, written after
// the answer's end, then crosses at once. Dated by the late loop, the answer still held the line
// when that frame came, which reached its drives a whole stall late.
TEST_P(SerialLineHostTest, AnAnswerIsDatedFromItsRequestThoughTheLoopGotToItLate) {
  const std::vector<std::uint8_t> answer(500, 0x33);  // 43 ms at 115200 baud
  device_->answer_with(answer);
  const TimePoint written = loop_.now();
  write({0x01, 0x03});
  std::this_thread::sleep_for(milliseconds(100));  // the loop is busy elsewhere
  EXPECT_EQ(received(2), (std::vector<std::uint8_t>{0x01, 0x03}));
  got_.clear();
  // The answer ended on the line about 43 ms after the request; the loop ran only at 100 ms.
  const std::vector<std::uint8_t> frame{0x01, 0x06, 0x00, 0x10, 0x00, 0x01, 0x49, 0xCF};
  const TimePoint second = loop_.now();
  write(frame);
  EXPECT_EQ(received(frame.size()), frame);
  ASSERT_FALSE(got_.empty());
  EXPECT_GE(second - written, milliseconds(100));
  EXPECT_LT(got_.back().arrival - second, wire_time(frame.size()) + milliseconds(30))
      << "waited behind an answer dated by the late loop";
}

// What any port that has the line open writes reaches the device, and what the device says comes
// back whole and in order, however short the reader's buffer (a socket line sends it in messages
// of at most kSimLinkMessage bytes). On a socket every port hears it; a pty has one input queue
// for all who opened its slave, so each byte goes to whichever reads first, as on a real tty.
TEST_P(SerialLineHostTest, EveryPortReachesTheDeviceAndItsAnswerComesBackWhole) {
  std::error_code error;
  auto second = open_port(error);
  ASSERT_TRUE(second) << error.message();
  std::vector<std::uint8_t> reply(600);
  for (std::size_t i = 0; i < reply.size(); ++i) reply[i] = static_cast<std::uint8_t>(i * 7);
  ASSERT_FALSE(second->write(std::vector<std::uint8_t>{0x02}));
  EXPECT_EQ(received(1), (std::vector<std::uint8_t>{0x02})) << "the second port is on the line";
  device_->answer_with(reply);
  write({0x01});
  EXPECT_EQ(received(2), (std::vector<std::uint8_t>{0x02, 0x01}));
  EXPECT_EQ(read_from(*port_, reply.size()), reply);
  if (socket()) { EXPECT_EQ(read_from(*second, reply.size()), reply); }
}

// When motion-sim closes the line (it stops, or restarts), the gateway's port reads an error (a
// hang-up), so the gateway closes it and opens the new line; nothing reads as silence for ever.
TEST_P(SerialLineHostTest, APortWhoseLineMotionSimClosedReadsAnError) {
  const std::string path = host_->link_path();
  host_.reset();
  std::array<std::uint8_t, 16> buffer{};
  std::error_code error;
  EXPECT_EQ(port_->read(buffer, error), 0U);
  EXPECT_TRUE(error) << "a hang-up (pty, socket) or a reset (a socket never accepted)";
  EXPECT_FALSE(serial::SerialPort::open(path, line(), error)) << "the line's end is gone";
}

// The gateway refuses on a socket line exactly what it refuses on a tty: a baud rate without a
// termios constant, a stop-bit count other than 1 or 2; and the parity is counted, never set.
TEST_P(SerialLineHostTest, ThePortRefusesTheSameSettingsOnEitherLink) {
  std::error_code error;
  serial::SerialSettings odd_baud = line();
  odd_baud.baud = 14400;
  EXPECT_FALSE(serial::SerialPort::open(host_->link_path(), odd_baud, error));
  EXPECT_EQ(error, std::errc::invalid_argument);
  serial::SerialSettings three_stops = line();
  three_stops.stop_bits = 3;
  EXPECT_FALSE(serial::SerialPort::open(host_->link_path(), three_stops, error));
  EXPECT_EQ(error, std::errc::invalid_argument);
  serial::SerialSettings even = line();
  even.parity = serial::Parity::kEven;
  auto port = serial::SerialPort::open(host_->link_path(), even, error);
  ASSERT_TRUE(port) << error.message();
  EXPECT_EQ(port->settings().bits_per_character(), 11);
}

INSTANTIATE_TEST_SUITE_P(Links, SerialLineHostTest, ::testing::Values(SerialLink::kPty, SerialLink::kSocket),
                         [](const auto& link) { return link.param == SerialLink::kSocket ? "Socket" : "Pty"; });

// The socket's end of a line: made private (0600) before anyone can connect; a second simulator
// cannot take a live line's path; a file a dead one left, or an earlier run's pty link, is
// replaced; the file goes when the line does, unless someone else's socket replaced it.
TEST(SocketLinkTest, IsPrivateRefusesASecondSimulatorAndReplacesWhatADeadRunLeft) {
  testing::TempDir dir{"socket-link"};
  const std::string path = (dir.path() / "rs485.tty").string();
  std::filesystem::create_symlink("/dev/null", path);  // an earlier run's pty link
  std::error_code error;
  auto link = serial::SocketLink::create(path, error);
  ASSERT_TRUE(link) << error.message();
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 0777, 0600U);
  EXPECT_FALSE(serial::SocketLink::create(path, error)) << "a second simulator on a live line";
  EXPECT_EQ(error, std::errc::address_in_use);
  link.reset();
  EXPECT_FALSE(std::filesystem::exists(path));
  link = serial::SocketLink::create(path, error);
  ASSERT_TRUE(link) << error.message();
  auto port = serial::SerialPort::open(path, serial::SerialSettings{}, error);
  ASSERT_TRUE(port) << error.message();
  std::int64_t sent_wall_ns = 0;
  std::array<std::uint8_t, 16> buffer{};
  EXPECT_EQ(link->read(buffer, sent_wall_ns), 0U) << "the connection is accepted, nothing was sent";
  EXPECT_EQ(link->connections(), 1U);
  const auto before = std::chrono::system_clock::now();
  ASSERT_FALSE(port->write(std::vector<std::uint8_t>{0x11, 0x22}));
  ASSERT_EQ(link->read(buffer, sent_wall_ns), 2U);
  EXPECT_GE(sent_wall_ns, std::chrono::duration_cast<std::chrono::nanoseconds>(before.time_since_epoch()).count())
      << "stamped by the kernel at the send";
  port.reset();
  EXPECT_EQ(link->read(buffer, sent_wall_ns), 0U);
  EXPECT_EQ(link->connections(), 0U) << "a closed connection is dropped";
}

}  // namespace
}  // namespace motion::sim
