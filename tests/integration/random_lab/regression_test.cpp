// Shrunk reproductions of seeds the randomized lab test once failed (random_lab_test.cpp prints
// them ready to paste): each runs its lab and steps against the reference model. Those of a jog, a
// stop or an e-stop are in regression_stop_test.cpp.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "random_lab.hpp"

namespace motion::random_lab {
namespace {

// Seeds 2 and 4: SET_OUTPUTS on a UIM242 axis; the gateway's acknowledgement handler read the
// command through a reference dead since execute() returned, and the gateway stopped heartbeating
// (ABORTED 16 "lost the heartbeat of the gateway of bus rs232").
TEST(RandomLabRegression, Seed2Uim242SetOutputs) {
  LabSpec spec;
  spec.rs232_baud = 38400;
  spec.axes.push_back(AxisSpec{"ax1", DriveSpec{"uim242", "rs232", 5, 0}, 640, -18, 59, 67.5, 312, false, 0, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kRequest, 0, 10 /* SET_OUTPUTS */, {"ax1"}, {0.0}, 0.0, 0.0, 0, 1, 0, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kRequest, 1, 10 /* SET_OUTPUTS */, {"ax1"}, {0.0}, 0.0, 0.0, 0, 1, 1, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kRequest,
           2,
           10 /* SET_OUTPUTS */,
           {"ax1"},
           {0.0},
           0.0,
           0.0,
           0,
           2,
           2,
           0,
           0,
           0,
           {},
           {},
           0,
           0},  // only P4: 17
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// Seed 1: a HOME refused for one UC57 axis (offset on a current-position homing) is aborted by the
// coordinator with a STOP it does not wait for; the JOG right after found a node "busy" with that
// STOP (the idle halt held the node for two SYNC cycles), and the refused HOME had zeroed ax0.
TEST(RandomLabRegression, Seed1Uc57JogAfterAFailedHome) {
  LabSpec spec;
  spec.can_bitrate = 125000;
  spec.axes.push_back(AxisSpec{"ax0", DriveSpec{"uc57", "can0", 1, 0}, 160, -18, 46, 54.5, 367, true, 0, 0, 0});
  spec.axes.push_back(
      AxisSpec{"ax1", DriveSpec{"uc57", "can0", 61, 0}, 12.5, -220, 740, 384.5, 1475.5, true, -105.5, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kRequest, 0, 7 /* ENABLE */, {"ax0", "ax1"}, {0.0, 0.0}, 0.0, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kRequest, 2, 6 /* HOME */, {"ax0", "ax1"}, {0.0, 0.0}, 0.0, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kJogStop,
           1,
           3 /* JOG */,
           {"ax1", "ax0"},
           {-76.62, -12.55},
           0.0,
           0.0,
           0,
           0,
           0,
           1,
           4 /* STOP */,
           0,
           {},
           {},
           0,
           0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// A SET_POSITION of a UIM342 and a UC57 axis on one bus, the UC57 value not zero: refused whole
// by the coordinator; before, the UIM342 part was applied and the request FAILED.
TEST(RandomLabRegression, Seed100) {
  LabSpec spec;
  spec.can_bitrate = 1000000;
  spec.rs485_baud = 19200;
  spec.rs232_baud = 115200;
  spec.rs485_parity = "none";
  spec.axes.push_back(
      AxisSpec{"ax0", DriveSpec{"uim342", "can0", 109, 0}, 533.33333333333337, -3, 11, 7, 38.5, false, 0, 0, 0});
  spec.axes.push_back(AxisSpec{"ax1", DriveSpec{"uc57", "can0", 10, 0}, 640, -8, 26, 11.5, 68, true, 0, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kConflict,
           1,
           1 /* MOVE_ABSOLUTE */,
           {"ax1"},
           {26.0},
           0.121,
           0.0,
           0,
           0,
           0,
           2,
           4 /* STOP */,
           13 /* SET_POSITION */,
           {"ax0", "ax1"},
           {11.0, -6.4900000000000002},
           0,
           0},
      Step{Op::kRequest,
           2,
           2 /* MOVE_RELATIVE */,
           {"ax0"},
           {0.00075000000000002842},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0 /* ? */,
           0 /* ? */,
           {},
           {},
           0,
           0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// A move that ended exactly at the upper limit (17 u = 9066.67 counts, so the drive stands at 9067),
// then an e-stop and a relative move of 0: measured from the commanded 17 u it is within the
// limits and DONE (the model had taken the read-back 17.0006 u as the base and refused it).
TEST(RandomLabRegression, Seed5001RelativeZeroAtTheLimitAfterAnEstop) {
  LabSpec spec;
  spec.rs485_baud = 38400;
  spec.rs232_baud = 115200;
  spec.rs485_parity = "even";
  spec.axes.push_back(
      AxisSpec{"ax0", DriveSpec{"uim242", "rs232", 78, 0}, 533.33333333333337, -13, 17, 14, 81, false, 0, 0, 0});
  spec.axes.push_back(
      AxisSpec{"ax1", DriveSpec{"uim242", "rs232", 125, 0}, 1, -1420, 9020, 9285.5, 67250.5, false, 0, 0, 0});
  spec.axes.push_back(
      AxisSpec{"ax2", DriveSpec{"adam-modbus", "rs485", 64, 0}, 320, -3, 11, 6.5, 27, true, -2.5, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kRequest,
           0,
           7 /* ENABLE */,
           {"ax0", "ax1", "ax2"},
           {0.0, 0.0, 0.0},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0,
           0,
           {},
           {},
           0,
           0},
      Step{Op::kRequest,
           1,
           2 /* MOVE_RELATIVE */,
           {"ax2", "ax0", "ax1"},
           {11.0, 17.0, 2601.2400000000002},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0,
           0,
           {},
           {},
           0,
           0},
      Step{Op::kRequest,
           1,
           5 /* ESTOP */,
           {"ax2", "ax0", "ax1"},
           {0.0, 0.0, 0.0},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0,
           0,
           {},
           {},
           0,
           0},
      Step{Op::kRequest,
           0,
           7 /* ENABLE */,
           {"ax0", "ax2", "ax1"},
           {0.0, 0.0, 0.0},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0,
           0,
           {},
           {},
           0,
           0},
      Step{Op::kRequest, 1, 2 /* MOVE_RELATIVE */, {"ax0"}, {0.0}, 0.0, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// A UIM242 move of one count synchronized with a long UC57 move crawls (below 1 count/s): the
// gateway took two polls without a position change for a stop short of the target (ABORTED 15).
TEST(RandomLabRegression, Seed11Uim242OneCountCrawlIsNotAStop) {
  LabSpec spec;
  spec.can_bitrate = 125000;
  spec.rs485_baud = 57600;
  spec.rs232_baud = 19200;
  spec.rs485_parity = "none";
  spec.axes.push_back(AxisSpec{"ax2", DriveSpec{"uc57", "can0", 127, 0}, 640, -6, 45, 18, 58, true, 0, 0, 0});
  spec.axes.push_back(
      AxisSpec{"ax3", DriveSpec{"uim242", "rs232", 5, 0}, 533.33333333333337, -6, 25, 17, 97.5, true, -3.75, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kRequest, 0, 7 /* ENABLE */, {"ax2", "ax3"}, {0.0, 0.0}, 0.0, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kRequest,
           1,
           1 /* MOVE_ABSOLUTE */,
           {"ax2", "ax3"},
           {12.92, 0.0018749999999999999},
           0.0,
           0.42999999999999999,
           0,
           0,
           0,
           0,
           0,
           0,
           {},
           {},
           0,
           0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// A conflict step whose slow move has nothing to do: the generator aimed ax0 at its farther limit
// from where its own model put it, but at run time ax0 already stood there (set there, and a
// relative move since refused). The move is DONE at once, the second request and the stop find
// nothing busy (the runner demanded a ~10 s move: seed 30082).
TEST(RandomLabRegression, Seed30082AConflictMoveAlreadyAtItsTargetIsDoneAtOnce) {
  LabSpec spec;
  spec.can_bitrate = 125000;
  spec.rs485_baud = 9600;
  spec.rs232_baud = 9600;
  spec.rs485_parity = "none";
  spec.axes.push_back(AxisSpec{"ax0", DriveSpec{"uim242", "rs232", 125, 0}, 160, -8, 12, 14, 108, false, 0, 0, 0});
  spec.axes.push_back(AxisSpec{"ax1", DriveSpec{"uc57", "can0", 30, 0}, 12.5, -250, 393, 225, 744, false, 0, 0, 0});
  spec.axes.push_back(
      AxisSpec{"ax2", DriveSpec{"adam-modbus", "rs485", 64, 0}, 1, -1385, 1891, 3206, 11902.5, false, 0, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kRequest,
           0,
           7 /* ENABLE */,
           {"ax0", "ax1", "ax2"},
           {0.0, 0.0, 0.0},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0,
           0,
           {},
           {},
           0,
           0},
      Step{Op::kRequest, 2, 13 /* SET_POSITION */, {"ax0"}, {-8.0}, 0.0, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kConflict,
           0,
           1 /* MOVE_ABSOLUTE */,
           {"ax0"},
           {-8.0},
           0.074999999999999997,
           0.0,
           120000,
           0,
           0,
           1,
           4 /* STOP */,
           1 /* MOVE_ABSOLUTE */,
           {"ax0"},
           {11.15375},
           0,
           0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// Chaos seed 50026: a BUS_DROP of 47 frames on a CAN bus whose only drive then went offline. The
// gateway probes an offline drive with backed-off retries, so the 47 frames took minutes to pass
// and the "1 s" fault outlasted the 30 s recovery; the runner now ends it after its second
// (BUS_DROP 0), as it ends silence and CRC errors.
TEST(RandomLabRegression, Seed50026ABusDropOnAQuietBusEndsWithItsSecond) {
  LabSpec spec;
  spec.can_bitrate = 250000;
  spec.rs485_baud = 115200;
  spec.rs232_baud = 19200;
  spec.rs485_parity = "odd";
  spec.axes.push_back(
      AxisSpec{"ax1", DriveSpec{"uim342", "can0", 7, 30}, 33.333333333333336, -49, 207, 89, 622, false, 0, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kFault,
           2,
           1 /* MOVE_ABSOLUTE */,
           {"ax1"},
           {46.5},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0,
           0,
           {"ax1"},
           {},
           8 /* BUS_DROP */,
           47},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// Chaos seed 50039: a move with a fault during it was REJECTED (an axis disabled by an e-stop),
// and the runner's model then dropped the relative base of its axes as if they had moved: the
// next relative move of ax2 was predicted from 602 counts instead of the last target, 0.94 units
// (601.6 counts), one count off. A refused request leaves nothing behind, that base included.
TEST(RandomLabRegression, Seed50039ARejectedFaultMoveKeepsTheRelativeBase) {
  LabSpec spec;
  spec.can_bitrate = 250000;
  spec.rs485_baud = 19200;
  spec.rs232_baud = 19200;
  spec.rs485_parity = "none";
  spec.security = true;
  spec.axes.push_back(
      AxisSpec{"ax0", DriveSpec{"uim342", "can0", 36, 0}, 12.5, -283, 313, 402.5, 1881, false, 0, 0, 0});
  spec.axes.push_back(
      AxisSpec{"ax1", DriveSpec{"adam-modbus", "rs485", 30, 0}, 320, -4, 15, 16.5, 63.5, true, 4.5, 0, 0});
  spec.axes.push_back(AxisSpec{"ax2", DriveSpec{"uim242", "rs232", 125, 0}, 640, -3, 4, 3.5, 25.5, false, 0, 0, 0});
  spec.axes.push_back(
      AxisSpec{"ax3", DriveSpec{"uc57", "can0", 1, 0}, 533.33333333333337, -8, 27, 14, 37, false, 0, 0, 0});
  spec.axes.push_back(AxisSpec{"ax4", DriveSpec{"adam-modbus", "rs485", 64, 0}, 533.33333333333337, -23, 28, 23.5,
                               114.5, false, 0, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kFault,
           1,
           1 /* MOVE_ABSOLUTE */,
           {"ax3", "ax4"},
           {-3.9100000000000001, 3.4900000000000002},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0 /* UNKNOWN */,
           0 /* UNKNOWN */,
           {"ax4"},
           {},
           1 /* STALL */,
           0},
      Step{Op::kRequest,
           1,
           1 /* MOVE_ABSOLUTE */,
           {"ax4", "ax2", "ax1"},
           {-0.0011249999999999999, 0.94000000000000006, 14.99},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0 /* UNKNOWN */,
           0 /* UNKNOWN */,
           {},
           {},
           0 /* none */,
           0},
      Step{Op::kRequest,
           1,
           5 /* ESTOP */,
           {},
           {},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0 /* UNKNOWN */,
           0 /* UNKNOWN */,
           {},
           {},
           0 /* none */,
           0},
      Step{Op::kFault,
           1,
           1 /* MOVE_ABSOLUTE */,
           {"ax3", "ax0", "ax2"},
           {25.199999999999999, 15.460000000000001, -0.16},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0 /* UNKNOWN */,
           0 /* UNKNOWN */,
           {"ax3"},
           {},
           7 /* REPLY_LATENCY */,
           30000},
      Step{Op::kRequest,
           2,
           1 /* MOVE_ABSOLUTE */,
           {"ax4", "ax0"},
           {23.010000000000002, -195.852},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0 /* UNKNOWN */,
           0 /* UNKNOWN */,
           {},
           {},
           0 /* none */,
           0},
      Step{Op::kRequest,
           2,
           2 /* MOVE_RELATIVE */,
           {"ax3", "ax2", "ax0"},
           {0.0018749999999999999, 1.02, 340.23199999999997},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0 /* UNKNOWN */,
           0 /* UNKNOWN */,
           {},
           {},
           0 /* none */,
           0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// Chaos seed 50054: a UC57 that went silent during a move (its set-point acknowledged, bit 4
// never released in profile position), then jogged and stopped, was asked for the next move: the
// simulator still showed the old move's acknowledge in bit 12 and the gateway waited in vain ("not
// ready for a set-point"). Profile position entered again has no set-point pending.
TEST(RandomLabRegression, Seed50054AUc57BackInProfilePositionHasNoStaleAcknowledge) {
  LabSpec spec;
  spec.can_bitrate = 125000;
  spec.rs485_baud = 115200;
  spec.rs232_baud = 115200;
  spec.rs485_parity = "none";
  spec.axes.push_back(AxisSpec{"ax0", DriveSpec{"uim342", "can0", 112, 68}, 640, -6, 8, 13, 77.5, false, 0, 0, 0});
  spec.axes.push_back(AxisSpec{"ax1", DriveSpec{"uc57", "can0", 79, 0}, 160, -10, 49, 49, 155.5, false, 0, 0, 0});
  spec.axes.push_back(AxisSpec{"ax2", DriveSpec{"adam-modbus", "rs485", 1, 0}, 33.333333333333336, -92, 93, 127, 565.5,
                               true, -47.25, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kFault,
           2,
           1 /* MOVE_ABSOLUTE */,
           {"ax0", "ax2", "ax1"},
           {6.3500000000000005, 76.799999999999997, 0.35999999999999999},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0 /* UNKNOWN */,
           0 /* UNKNOWN */,
           {"ax0"},
           {},
           3 /* SILENCE */,
           1},
      Step{Op::kFault,
           0,
           1 /* MOVE_ABSOLUTE */,
           {"ax0", "ax1", "ax2"},
           {-1.3200000000000001, 4.6799999999999997, 45.439999999999998},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0 /* UNKNOWN */,
           0 /* UNKNOWN */,
           {"ax1"},
           {},
           3 /* SILENCE */,
           1},
      Step{Op::kJogStop,
           1,
           3 /* JOG */,
           {"ax1", "ax2"},
           {-12.75, -17.300000000000001},
           0.0,
           0.0,
           0,
           0,
           0,
           2,
           4 /* STOP */,
           0 /* UNKNOWN */,
           {},
           {},
           0 /* none */,
           0},
      Step{Op::kRequest,
           1,
           1 /* MOVE_ABSOLUTE */,
           {"ax2", "ax1", "ax0"},
           {-26.84, 21.703749999999999, -4.7400000000000002},
           0.0,
           0.0,
           0,
           0,
           0,
           0,
           0 /* UNKNOWN */,
           0 /* UNKNOWN */,
           {},
           {},
           0 /* none */,
           0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

}  // namespace
}  // namespace motion::random_lab
