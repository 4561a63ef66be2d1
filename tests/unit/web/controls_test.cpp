// The page's commands (controls.hpp): what a browser's JSON becomes, and every way it is refused
// before anything is sent, each naming what was wrong.
#include "motion/web/controls.hpp"

#include <gtest/gtest.h>

#include "shipped_lab.hpp"

#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "motion/lcm/request_kinds.hpp"

namespace motion::web {
namespace {

using motionlcm::request_t;
using nlohmann::json;
using testing::lab;

constexpr const char* kToken = "0123456789abcdef0123456789abcdef";

json command(const std::string& kind, json axes, json values = nullptr) {
  json c{{"type", "command"}, {"token", kToken}, {"tag", 7}, {"kind", kind}, {"axes", std::move(axes)}};
  if (!values.is_null()) c["values"] = std::move(values);
  return c;
}

request_t accepted(const json& c) {
  auto parsed = parse_control(c.dump(), lab(), kToken);
  if (const auto* e = std::get_if<ControlError>(&parsed)) ADD_FAILURE() << c.dump() << ": " << e->error;
  const auto* ok = std::get_if<ControlRequest>(&parsed);
  return ok != nullptr ? ok->request : request_t{};
}

// The error, or "" when it was accepted.
std::string refused(const std::string& text) {
  auto parsed = parse_control(text, lab(), kToken);
  const auto* e = std::get_if<ControlError>(&parsed);
  return e != nullptr ? e->error : "";
}

TEST(WebControls, AMoveOfTwoAxesBecomesOneRequestWithItsValuesAndScale) {
  auto c = command("MOVE_ABSOLUTE", {"x", "y"}, {40.0, -2.5});
  c["velocity_scale"] = 0.5;
  const auto r = accepted(c);
  EXPECT_EQ(r.kind, std::int8_t{request_t::MOVE_ABSOLUTE});
  EXPECT_EQ(r.num_axes, 2);
  EXPECT_EQ(r.axes, (std::vector<std::string>{"x", "y"}));
  EXPECT_EQ(r.values, (std::vector<double>{40.0, -2.5}));
  EXPECT_DOUBLE_EQ(r.velocity_scale, 0.5);
  EXPECT_DOUBLE_EQ(r.acceleration_scale, 0.0);  // absent: the coordinator's default
  EXPECT_EQ(r.timeout_ms, 0);                   // the coordinator's default, not whatever was in memory
  EXPECT_EQ(r.output_mask, 0);
  auto parsed = parse_control(c.dump(), lab(), kToken);
  EXPECT_EQ(std::get<ControlRequest>(parsed).tag, 7);
}

TEST(WebControls, EveryPageKindIsAcceptedAndNoOtherKind) {
  const std::set<std::int8_t> page{request_t::ENABLE,        request_t::DISABLE, request_t::MOVE_ABSOLUTE,
                                   request_t::MOVE_RELATIVE, request_t::JOG,     request_t::STOP,
                                   request_t::ESTOP,         request_t::HOME,    request_t::FAULT_RESET};
  for (std::int8_t kind = 1; kind <= request_t::SET_POSITION; ++kind) {
    const std::string name = lcm::request_kind_name(kind);
    const bool with_values =
        kind == request_t::MOVE_ABSOLUTE || kind == request_t::MOVE_RELATIVE || kind == request_t::JOG;
    const auto c = command(name, {"z"}, with_values ? json{1.0} : json(nullptr));
    const std::string error = refused(c.dump());
    if (page.contains(kind)) {
      EXPECT_EQ(error, "") << name;
      EXPECT_EQ(accepted(c).kind, kind);
    } else {
      EXPECT_NE(error.find("is not one the page may send"), std::string::npos) << name << ": " << error;
    }
  }
}

TEST(WebControls, StopAndEStopMayNameNoAxisTheOthersMayNot) {
  EXPECT_EQ(accepted(command("ESTOP", json::array())).num_axes, 0);
  EXPECT_EQ(accepted(command("STOP", json::array())).num_axes, 0);
  EXPECT_EQ(refused(command("ENABLE", json::array()).dump()), "ENABLE needs at least one axis");
  EXPECT_EQ(accepted(command("ENABLE", {"x", "c"})).values, (std::vector<double>{0.0, 0.0}));
}

TEST(WebControls, TheAccessTokenIsRequiredAndComparedWhole) {
  auto c = command("STOP", {"x"});
  c.erase("token");
  EXPECT_NE(refused(c.dump()).find("access token"), std::string::npos);
  for (const std::string wrong : {"", "0123456789abcdef0123456789abcdeF", "0123456789abcdef0123456789abcde",
                                  "0123456789abcdef0123456789abcdef0"}) {
    c["token"] = wrong;
    EXPECT_NE(refused(c.dump()).find("access token"), std::string::npos) << wrong;
  }
  c["token"] = 12;
  EXPECT_NE(refused(c.dump()).find("access token"), std::string::npos);
  // A motion-web without a token (none could be made) accepts none, not the empty one.
  c["token"] = "";
  auto parsed = parse_control(c.dump(), lab(), "");
  EXPECT_TRUE(std::holds_alternative<ControlError>(parsed));
}

TEST(WebControls, MalformedCommandsAreRefusedNamingWhatWasWrong) {
  EXPECT_EQ(refused("not json"), "a command is one JSON object");
  EXPECT_EQ(refused("[1,2]"), "a command is one JSON object");
  auto c = command("MOVE_ABSOLUTE", {"x"}, {1.0});
  c["type"] = "hello";
  EXPECT_EQ(refused(c.dump()), "\"type\" must be \"command\"");
  c["type"] = json::array();  // not a string at all (found by fuzz_web_controls: it threw)
  EXPECT_EQ(refused(c.dump()), "\"type\" must be \"command\"");
  c.erase("type");
  EXPECT_EQ(refused(c.dump()), "\"type\" must be \"command\"");
  c = command("MOVE_ABSOLUTE", {"x"}, {1.0});
  c["tag"] = "seven";
  EXPECT_EQ(refused(c.dump()), "\"tag\" must be an integer");
  EXPECT_EQ(refused(command("MOVE_ABSOLUTE", {"w"}, {1.0}).dump()), "no axis 'w' in " + lab().file);
  EXPECT_EQ(refused(command("MOVE_ABSOLUTE", {"x", "x"}, {1.0, 2.0}).dump()), "axis 'x' named twice");
  EXPECT_EQ(refused(command("MOVE_ABSOLUTE", {"x", "y"}, {1.0}).dump()),
            "\"values\" must hold one number per axis for MOVE_ABSOLUTE");
  EXPECT_EQ(refused(command("JOG", {"x"}).dump()), "\"values\" must hold one number per axis for JOG");
  EXPECT_EQ(refused(command("MOVE_RELATIVE", {"x"}, {"1"}).dump()), "\"values\" must be finite numbers");
  EXPECT_EQ(refused(command("STOP", {"x"}, {1.0}).dump()), "STOP takes no values");
  EXPECT_EQ(refused(command("MOVE_ABSOLUTE", "x", {1.0}).dump()), "\"axes\" must be an array of axis names");
  EXPECT_EQ(refused(command("FLY", {"x"}).dump()).rfind("kind 'FLY' is not one the page may send (ENABLE, ", 0), 0u);
  for (const double scale : {0.0, -0.5, 1.5}) {
    c = command("MOVE_ABSOLUTE", {"x"}, {1.0});
    c["velocity_scale"] = scale;
    EXPECT_EQ(refused(c.dump()), "\"velocity_scale\" must be in (0, 1]") << scale;
  }
  c = command("MOVE_ABSOLUTE", {"x"}, {1.0});
  c["acceleration_scale"] = 1.0;
  EXPECT_EQ(refused(c.dump()), "");
}

TEST(WebControls, TheAnswersNameTheTagAndTheRequestOrTheError) {
  const auto ok = json::parse(control_accepted(7, "web/12"));
  EXPECT_EQ(ok, (json{{"type", "command_result"}, {"tag", 7}, {"ok", true}, {"id", "web/12"}}));
  const auto no = json::parse(control_refused({std::nullopt, "a command is one JSON object"}));
  EXPECT_TRUE(no["tag"].is_null());
  EXPECT_EQ(no["ok"], false);
  EXPECT_EQ(no["error"], "a command is one JSON object");
}

TEST(WebControls, AccessTokensAre128RandomBitsInHex) {
  const auto a = new_access_token();
  const auto b = new_access_token();
  EXPECT_EQ(a.size(), 32u);
  EXPECT_EQ(a.find_first_not_of("0123456789abcdef"), std::string::npos);
  EXPECT_NE(a, b);
}

}  // namespace
}  // namespace motion::web
