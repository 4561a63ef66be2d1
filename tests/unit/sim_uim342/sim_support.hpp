// Test bench for the simulated UIM342: one drive with a recording context, frames written as the
// manual's rows (`ID CW DL d0 ... d7` in hex, bytes beyond DL are padding), explicit `now`.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "motion/config/config.hpp"
#include "motion/sim/uim342_drive.hpp"
#include "motion/uim342/identifier.hpp"
#include "motion/uim342/instructions.hpp"
#include "motion/uim342/message.hpp"

namespace motion::sim::test {

// Ground-truth report as the drive made it.
struct Report {
  std::int8_t kind = 0;
  std::int64_t frame_utime = 0;
  std::int64_t position = 0;
  std::int64_t target = 0;
};

inline std::vector<std::uint8_t> hex_bytes(std::string_view text) {
  std::vector<std::uint8_t> out;
  std::size_t i = 0;
  while (i < text.size()) {
    if (text[i] == ' ') {
      ++i;
      continue;
    }
    const std::size_t end = std::min(text.find(' ', i), text.size());
    out.push_back(static_cast<std::uint8_t>(std::stoul(std::string(text.substr(i, end - i)), nullptr, 16)));
    i = end;
  }
  return out;
}

// A manual row as a CAN frame from `producer` to `consumer`: the row's ID column is the drive
// (the addressee of an instruction, the sender of an ACK), the other side is the host (4).
inline can::Frame row_frame(std::string_view row, bool from_host, std::int64_t timestamp_us = 0) {
  const auto b = hex_bytes(row);
  EXPECT_GE(b.size(), 3U) << row;
  const std::uint8_t id = b.at(0);
  const std::uint8_t length = b.at(2);
  const uim342::CanIdFields fields{from_host ? uim342::kMasterId : id, from_host ? id : uim342::kMasterId, b.at(1)};
  const auto count = static_cast<std::ptrdiff_t>(std::min<std::size_t>(length, b.size() - 3));
  std::vector<std::uint8_t> data(b.begin() + 3, b.begin() + 3 + count);
  auto frame = *can::Frame::make(*uim342::encode_can_id(fields), true, data);
  frame.timestamp_us = timestamp_us;
  return frame;
}
inline can::Frame instruction_row(std::string_view row, std::int64_t timestamp_us = 0) {
  return row_frame(row, true, timestamp_us);
}
inline can::Frame reply_row(std::string_view row) { return row_frame(row, false); }

inline can::Frame encode(std::uint8_t target, const uim342::Instruction& instruction, std::int64_t timestamp_us = 0) {
  auto frame = *uim342::instruction_frame(target, instruction);
  frame.timestamp_us = timestamp_us;
  return frame;
}

inline config::Drive uim342_drive(std::string name, int node_id, int group_id = 0,
                                  std::map<std::string, config::SetupValue> setup = {}) {
  config::Drive d;
  d.name = std::move(name);
  d.family = config::Family::kUim342;
  d.bus = "can0";
  d.node_id = node_id;
  d.group_id = group_id;
  d.setup = std::move(setup);
  return d;
}

// One simulated drive, powered up at t0, with everything it sends and reports recorded.
class Bench {
 public:
  explicit Bench(const config::Drive& drive, Uim342Identity identity = {},
                 MicroStepsApply apply = MicroStepsApply::kAfterRestart)
      : node(static_cast<std::uint8_t>(drive.node_id)) {
    SimDriveContext context;
    context.drive = drive.name;
    context.bus = drive.bus;
    context.send = [this](const can::Frame& f) { sent.push_back(f); };
    context.report = [this](std::int8_t kind, std::int64_t utime, std::int64_t position, std::int64_t target) {
      reports.push_back({kind, utime, position, target});
    };
    sim = std::make_unique<Uim342Drive>(drive, std::move(context), identity, std::nullopt, apply);
    sim->power_up(now);
  }

  TimePoint at(double seconds) const {
    return t0 + std::chrono::duration_cast<Duration>(std::chrono::duration<double>(seconds));
  }
  // Delivers a frame at `now` and returns what the drive sent in response (and clears it).
  std::vector<can::Frame> deliver(const can::Frame& frame) {
    sent.clear();
    sim->on_frame(frame, now);
    return take();
  }
  std::vector<can::Frame> send(const uim342::Instruction& instruction, std::int64_t timestamp_us = 0) {
    return deliver(encode(node, instruction, timestamp_us));
  }
  // Sends and expects exactly one frame back: the reply.
  can::Frame exchange(const uim342::Instruction& instruction) {
    const auto replies = send(instruction);
    EXPECT_EQ(replies.size(), 1U) << uim342::to_string(instruction);
    return replies.empty() ? can::Frame{} : replies.front();
  }
  // Advances to `t` the way the host does: process() until the next deadline is after `t`.
  TimePoint advance_to(TimePoint t) {
    now = t;
    return sim->process(now);
  }
  // Follows the drive's deadlines until it has none left (a PTP motion ends); returns when the
  // last one was. Bounded, so a drive that never settles fails instead of hanging.
  TimePoint settle() {
    for (int i = 0; i < 100; ++i) {
      const TimePoint next = sim->process(now);
      if (next == kNever) return now;
      EXPECT_GT(next, now);
      now = next;
    }
    ADD_FAILURE() << "the drive did not settle";
    return now;
  }
  std::vector<can::Frame> take() {
    auto out = std::move(sent);
    sent.clear();
    return out;
  }
  // The reply decoded (fails the test when it is not a valid drive reply from this node).
  uim342::Reply decode(const can::Frame& frame) const {
    const auto r = uim342::decode_reply_frame(frame);
    EXPECT_TRUE(r.ok()) << r.error().message();
    if (!r) return {};
    EXPECT_EQ(r->address.producer, node);
    return r->reply;
  }
  [[nodiscard]] std::vector<Report> reports_of(std::int8_t kind) const {
    std::vector<Report> out;
    for (const auto& r : reports) {
      if (r.kind == kind) out.push_back(r);
    }
    return out;
  }

  const TimePoint t0 = TimePoint{} + std::chrono::hours(1);
  TimePoint now = t0;
  std::uint8_t node;
  std::unique_ptr<Uim342Drive> sim;
  std::vector<can::Frame> sent;
  std::vector<Report> reports;
};

inline std::int8_t started() { return std::int8_t{motionlcm::sim_report_t::MOTION_STARTED}; }
inline std::int8_t finished() { return std::int8_t{motionlcm::sim_report_t::MOTION_FINISHED}; }
inline std::int8_t powered_up() { return std::int8_t{motionlcm::sim_report_t::POWERED_UP}; }

inline motionlcm::sim_control_t control(std::int8_t action, std::int32_t value = 0, std::int32_t level = 0) {
  motionlcm::sim_control_t c{};
  c.action = action;
  c.value = value;
  c.level = level;
  return c;
}

}  // namespace motion::sim::test
