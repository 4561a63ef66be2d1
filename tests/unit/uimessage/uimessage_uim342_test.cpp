// End to end through a serial gateway: the gateway's UIM342 stack (Uim342Stack) opens its
// uimessage: bus with the transport factory, and the other end of the pty plays the UIROBOT
// UIM2533: it parses the host's UIMessages, hands them as CAN frames to the simulated UIM342
// drive (sim::Uim342Drive, passive) and writes the drive's frames back as UIMessages.
// Time is explicit (stack and drive get the same `now`); the pty only carries the bytes, and every
// wait is for a known number of bytes or frames, so the run is deterministic.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>

#include "motion/gateway/can_transport_factory.hpp"
#include "motion/sim/uim342_drive.hpp"
#include "motion/uim342/message.hpp"
#include "motion/uim342/uimessage_stream.hpp"
#include "motion/uim342_driver/uim342_stack.hpp"
#include "motion/uimessage/uimessage_transport.hpp"
#include "pty_peer.hpp"

namespace motion::uimessage {
namespace {

using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using std::chrono::milliseconds;
using std::chrono::seconds;

constexpr std::int64_t kEpochUs = 1'700'000'000'000'000;
// Copies of LCM constants (never ODR-use the generated in-class constants).
constexpr std::int8_t kDone = gateway_reply_t::DONE;
constexpr std::int8_t kFailed = gateway_reply_t::FAILED;

class RecordingOutput final : public gateway::GatewayOutput {
 public:
  void axis_status(const std::string& axis, const gateway::DriveStatus& status) override {
    statuses.emplace_back(axis, status);
  }
  void axis_event(const std::string& axis, const gateway::DriveEvent& event) override {
    events.emplace_back(axis, event);
  }
  void command_reply(gateway_reply_t reply) override { replies.push_back(std::move(reply)); }

  std::vector<std::pair<std::string, gateway::DriveStatus>> statuses;
  std::vector<std::pair<std::string, gateway::DriveEvent>> events;
  std::vector<gateway_reply_t> replies;
};

// The UIM2533's side of the cable, bridging to one simulated drive.
class GatewayPeer {
 public:
  GatewayPeer(std::string link, uim342::CrcCoverage crc)
      : pty_(std::move(link)),
        crc_(crc),
        from_host_(crc == uim342::CrcCoverage::kStartToAux ? uim342::CrcAcceptance::kStartToAux
                                                           : uim342::CrcAcceptance::kIdToAux) {}

  [[nodiscard]] const std::string& link() const { return pty_.link(); }
  void attach(sim::Uim342Drive& drive) { drive_ = &drive; }
  // What the drive sends (its SimDriveContext::send).
  void drive_sent(const can::Frame& frame) { outbox_.push_back(frame); }

  // Reads the `count` UIMessages the host wrote and hands them to the drive. True if any.
  bool deliver_to_drive(std::uint64_t count, TimePoint now, std::int64_t utime) {
    if (count == 0) return false;
    from_host_.feed(pty_.read(count * uim342::kUiMessageSize));
    while (const auto decoded = from_host_.next()) {
      auto frame = uim342::encode_can(uim342::instruction_from_ui(decoded->message));
      EXPECT_TRUE(frame.ok()) << frame.error().message();
      if (!frame) continue;
      can::Frame f = *frame;
      f.timestamp_us = utime;
      drive_->on_frame(f, now);
    }
    return true;
  }
  // Writes what the drive sent as UIMessages; returns how many.
  std::uint64_t deliver_to_host() {
    const auto frames = std::exchange(outbox_, {});
    for (const auto& frame : frames) {
      const auto message = uim342::decode_can(frame);
      EXPECT_TRUE(message.ok()) << message.error().message();
      if (!message) continue;
      pty_.write(*uim342::encode_ui_message(uim342::drive_message_to_ui(*message), crc_));
    }
    return frames.size();
  }
  [[nodiscard]] const uim342::UiMessageStream::Counters& counters() const { return from_host_.counters(); }

