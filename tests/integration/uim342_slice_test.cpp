// The first vertical slice, request to drive and back, on the simulated lab's UIM342 axes:
// client -> coordinator -> gateway (UIM342 stack) -> bit-timed simulated CAN -> simulated UIM342
// drives, and replies, axis state and events all the way back. The simulated drives' own reports
// (SIM_REPORT) are the ground truth: x and y share group id 20, so their move must start on the
// one group-addressed BG frame (same end-of-frame time); z has no group and starts on its own frame.
#include <gtest/gtest.h>

#include <cmath>

#include "sim_lab.hpp"

namespace motion::testing {
namespace {

constexpr double kPositionTolerance = 1.0 / 640.0;  // one micro-step, in mm

std::int8_t status(std::int8_t s) { return s; }

bool saw(const std::vector<reply_t>& replies, std::int8_t s) {
  for (const auto& r : replies) {
    if (r.status == s) return true;
  }
  return false;
}

class Uim342Slice : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(lab.start({"x", "y", "z"}));
    const auto enabled = lab.call(Client::make(request_t::ENABLE, std::vector<std::string>{"x", "y", "z"}));
    ASSERT_EQ(enabled.status, status(reply_t::DONE)) << enabled.reason;
  }
  void TearDown() override {
    if (HasFailure()) lab.group().print_logs();
  }
  double position(const std::string& axis) { return lab.client().axes().at(axis).position; }

  SimLab lab;
};

TEST_F(Uim342Slice, GroupMoveStartsOnOneBgFrameAndArrives) {
  std::vector<reply_t> replies;
  const auto done = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", 10.0}, {"y", 5.0}}), &replies);
  ASSERT_EQ(done.status, status(reply_t::DONE)) << done.reason;
  EXPECT_TRUE(saw(replies, reply_t::ACCEPTED));
  EXPECT_TRUE(saw(replies, reply_t::STARTED));

  const auto x = lab.starts_of("x-drive");
  const auto y = lab.starts_of("y-drive");
  ASSERT_EQ(x.size(), 1u);
  ASSERT_EQ(y.size(), 1u);
  EXPECT_EQ(x[0].frame_utime, y[0].frame_utime) << "x and y did not start on the same frame";
  EXPECT_EQ(x[0].target_counts, 6400);
  EXPECT_EQ(y[0].target_counts, 3200);

  ASSERT_EQ(done.num_axes, 2);
  for (std::size_t i = 0; i < done.axes.size(); ++i)
    EXPECT_NEAR(done.positions[i], done.targets[i], kPositionTolerance) << done.axes[i];
  EXPECT_NEAR(done.measured_start_skew_us, 0.0, 1.0);
  EXPECT_TRUE(lab.client().wait_until([&] { return std::abs(position("x") - 10.0) < kPositionTolerance; }, seconds(2)));
}

TEST_F(Uim342Slice, AxesWithoutACommonGroupStartOnSeparateFramesAndStillArrive) {
  const auto done = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{"x", 2.0}, {"z", -3.0}}));
  ASSERT_EQ(done.status, status(reply_t::DONE)) << done.reason;
  const auto x = lab.starts_of("x-drive");
  const auto z = lab.starts_of("z-drive");
  ASSERT_EQ(x.size(), 1u);
  ASSERT_EQ(z.size(), 1u);
  EXPECT_NE(x[0].frame_utime, z[0].frame_utime);
  EXPECT_GT(done.predicted_skew_us, 0.0);
  EXPECT_NEAR(position("z"), -3.0, kPositionTolerance);
}

TEST_F(Uim342Slice, StallAbortsTheWholeMoveWithTheReason) {
  std::vector<reply_t> replies;
  const auto id = lab.client().send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", 200.0}, {"y", 150.0}}),
                                    [&](const reply_t& r) { replies.push_back(r); });
  (void)id;
  ASSERT_TRUE(lab.client().wait_until([&] { return saw(replies, reply_t::STARTED); }, seconds(10)));
  lab.control("y-drive", motionlcm::sim_control_t::STALL);
  ASSERT_TRUE(lab.client().wait_until([&] { return !replies.empty() && client::is_terminal(replies.back().status); },
                                      seconds(10)));
  const reply_t& last = replies.back();
  EXPECT_EQ(last.status, status(reply_t::ABORTED)) << last.reason;
  EXPECT_NE(last.reason.find('y'), std::string::npos) << last.reason;
  EXPECT_NE(last.reason.find("stall"), std::string::npos) << last.reason;
  // x was stopped with y: it is nowhere near its target and not moving.
  EXPECT_TRUE(lab.client().wait_until([&] { return !lab.client().axes().at("x").moving; }, seconds(5)));
  EXPECT_LT(position("x"), 199.0);
}

TEST_F(Uim342Slice, SilentDriveFailsTheMoveNamingTheDrive) {
  lab.control("z-drive", motionlcm::sim_control_t::SILENCE, 1);
  const auto done = lab.call(Client::make(request_t::MOVE_RELATIVE, Values{{"z", 1.0}}));
  EXPECT_TRUE(done.status == status(reply_t::FAILED) || done.status == status(reply_t::ABORTED)) << done.reason;
  EXPECT_NE(done.reason.find('z'), std::string::npos) << done.reason;
  EXPECT_TRUE(lab.starts_of("z-drive").empty());
}

TEST_F(Uim342Slice, TargetBeyondTheLimitIsRejectedAndNothingMoves) {
  const auto done = lab.call(Client::make(request_t::MOVE_ABSOLUTE, Values{{"x", 301.0}, {"y", 1.0}}));
  EXPECT_EQ(done.status, status(reply_t::REJECTED));
  EXPECT_NE(done.reason.find('x'), std::string::npos) << done.reason;
  EXPECT_NE(done.reason.find("300"), std::string::npos) << done.reason;
  EXPECT_TRUE(lab.starts_of("x-drive").empty());
  EXPECT_TRUE(lab.starts_of("y-drive").empty());
}

}  // namespace
}  // namespace motion::testing
