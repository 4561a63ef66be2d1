// Uim342Stack homing on a switch: the origin action armed on the input, the jog toward it, the
// drive's settings restored, starting on the switch, a missing switch and a driver that is off
// (bench: uim342_stack_fixture.hpp).
#include "uim342_stack_fixture.hpp"

namespace motion::gateway::test {
namespace {

// x homes on a switch at IN2 (falling edge) toward min; travel 310 mm = 198400 counts.
std::string homing_lab() {
  std::string yaml = kLab;
  const std::string x_axis = "limits: {min: -10, max: 300, velocity: 50, acceleration: 400}}";
  yaml.replace(yaml.find(x_axis), x_axis.size(),
               "limits: {min: -10, max: 300, velocity: 50, acceleration: 400}, homing: {method: switch, input: 2, "
               "velocity: -5}}");
  return yaml;
}

std::vector<uim342::Instruction> without_polls(std::vector<uim342::Instruction> list) {
  std::erase_if(list, [](const uim342::Instruction& i) {
    return i.function == FC::kMS && i.operation == uim342::Operation::kGet &&
           std::get<uim342::Index>(i.body).index == 1;
  });
  return list;
}

TEST_F(Uim342StackTest, HomeOnASwitchArmsTheOriginActionJogsRestoresAndReturnsToTheEdge) {
  build(homing_lab());
  start_and_set_up();
  enable({"x"});
  drives.at(5).inputs = 0x02;  // IN2 high: off the switch
  // The drive's IL[1] before homing (§5.26 example bytes): restored afterwards.
  drives.at(5).handle(*uim342::instruction_frame(
      5, uim342::request::set_input_logic(uim342::InputPort::kIn2,
                                          uim342::EdgeAction{uim342::InputAction::kDecelerateStop, false},
                                          uim342::EdgeAction{})));
  sent.clear();
  auto cmd = command(gateway_command_t::HOME, {"x"});
  cmd.axes[0].velocity = -3200;
  cmd.axes[0].target_counts = 640;  // homing offset 1 mm
  const auto home = execute(cmd);
  run_for(milliseconds(10));
  ASSERT_TRUE(statuses_of(home).empty()) << "HOME must not end before the switch is found";
  ASSERT_TRUE(drives.at(5).moving());
  namespace rq = uim342::request;
  using uim342::EdgeAction;
  using uim342::InputAction;
  const EdgeAction origin{InputAction::kOriginThenDecelerateStop, true};  // 0x86: FG = 1, action 0x06
  const EdgeAction nothing{InputAction::kNone, true};                     // 0x80
  auto x = without_polls(sent_to(5));
  const std::vector<uim342::Instruction> search{rq::get(uim342::MotionStatusIndex::kStatus),
                                                rq::get_input_logic(1),
                                                rq::select_group(uim342::ParameterGroup::kIn2Falling),
                                                rq::set_deceleration(10000),
                                                rq::set_input_logic(uim342::InputPort::kIn2, origin, nothing),
                                                rq::set_jog_velocity(-3200),
                                                rq::set_acceleration(10000),
                                                rq::set_deceleration(10000),
                                                rq::begin()};
  ASSERT_GE(x.size(), search.size());
  EXPECT_EQ(std::vector<uim342::Instruction>(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(search.size())),
            search);
  EXPECT_EQ(count_sent(5, FC::kOG), 0u);  // the origin comes from the switch, not from OG

  // The switch is reached: IN2 falls, the drive zeroes its counter there and stops 12 counts on.
  sent.clear();
  deliver(drives.at(5).origin_action(uim342::InputPort::kIn2, false, -12));
  run_for(milliseconds(100));  // the next MS[0] poll sees it stopped on the switch
  x = without_polls(sent_to(5));
  std::erase_if(x, [](const uim342::Instruction& i) { return i.function == FC::kMS; });
  const std::vector<uim342::Instruction> back{
      rq::set_input_logic(uim342::InputPort::kIn2, EdgeAction{InputAction::kDecelerateStop, false}, EdgeAction{}),
      rq::set_absolute_position(0), rq::set_ptp_speed(3200), rq::begin()};
  EXPECT_EQ(x, back);
  EXPECT_TRUE(statuses_of(home).empty());
  deliver(drives.at(5).finish_move());
  EXPECT_EQ(statuses_of(home), (std::vector<std::int8_t>{kDone}));
  EXPECT_NE(last_reply(home).reason.find("IN2 falling edge"), std::string::npos) << last_reply(home).reason;
  EXPECT_TRUE(stack->status("x")->homed);
  EXPECT_EQ(stack->status("x")->position_counts, 640);
}

TEST_F(Uim342StackTest, HomeStartingOnTheSwitchLeavesItTheOtherWay) {
  build(homing_lab());
  start_and_set_up();
  enable({"x"});
  drives.at(5).inputs = 0x00;  // IN2 low: on the switch
  sent.clear();
  auto cmd = command(gateway_command_t::HOME, {"x"});
  cmd.axes[0].velocity = -3200;
  const auto home = execute(cmd);
  run_for(milliseconds(10));
  const auto x = sent_to(5);
  const uim342::EdgeAction origin{uim342::InputAction::kOriginThenDecelerateStop, true};
  const uim342::EdgeAction nothing{uim342::InputAction::kNone, true};
  EXPECT_NE(std::find(x.begin(), x.end(), uim342::request::set_input_logic(uim342::InputPort::kIn2, nothing, origin)),
            x.end());
  EXPECT_NE(std::find(x.begin(), x.end(), uim342::request::set_jog_velocity(3200)), x.end());
  deliver(drives.at(5).origin_action(uim342::InputPort::kIn2, true, 5));
  run_for(milliseconds(100));
  deliver(drives.at(5).finish_move());
  EXPECT_EQ(last_reply(home).status, kDone);
}

TEST_F(Uim342StackTest, HomeWithoutTheSwitchStopsAndFailsNamingTheInputWithinItsBound) {
  build(homing_lab());
  start_and_set_up();
  enable({"x"});
  drives.at(5).inputs = 0x02;
  auto cmd = command(gateway_command_t::HOME, {"x"});
  cmd.axes[0].velocity = -3200;
  const auto home = execute(cmd);
  // Bound: 198400 counts / 3200 counts/s + 2 x 3200/10000 s of ramps + 2 s = 64.64 s.
  run_for(std::chrono::seconds(64));
  EXPECT_TRUE(statuses_of(home).empty());
  EXPECT_TRUE(drives.at(5).moving());
  sent.clear();
  run_for(std::chrono::seconds(1));
  ASSERT_EQ(statuses_of(home), (std::vector<std::int8_t>{kFailed}));
  const auto reason = last_reply(home).reason;
  EXPECT_NE(reason.find("IN2"), std::string::npos) << reason;
  EXPECT_NE(reason.find("not found"), std::string::npos) << reason;
  EXPECT_FALSE(drives.at(5).moving());  // ST
  EXPECT_EQ(count_sent(5, FC::kST), 1u);
  // IL[1] disarmed: the drive's earlier (factory) value again.
  EXPECT_EQ(drives.at(5).word(FC::kIL, 1), 0);
  EXPECT_FALSE(stack->status("x")->homed);
}

TEST_F(Uim342StackTest, HomeOnASwitchNeedsTheDriverOn) {
  build(homing_lab());
  start_and_set_up();
  const auto home = execute(command(gateway_command_t::HOME, {"x"}));
  EXPECT_EQ(last_reply(home).status, kFailed);
  EXPECT_NE(last_reply(home).reason.find("disabled"), std::string::npos);
  EXPECT_EQ(count_sent(5, FC::kIL), 0u);  // IL with the driver off would go to EEPROM (§5.26)
}

}  // namespace
}  // namespace motion::gateway::test