 private:
  test::PtyPeer pty_;
  uim342::CrcCoverage crc_;
  uim342::UiMessageStream from_host_;  // strict: the gateway checks our CRC the way it is set up
  sim::Uim342Drive* drive_ = nullptr;
  std::vector<can::Frame> outbox_;
};

class UiMessageUim342 : public ::testing::TestWithParam<uim342::CrcCoverage> {
 protected:
  void SetUp() override {
    const bool manual = GetParam() == uim342::CrcCoverage::kStartToAux;
    const std::string yaml =
        "buses:\n"
        "  - {name: gw, transport: \"uimessage:" +
        peer.link() + "\", baud: 115200, uimessage_crc: " + (manual ? "start_to_aux" : "id_to_aux") +
        ", request_timeout_ms: 50, retries: 2, poll_hz: 20}\n"
        "drives:\n"
        "  - {name: x-drive, family: uim342, bus: gw, node_id: 5, group_id: 20,\n"
        "     setup: {micro_steps: 16, current_a: 2.0, acceleration_unit: rate}}\n"
        "axes:\n"
        "  - {name: x, drive: x-drive, unit: mm, steps_per_unit: 640,\n"
        "     limits: {min: -10, max: 300, velocity: 50, acceleration: 400}}\n";
    auto loaded = config::load_string(yaml, "uimessage-lab.yaml");
    ASSERT_TRUE(loaded.ok()) << loaded.error_text();
    config_ = *loaded.config;
    const config::Bus& bus = *config_.find_bus("gw");

    std::error_code error;
    transport_ = gateway::open_can_transport(config_, bus, "test", error);
    ASSERT_TRUE(transport_) << gateway::open_error_message(config_, bus, error);

    const config::Drive& drive = *config_.find_drive("x-drive");
    sim::SimDriveContext drive_context;
    drive_context.drive = drive.name;
    drive_context.bus = drive.bus;
    drive_context.send = [this](const can::Frame& f) { peer.drive_sent(f); };
    drive_context.report = [](std::int8_t, std::int64_t, std::int64_t, std::int64_t) {};
    drive_ =
        std::make_unique<sim::Uim342Drive>(drive, std::move(drive_context), sim::uim342_identity(drive, bus.bitrate));
    peer.attach(*drive_);
    drive_->power_up(now);

    gateway::CanStackContext context;
    context.out = &out;
    context.send = [this](const can::Frame& f) { return !transport_->send(f); };
    stack_ = std::make_unique<gateway::Uim342Stack>(config_, "gw", context, [](TimePoint t) { return utime(t); });
  }

  static std::int64_t utime(TimePoint t) {
    return kEpochUs + std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
  }

  // Moves every frame across the pty until the line is quiet; true when anything moved.
  bool settle() {
    bool moved = false;
    for (;;) {
      bool progress = peer.deliver_to_drive(transport_->statistics().tx_frames - to_drive_, now, utime(now));
      to_drive_ = transport_->statistics().tx_frames;
      to_host_ += peer.deliver_to_host();
      const auto waiting = to_host_ - transport_->statistics().rx_frames;
      for (const auto& frame : test::receive_frames(*transport_, waiting)) {
        stack_->on_frame(frame, now);
        progress = true;
      }
      if (!progress) return moved;
      moved = true;
    }
  }

  // Runs stack and drive deadlines in simulated time until `done` or `limit` has passed.
  bool run_until(const std::function<bool()>& done, Duration limit) {
    const TimePoint end = now + limit;
    for (int step = 0; step < 100'000; ++step) {
      const TimePoint next = std::min(stack_->process(now), drive_->process(now));
      if (settle()) continue;  // new frames, new deadlines: ask again at the same `now`
      if (done()) return true;
      if (next > end) return false;
      now = std::max(next, now + std::chrono::microseconds(1));
    }
    ADD_FAILURE() << "no quiet point after 100000 steps";
    return false;
  }

