// Which start each axis of a synchronized move joins, decided from the drive models and the axis
// states: one BG for a UIM342 group moving whole, or for part of it while the rest of the group
// is free and at rest, a start of its own for everything else in this fixture's lab
// (x and y: UIM342 group 20; r: UIM342 without a group; c: ADAM, one broadcast).
#include "coordinator_fixture.hpp"

namespace motion::coordinator::test_fixture {
namespace {

// The ARM_MOVE commands of a move's trigger, as sets of axis names.
std::vector<std::set<std::string>> commands_of(const std::vector<gateway_command_t>& arms) {
  std::vector<std::set<std::string>> out;
  for (const auto& c : arms) {
    std::set<std::string> axes;
    for (const auto& a : c.axes) axes.insert(a.axis);
    out.push_back(axes);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// r's gateway set its drive up in group 20 (the configuration names no group for it): its drive
// model offers BG to group 20 first.
void put_r_in_group_20(FakeGateways& gateways) {
  using M = motionlcm::drive_model_t;
  auto& r_model = gateways.models.at("r");
  r_model.start_kinds.insert(r_model.start_kinds.begin(), std::int8_t{M::START_UIM342_GROUP_BG});
  r_model.start_addresses.insert(r_model.start_addresses.begin(), 20);
  r_model.start_wire_us.insert(r_model.start_wire_us.begin(), 70.0);
  r_model.num_starts = static_cast<std::int32_t>(r_model.start_kinds.size());
}

TEST_F(CoordinatorTest, AGroupMovingWholeSharesOneStartAndAPartOfItStartsAxisByAxis) {
  auto_execute_moves();
  const auto whole = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y", "r"}, {1.0, -2.0, 3.0}));
  ASSERT_EQ(whole.status, std::int8_t{reply_t::DONE}) << whole.reason;
  ASSERT_EQ(gateways.triggers.size(), 1u);
  using Axes = std::set<std::string>;
  EXPECT_EQ(commands_of(armed[gateways.triggers[0].trigger_id]), (std::vector<Axes>{{"r"}, {"x", "y"}}));

  // x without y: a BG to group 20 would start y too, so x has a start of its own.
  const auto part = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "r"}, {2.0, 4.0}));
  ASSERT_EQ(part.status, std::int8_t{reply_t::DONE}) << part.reason;
  ASSERT_EQ(gateways.triggers.size(), 2u);
  EXPECT_EQ(commands_of(armed[gateways.triggers[1].trigger_id]), (std::vector<Axes>{{"r"}, {"x"}}));
}

TEST_F(CoordinatorTest, TheGroupAStartReachesIsTheOneTheDriveModelsSay) {
  // A BG to group 20 now starts r as well.
  put_r_in_group_20(gateways);
  pump(milliseconds(100));  // the models are published every tick
  auto_execute_moves();
  // r's driver is off: a BG to group 20 cannot leave it be (its gateway holds only a drive that is
  // on and at rest), so x and y moving without r cannot share it.
  gateways.states["r"].enabled = false;
  pump(milliseconds(100));
  const auto done = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {1.0, -2.0}));
  ASSERT_EQ(done.status, std::int8_t{reply_t::DONE}) << done.reason;
  ASSERT_EQ(gateways.triggers.size(), 1u);
  using Axes = std::set<std::string>;
  EXPECT_EQ(commands_of(armed[gateways.triggers[0].trigger_id]), (std::vector<Axes>{{"x"}, {"y"}}));

  // r on and at rest: x and y, two of the group's three, share its BG (r is held at PR=0).
  gateways.states["r"].enabled = true;
  pump(milliseconds(100));
  const auto part = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {2.0, -1.0}));
  ASSERT_EQ(part.status, std::int8_t{reply_t::DONE}) << part.reason;
  ASSERT_EQ(gateways.triggers.size(), 2u);
  EXPECT_EQ(commands_of(armed[gateways.triggers[1].trigger_id]), (std::vector<Axes>{{"x", "y"}}));

  // With r in the move, the three share the group's one BG.
  const auto all = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y", "r"}, {3.0, -1.5, 5.0}));
  ASSERT_EQ(all.status, std::int8_t{reply_t::DONE}) << all.reason;
  ASSERT_EQ(gateways.triggers.size(), 3u);
  EXPECT_EQ(commands_of(armed[gateways.triggers[2].trigger_id]), (std::vector<Axes>{{"r", "x", "y"}}));
}

// Part of a group shares its BG only while each of the group's other axes is free and at rest,
// and only when the move holds at least two and at least half of the group.
TEST_F(CoordinatorTest, PartOfAGroupSharesItsBgOnlyWhileTheOthersAreFreeAndAtRest) {
  put_r_in_group_20(gateways);
  using Axes = std::set<std::string>;
  // r moving (someone else's jog, as its state says): no hold.
  gateways.states["r"].moving = true;
  pump(milliseconds(100));
  auto_execute_moves();
  const auto moving = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {1.0, -2.0}));
  ASSERT_EQ(moving.status, std::int8_t{reply_t::DONE}) << moving.reason;
  ASSERT_EQ(gateways.triggers.size(), 1u);
  EXPECT_EQ(commands_of(armed[gateways.triggers[0].trigger_id]), (std::vector<Axes>{{"x"}, {"y"}}));
  // r at rest but faulted, then offline: no hold either.
  gateways.states["r"].moving = false;
  gateways.states["r"].fault = true;
  pump(milliseconds(100));
  const auto faulted = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {2.0, -1.0}));
  ASSERT_EQ(faulted.status, std::int8_t{reply_t::DONE}) << faulted.reason;
  ASSERT_EQ(gateways.triggers.size(), 2u);
  EXPECT_EQ(commands_of(armed[gateways.triggers[1].trigger_id]), (std::vector<Axes>{{"x"}, {"y"}}));
  gateways.states["r"].fault = false;
  // One of the three (x alone) is below half: a BG of its own, whatever r does.
  pump(milliseconds(100));
  const auto one = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x"}, {3.0}));
  ASSERT_EQ(one.status, std::int8_t{reply_t::DONE}) << one.reason;
  ASSERT_EQ(gateways.triggers.size(), 3u);
  EXPECT_EQ(commands_of(armed[gateways.triggers[2].trigger_id]), (std::vector<Axes>{{"x"}}));
  // Free and at rest: shared.
  const auto shared = run_to_terminal(send(request_t::MOVE_ABSOLUTE, {"x", "y"}, {4.0, 1.0}));
  ASSERT_EQ(shared.status, std::int8_t{reply_t::DONE}) << shared.reason;
  ASSERT_EQ(gateways.triggers.size(), 4u);
  EXPECT_EQ(commands_of(armed[gateways.triggers[3].trigger_id]), (std::vector<Axes>{{"x", "y"}}));
}

}  // namespace
}  // namespace motion::coordinator::test_fixture
