// The bench of the simulated UC57's tests (uc57_drive_protocol_test.cpp, uc57_drive_motion_test.cpp):
// one Uc57DriveSim with a recording context and a manual clock, driven frame by frame with the
// manual's and derived frames. Thread contract: single-threaded test code.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "../canopen/frame_text.hpp"
#include "motion/cia402/words.hpp"
#include "motion/sim/uc57_drive.hpp"

namespace motion::sim::uc57_test {

using namespace std::chrono_literals;
using canopen::test::frame;
using Texts = std::vector<std::string>;
namespace od = cia402::uc57;

inline const TimePoint t0 = TimePoint{} + 1h;
inline constexpr std::int64_t kEpochUs = 1'700'000'000'000'000;  // wall time of t0

inline std::int64_t utime_of(TimePoint t) {
  return kEpochUs + std::chrono::duration_cast<std::chrono::microseconds>(t - t0).count();
}

struct Report {
  std::int8_t kind;
  std::int64_t frame_utime;
  std::int64_t position;
  std::int64_t target;
};

// One simulated drive with a recording context and a manual clock.
class Drive {
 public:
  explicit Drive(canopen::NodeId node = 1, Uc57SimOptions options = {}) : node_(node), sim_(node, context(), options) {
    sim_.power_up(now);
  }

  // Delivers a frame at `now` (its end-of-frame time) and returns what the drive sent.
  Texts deliver(const char* text) {
    can::Frame f = frame(text);
    f.timestamp_us = utime_of(now);
    sim_.on_frame(f, now);
    return take();
  }
  // Moves the clock, running every deadline on the way, as the host's loop does.
  void advance_to(TimePoint until) {
    for (int guard = 0; guard < 10000; ++guard) {
      const TimePoint next = sim_.process(now);
      if (next > until) break;
      now = std::max(now, next);
    }
    now = until;
    sim_.process(now);
  }
  Texts take() {
    auto texts = canopen::test::to_texts(sent_);
    sent_.clear();
    return texts;
  }
  std::uint16_t statusword() const { return sim_.statusword(now); }
  std::vector<Report> reports_of(std::int8_t kind) const {
    std::vector<Report> out;
    for (const auto& r : reports_) {
      if (r.kind == kind) out.push_back(r);
    }
    return out;
  }
  // SDO write with the manual's frame, expecting the plain confirmation.
  // TPDOs that follow the change may go out too; exactly one SDO reply must be a confirmation.
  void sdo_ok(const char* request) {
    const std::string channel = "58" + std::to_string(node_) + ":";
    Texts replies;
    for (const auto& text : deliver(request)) {
      if (text.starts_with(channel)) replies.push_back(text);
    }
    ASSERT_EQ(replies.size(), 1u) << request;
    EXPECT_EQ(replies[0].substr(0, 6), channel + " 6") << request << " -> " << replies[0];
  }
  void enable() {
    for (const char* cw : {"0: 2B 40 60 00 06 00 00 00", "0: 2B 40 60 00 07 00 00 00", "0: 2B 40 60 00 0F 00 00 00"}) {
      sdo_ok(for_node(cw).c_str());
    }
  }
  // "0: ..." -> "60n: ..." for this node.
  std::string for_node(const char* sdo_tail) const {
    return "60" + std::to_string(node_) + std::string(sdo_tail).substr(1);
  }

  TimePoint now = t0;
  Uc57DriveSim& sim() { return sim_; }

 private:
  SimDriveContext context() {
    SimDriveContext c;
    c.drive = "axis";
    c.bus = "can0";
    c.send = [this](const can::Frame& f) { sent_.push_back(f); };
    c.report = [this](std::int8_t kind, std::int64_t utime, std::int64_t position, std::int64_t target) {
      reports_.push_back({kind, utime, position, target});
    };
    return c;
  }

  canopen::NodeId node_;
  std::vector<can::Frame> sent_;
  std::vector<Report> reports_;
  Uc57DriveSim sim_;
};

inline constexpr auto kStarted = motionlcm::sim_report_t::MOTION_STARTED;
inline constexpr auto kFinished = motionlcm::sim_report_t::MOTION_FINISHED;

inline bool bit(std::uint16_t word, cia402::StatusBit b) { return cia402::is_set(word, b); }

}  // namespace motion::sim::uc57_test