  std::int64_t execute(gateway_command_t command) {
    command.command_id = ++next_id_;
    command.bus = "gw";
    command.num_axes = static_cast<std::int32_t>(command.axes.size());
    stack_->execute(command, now);
    return command.command_id;
  }
  // The command's terminal reply (DONE or FAILED), running the lab until it comes.
  gateway_reply_t finish(std::int64_t id, Duration limit) {
    const auto terminal = [this, id]() -> const gateway_reply_t* {
      for (const auto& r : out.replies) {
        if (r.command_id == id && (r.status == kDone || r.status == kFailed)) return &r;
      }
      return nullptr;
    };
    EXPECT_TRUE(run_until([&] { return terminal() != nullptr; }, limit)) << "command " << id << " did not end";
    const auto* reply = terminal();
    return reply ? *reply : gateway_reply_t{};
  }
  static motionlcm::axis_command_t axis(std::int64_t target = 0) {
    motionlcm::axis_command_t a{};
    a.axis = "x";
    a.target_counts = target;
    a.velocity = 6400;
    a.acceleration = 20000;
    a.deceleration = 20000;
    return a;
  }

  test::TempDir dir;
  GatewayPeer peer{dir.file("uim2533.tty"), GetParam()};
  config::Config config_;
  std::unique_ptr<can::Transport> transport_;
  std::unique_ptr<sim::Uim342Drive> drive_;
  std::unique_ptr<gateway::Uim342Stack> stack_;
  RecordingOutput out;
  TimePoint now = TimePoint{} + seconds(10);
  std::uint64_t to_drive_ = 0;  // UIMessages the peer took from the line
  std::uint64_t to_host_ = 0;   // UIMessages the peer wrote
  std::int64_t next_id_ = 0;
};

TEST_P(UiMessageUim342, IdentifySetUpEnableAndMoveThroughTheSerialGateway) {
  // Identification (ML), group id (PP[8]) and set-up (MT, IC, IE, QE ...) over the gateway.
  stack_->start(now);
  ASSERT_TRUE(run_until([&] { return stack_->ready(); }, seconds(2)));
  ASSERT_TRUE(stack_->status("x").has_value());
  EXPECT_TRUE(stack_->status("x")->online);
  EXPECT_EQ(peer.counters().frames, to_drive_);  // every host UIMessage passed the gateway's CRC check

  gateway_command_t enable{};
  enable.kind = gateway_command_t::ENABLE;
  enable.axes = {axis()};
  const auto enabled = finish(execute(enable), seconds(1));
  EXPECT_EQ(enabled.status, kDone) << enabled.reason;
  EXPECT_TRUE(drive_->driver_on());

  gateway_command_t move{};
  move.kind = gateway_command_t::ARM_MOVE;  // trigger 0: starts at once
  move.axes = {axis(6400)};
  const auto moved = finish(execute(move), seconds(10));
  EXPECT_EQ(moved.status, kDone) << moved.reason;
  EXPECT_EQ(drive_->position(now), 6400);
  EXPECT_FALSE(drive_->moving(now));
  ASSERT_TRUE(run_until([&] { return stack_->status("x")->position_counts == 6400; }, seconds(1)));
  EXPECT_TRUE(stack_->status("x")->in_position);

  const auto stats = transport_->statistics();
  EXPECT_EQ(stats.errors, 0u);
  EXPECT_EQ(stats.tx_dropped, 0u);
  EXPECT_GT(stats.rx_frames, 10u);
  EXPECT_EQ(peer.counters().crc_errors, 0u);
  EXPECT_EQ(peer.counters().discarded_bytes, 0u);
}

INSTANTIATE_TEST_SUITE_P(CrcCoverages, UiMessageUim342,
                         ::testing::Values(uim342::CrcCoverage::kStartToAux, uim342::CrcCoverage::kIdToAux),
                         [](const auto& param_info) {
                           return std::string(param_info.param == uim342::CrcCoverage::kStartToAux ? "StartToAux"
                                                                                                   : "IdToAux");
                         });

}  // namespace
}  // namespace motion::uimessage
