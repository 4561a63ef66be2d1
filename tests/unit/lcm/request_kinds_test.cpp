// One table names request kinds for people and for logs: every constant of request_t has both,
// and a value no constant has is named as such (never a null pointer, never another kind's name).
#include "motion/lcm/request_kinds.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>

#include <motionlcm/request_t.hpp>

namespace motion::lcm {
namespace {

using motionlcm::request_t;

TEST(RequestKinds, EveryKindHasOneNameAndOneWording) {
  std::set<std::string> names, words;
  for (int k = request_t::MOVE_ABSOLUTE; k <= request_t::SET_POSITION; ++k) {
    const auto kind = static_cast<std::int8_t>(k);
    EXPECT_STRNE(request_kind_name(kind), "UNKNOWN") << k;
    EXPECT_STRNE(request_kind_words(kind), "unknown") << k;
    names.insert(request_kind_name(kind));
    words.insert(request_kind_words(kind));
  }
  EXPECT_EQ(names.size(), 13u);
  EXPECT_EQ(words.size(), 13u);
  EXPECT_STREQ(request_kind_name(request_t::MOVE_RELATIVE), "MOVE_RELATIVE");
  EXPECT_STREQ(request_kind_words(request_t::ESTOP), "e-stop");
  EXPECT_STREQ(request_kind_name(0), "UNKNOWN");
  EXPECT_STREQ(request_kind_words(99), "unknown");
}

TEST(RequestKinds, TheKindsThatMoveAxes) {
  std::set<std::string> moving;
  for (int k = -128; k <= 127; ++k) {
    if (request_kind_moves(static_cast<std::int8_t>(k))) moving.insert(request_kind_name(static_cast<std::int8_t>(k)));
  }
  EXPECT_EQ(moving, (std::set<std::string>{"MOVE_ABSOLUTE", "MOVE_RELATIVE", "JOG", "HOME"}));
}

}  // namespace
}  // namespace motion::lcm
