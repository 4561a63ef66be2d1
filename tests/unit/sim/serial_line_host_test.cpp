// motion-sim's simulated serial line (sim::SerialLineHost) over a real pseudo-terminal, with a
// device that records what reached it and when: what the host adds to its devices (dating, wire
// time, order), whatever the family.
#include "motion/sim/serial_line_host.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "motion/serial/serial_port.hpp"
#include "motion/testing/pump.hpp"
#include "motion/testing/temp_dir.hpp"

namespace motion::sim {
namespace {

using std::chrono::milliseconds;

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
  [[nodiscard]] bool full_duplex() const override { return full_duplex_; }
  void power_up(TimePoint /*now*/) override {}
  TimePoint receive(std::span<const std::uint8_t> bytes, TimePoint now) override {
    got_.push_back({now, {bytes.begin(), bytes.end()}});
    return kNever;
  }
  TimePoint process(TimePoint /*now*/) override { return kNever; }
  bool control(const motionlcm::sim_control_t& /*control*/, TimePoint /*now*/) override { return false; }

 private:
  std::vector<Received>& got_;
  bool full_duplex_;
  SerialDeviceContext context_;
};

class SerialLineHostTest : public ::testing::Test {
 protected:
  void SetUp() override { open_line(false); }
  void open_line(bool full_duplex) {
    if (port_ >= 0) ::close(port_);
    port_ = -1;
    host_.reset();
    const std::string yaml =
        "buses:\n"
        "  - {name: rs485, transport: 'simserial:rs485', baud: 115200, parity: none}\n"
        "drives:\n"
        "  - {name: c-drive, family: adam-modbus, bus: rs485, node_id: 1}\n"
        "axes:\n"
        "  - {name: c, drive: c-drive, unit: mm, steps_per_unit: 640, limits: {min: -100, max: 100, velocity: 30, "
        "acceleration: 150}}\n"
        "simulation: {runtime_dir: '" +
        dir_.path().string() + "'}\n";
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
    port_ = ::open(host_->link_path().c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
    ASSERT_GE(port_, 0) << host_->link_path();
    termios tio{};  // binary, as the gateway's port (no CR/LF translation)
    ASSERT_EQ(::tcgetattr(port_, &tio), 0);
    ::cfmakeraw(&tio);
    ASSERT_EQ(::tcsetattr(port_, TCSANOW, &tio), 0);
  }
  void TearDown() override {
    if (port_ >= 0) ::close(port_);
    host_.reset();
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
  [[nodiscard]] Duration wire_time(std::size_t bytes) const {
    return serial::line_settings(config_.buses[0].baud, config_.buses[0].parity, config_.buses[0].stop_bits)
        .wire_time(bytes);
  }

  testing::TempDir dir_{"serial-line-host"};
  EventLoop loop_;
  config::Config config_;
  std::vector<Received> got_;
  std::unique_ptr<SerialLineHost> host_;
  RecordingDevice* device_ = nullptr;  // host_'s
  int port_ = -1;
};

// What the gateway writes reaches the device one wire time after it was written, though
// motion-sim's loop was busy meanwhile (with the CAN buses it also serves): the frame's time is
// the ground truth of a serial drive's start (SIM_REPORT). Dated by the loop's read, a write made
// while the loop was busy for 100 ms arrived 100 ms late.
TEST_F(SerialLineHostTest, AWriteArrivesOneWireTimeAfterItWasWrittenThoughTheLoopWasBusy) {
  const std::vector<std::uint8_t> frame{0x01, 0x06, 0x00, 0x10, 0x00, 0x01, 0x49, 0xCF};
  const TimePoint written = loop_.now();
  ASSERT_EQ(::write(port_, frame.data(), frame.size()), static_cast<ssize_t>(frame.size()));
  std::this_thread::sleep_for(milliseconds(100));  // the loop is busy elsewhere
  EXPECT_EQ(received(frame.size()), frame);
  ASSERT_FALSE(got_.empty());
  const Duration late = got_.back().arrival - written - wire_time(frame.size());
  EXPECT_GE(late, Duration::zero()) << "before its wire time";
  EXPECT_LT(late, milliseconds(50)) << "dated by the busy loop's read";
}

// Reads keep their order, and the device's time never goes back, however the reads were dated.
TEST_F(SerialLineHostTest, WritesArriveInOrderAndTheDevicesTimeNeverGoesBack) {
  std::vector<std::uint8_t> all;
  for (std::uint8_t i = 0; i < 20; ++i) {
    const std::vector<std::uint8_t> piece{i, static_cast<std::uint8_t>(i + 100)};
    ASSERT_EQ(::write(port_, piece.data(), piece.size()), 2);
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
TEST_F(SerialLineHostTest, AWriteWaitsForTheDevicesBytesOnAHalfDuplexLineOnly) {
  const std::vector<std::uint8_t> notification(1000, 0x55);  // 87 ms at 115200 baud
  const std::vector<std::uint8_t> frame{0x01, 0x06, 0x00, 0x10, 0x00, 0x01, 0x49, 0xCF};
  for (const bool full_duplex : {true, false}) {
    SCOPED_TRACE(full_duplex ? "full duplex" : "half duplex");
    open_line(full_duplex);
    ASSERT_NE(device_, nullptr);
    got_.clear();
    const TimePoint said = loop_.now();
    device_->say(notification);
    const TimePoint written = loop_.now();
    ASSERT_EQ(::write(port_, frame.data(), frame.size()), static_cast<ssize_t>(frame.size()));
    EXPECT_EQ(received(frame.size()), frame);
    ASSERT_FALSE(got_.empty());
    if (full_duplex) {
      const Duration late = got_.back().arrival - written - wire_time(frame.size());
      EXPECT_GE(late, Duration::zero()) << "before its wire time";
      EXPECT_LT(late, wire_time(notification.size()) / 2) << "waited for the device's bytes";
    } else {
      EXPECT_GE(got_.back().arrival - said, wire_time(notification.size()) + wire_time(frame.size()))
          << "crossed the line while the device's bytes were on it";
    }
  }
}

}  // namespace
}  // namespace motion::sim
