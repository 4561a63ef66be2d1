// HeldOutput: what passes while held is handed on at the release, in order; nothing is lost or
// duplicated; nested holds release at the outermost.
#include "motion/gateway/held_output.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace motion::gateway {
namespace {

struct Log final : GatewayOutput {
  void axis_status(const std::string& axis, const DriveStatus&) override { calls.push_back("status " + axis); }
  void axis_event(const std::string& axis, const DriveEvent& e) override {
    calls.push_back("event " + axis + " " + e.text);
  }
  void command_reply(motionlcm::gateway_reply_t r) override {
    calls.push_back("reply " + std::to_string(r.command_id));
  }
  void drive_facts(const std::string& axis, const DriveFacts&) override { calls.push_back("facts " + axis); }
  void position_lost(const std::string& axis, const std::string& why) override {
    calls.push_back("lost " + axis + " " + why);
  }
  std::vector<std::string> calls;
};

motionlcm::gateway_reply_t reply(std::int64_t id) {
  motionlcm::gateway_reply_t r{};
  r.command_id = id;
  return r;
}

TEST(HeldOutput, PassesStraightOnUnlessHeld) {
  Log log;
  HeldOutput out(log);
  out.axis_status("x", {});
  out.command_reply(reply(7));
  EXPECT_EQ(log.calls, (std::vector<std::string>{"status x", "reply 7"}));
}

TEST(HeldOutput, WhatIsHeldGoesOnAtTheOutermostReleaseInOrder) {
  Log log;
  HeldOutput out(log);
  out.hold();
  out.axis_status("x", {});
  DriveEvent e;
  e.text = "late";
  out.axis_event("y", e);
  out.hold();
  out.command_reply(reply(3));
  out.drive_facts("z", {});
  out.release();
  EXPECT_TRUE(log.calls.empty()) << "still held by the outer hold";
  out.position_lost("x", "power cycle");
  out.release();
  EXPECT_FALSE(out.held());
  EXPECT_EQ(log.calls,
            (std::vector<std::string>{"status x", "event y late", "reply 3", "facts z", "lost x power cycle"}));
  out.release();  // one too many: nothing happens
  out.axis_status("y", {});
  EXPECT_EQ(log.calls.back(), "status y");
  EXPECT_EQ(log.calls.size(), 6u);
}

}  // namespace
}  // namespace motion::gateway
