// The words for reply statuses, heartbeat states and event kinds and severities: one per constant,
// all different, and a value no constant has is named as such (never a null pointer).
#include "motion/lcm/message_names.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>

#include <motionlcm/event_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/reply_t.hpp>

namespace motion::lcm {
namespace {

using motionlcm::event_t;
using motionlcm::health_t;
using motionlcm::reply_t;

TEST(MessageNames, ReplyStatuses) {
  std::set<std::string> names;
  for (int s = reply_t::ACCEPTED; s <= reply_t::FAILED; ++s)
    names.insert(reply_status_name(static_cast<std::int8_t>(s)));
  EXPECT_EQ(names.size(), 7u);
  EXPECT_FALSE(names.contains("unknown"));
  EXPECT_STREQ(reply_status_name(reply_t::DONE), "done");
  EXPECT_STREQ(reply_status_name(0), "unknown");
  std::set<std::string> terminal;
  for (int s = -128; s <= 127; ++s) {
    if (reply_is_terminal(static_cast<std::int8_t>(s))) terminal.insert(reply_status_name(static_cast<std::int8_t>(s)));
  }
  EXPECT_EQ(terminal, (std::set<std::string>{"done", "rejected", "aborted", "failed"}));
}

TEST(MessageNames, HealthStates) {
  std::set<std::string> names;
  for (int s = health_t::STARTING; s <= health_t::STOPPING; ++s)
    names.insert(health_state_name(static_cast<std::int8_t>(s)));
  EXPECT_EQ(names, (std::set<std::string>{"starting", "ok", "degraded", "fault", "stopping"}));
  EXPECT_STREQ(health_state_name(9), "?");
}

TEST(MessageNames, EventKindsAndSeverities) {
  std::set<std::string> kinds;
  for (int k = event_t::ALARM; k <= event_t::UNOWNED_MOTION; ++k)
    kinds.insert(event_kind_name(static_cast<std::int16_t>(k)));
  EXPECT_EQ(kinds.size(), static_cast<std::size_t>(event_t::UNOWNED_MOTION));
  EXPECT_FALSE(kinds.contains("unknown"));
  EXPECT_STREQ(event_kind_name(event_t::MOTION_COMPLETE), "motion complete");
  EXPECT_STREQ(event_kind_name(0), "unknown");
  EXPECT_STREQ(event_severity_name(event_t::WARNING), "warning");
  EXPECT_STREQ(event_severity_name(7), "unknown");
}

}  // namespace
}  // namespace motion::lcm
