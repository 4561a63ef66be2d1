// Shrunk reproductions of seeds the randomized lab test once failed in a jog, a stop or an e-stop
// (regression_test.cpp: the others): each runs its lab and steps against the reference model.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "random_lab.hpp"

namespace motion::random_lab {
namespace {

// A UC57 jogging, e-stopped, then enabled again: it must not resume the jog (60FFh zeroed).
TEST(RandomLabRegression, Seed108) {
  LabSpec spec;
  spec.can_bitrate = 500000;
  spec.rs485_baud = 9600;
  spec.rs232_baud = 38400;
  spec.rs485_parity = "none";
  spec.axes.push_back(AxisSpec{"ax0", DriveSpec{"uc57", "can0", 1, 0}, 12.5, -39, 910, 341.5, 2184.5, false, 0, 0, 0});
  spec.axes.push_back(
      AxisSpec{"ax1", DriveSpec{"adam-modbus", "rs485", 42, 0}, 320, -1, 66, 25.5, 53.5, true, 59.25, 0, 0});
  spec.axes.push_back(AxisSpec{"ax2", DriveSpec{"uc57", "can0", 127, 0}, 160, -62, 76, 68.5, 476, false, 0, 0, 0});
  spec.axes.push_back(
      AxisSpec{"ax3", DriveSpec{"uim242", "rs232", 42, 0}, 533.33333333333337, -5, 13, 7.5, 18, true, 4.5, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kRequest,
           0,
           7 /* ENABLE */,
           {"ax0", "ax1", "ax2", "ax3"},
           {0.0, 0.0, 0.0, 0.0},
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
      Step{Op::kJogStop,
           2,
           3 /* JOG */,
           {"ax3", "ax2"},
           {-2.1400000000000001, 16.690000000000001},
           0.0,
           0.0,
           0,
           0,
           0,
           1,
           5 /* ESTOP */,
           0 /* ? */,
           {},
           {},
           0,
           0},
      Step{Op::kRequest, 0, 7 /* ENABLE */, {"ax2"}, {0.0}, 0.0, 0.0, 0, 0, 0, 0, 0 /* ? */, 0 /* ? */, {}, {}, 0, 0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// Soak seed 7167: a UIM242 (533.33 counts/u) set to its upper limit 43 u stands at 22933 counts,
// a third of a count inside 22933.33; a jog toward the limit was accepted, the gateway's watch
// stopped it at once, but the stop reached the drive over the serial line after the jog's speed
// and the axis ended at 22935. Now a jog with less than one whole count to go is REJECTED, and a
// UIM242 jog is a position move onto the last count inside the limit: from one count away at full
// speed it ends inside the limit, however late the stop comes.
TEST(RandomLabRegression, Seed7167Uim242JogNextToItsLimitNeverPassesIt) {
  LabSpec spec;
  spec.can_bitrate = 125000;
  spec.rs485_baud = 9600;
  spec.rs232_baud = 19200;
  spec.rs485_parity = "none";
  spec.axes.push_back(
      AxisSpec{"ax2", DriveSpec{"uim242", "rs232", 125, 0}, 533.33333333333337, -4, 43, 21, 145, false, 0, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kRequest, 0, 7 /* ENABLE */, {"ax2"}, {0.0}, 0.0, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kRequest, 2, 13 /* SET_POSITION */, {"ax2"}, {43.0}, 0.0, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kJogStop, 0, 3 /* JOG */, {"ax2"}, {6.04}, 0.0, 0.0, 0, 0, 0, 2, 5 /* ESTOP */, 0, {}, {}, 0, 0},
      Step{Op::kRequest, 0, 7 /* ENABLE */, {"ax2"}, {0.0}, 0.0, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kRequest,
           2,
           13 /* SET_POSITION */,
           {"ax2"},
           {42.9975},
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
           0},  // 22932 counts
      Step{Op::kJogStop, 1, 3 /* JOG */, {"ax2"}, {21.0}, 0.0, 0.0, 0, 0, 0, 2, 4 /* STOP */, 0, {}, {}, 0, 0},
      Step{Op::kJogStop, 1, 3 /* JOG */, {"ax2"}, {-21.0}, 0.0, 0.0, 0, 0, 0, 2, 4 /* STOP */, 0, {}, {}, 0, 0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// Soak seed 7338 (ADAM at 9600 baud with parity odd, a UIM342, a UIM242): an ADAM jog right
// after a synchronized move in which the ADAM axis was already at its target (a sub-count relative
// step) did not stop on STOP; the coordinator e-stopped it (FAILED 12).
TEST(RandomLabRegression, Seed7338AdamJogAfterAnAtTargetMoveStopsOnStop) {
  LabSpec spec;
  spec.can_bitrate = 125000;
  spec.rs485_baud = 9600;
  spec.rs232_baud = 19200;
  spec.rs485_parity = "odd";
  spec.axes.push_back(AxisSpec{"ax0", DriveSpec{"adam-modbus", "rs485", 1, 0}, 33.333333333333336, -50, 484, 179, 630.5,
                               false, 0, 0, 0});
  spec.axes.push_back(
      AxisSpec{"ax1", DriveSpec{"uim342", "can0", 54, 126}, 533.33333333333337, -5, 22, 22.5, 92, true, 15.5, 2, -17});
  spec.axes.push_back(
      AxisSpec{"ax2", DriveSpec{"uim242", "rs232", 45, 0}, 1, -8782, 17319, 10165, 80713.5, true, -5507, 0, 0});
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
           0 /* UNKNOWN */,
           0 /* UNKNOWN */,
           {},
           {},
           0 /* none */,
           0},
      Step{Op::kJogStop,
           0,
           3 /* JOG */,
           {"ax0", "ax1"},
           {-37.5, 6.6699999999999999},
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
           0,
           1 /* MOVE_ABSOLUTE */,
           {"ax0", "ax2"},
           {85.579999999999998, -2531.5799999999999},
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
           2 /* MOVE_RELATIVE */,
           {"ax0", "ax1", "ax2"},
           {-0.012000000000000455, -5.0018750000000001, 7585.96},
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
      Step{Op::kJogStop,
           1,
           3 /* JOG */,
           {"ax0", "ax1"},
           {-31.34, -6.2199999999999998},
           0.0,
           0.0,
           0,
           0,
           0,
           1,
           4 /* STOP */,
           0 /* UNKNOWN */,
           {},
           {},
           0 /* none */,
           0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// The same cause, sharper: an ADAM drive's ramp times span the start speed to a speed register
// (ADAM manual §8.42/§8.43); after a slow move (1 rpm) a fast jog (about 100 rpm) kept the move's
// speed there, so its ramped stop took the jog's ramp time per rpm of the move: half a minute.
TEST(RandomLabRegression, AdamFastJogAfterASlowMoveStopsWithinItsRamp) {
  LabSpec spec;
  spec.rs485_baud = 19200;
  spec.axes.push_back(AxisSpec{"ax0", DriveSpec{"adam-modbus", "rs485", 1, 0}, 33.333333333333336, -50, 484, 179, 630.5,
                               false, 0, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kRequest, 0, 7 /* ENABLE */, {"ax0"}, {0.0}, 0.0, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kRequest, 0, 1 /* MOVE_ABSOLUTE */, {"ax0"}, {2.0}, 0.01, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kJogStop, 0, 3 /* JOG */, {"ax0"}, {170.0}, 0.0, 0.0, 0, 0, 0, 1, 4 /* STOP */, 0, {}, {}, 0, 0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// A UIM242 jog e-stopped, then every axis enabled: ENA ran the motor at the jog's speed again
// (the controller keeps its desired speed while disabled) and it ran on through the limits.
TEST(RandomLabRegression, Seed12Uim242JogDoesNotResumeAfterEstopAndEnable) {
  LabSpec spec;
  spec.can_bitrate = 125000;
  spec.rs485_baud = 38400;
  spec.rs232_baud = 9600;
  spec.rs485_parity = "none";
  spec.axes.push_back(
      AxisSpec{"ax1", DriveSpec{"adam-modbus", "rs485", 1, 0}, 640, -6, 22, 10.5, 57, true, 8.25, 0, 0});
  spec.axes.push_back(
      AxisSpec{"ax3", DriveSpec{"uim242", "rs232", 94, 0}, 1, -5103, 21734, 11272, 49960.5, false, 0, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kRequest, 0, 7 /* ENABLE */, {"ax1", "ax3"}, {0.0, 0.0}, 0.0, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kJogStop,
           0,
           3 /* JOG */,
           {"ax3", "ax1"},
           {-1166.1700000000001, 2.21},
           0.0,
           0.0,
           0,
           0,
           0,
           2,
           5 /* ESTOP */,
           0,
           {},
           {},
           0,
           0},
      Step{Op::kRequest, 0, 7 /* ENABLE */, {"ax1", "ax3"}, {0.0, 0.0}, 0.0, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// A UC57 one count below its upper limit jogs toward it: the gateway's jog watch stops it before
// the limit. It watched the jog only from the jog's reply, by when the drive ran at full speed
// (it ended 98 counts beyond the limit); the watch now starts when the jog is handed to the driver,
// and the jog fails naming the limit (FAILED 15).
TEST(RandomLabRegression, Uc57JogStartedNextToItsLimitStopsBeforeIt) {
  LabSpec spec;
  spec.can_bitrate = 125000;
  spec.axes.push_back(AxisSpec{"ax0", DriveSpec{"uc57", "can0", 111, 0}, 12.5, -118, 482, 216.5, 767.5, true, 0, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kRequest, 0, 7 /* ENABLE */, {"ax0"}, {0.0}, 0.0, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kRequest, 0, 1 /* MOVE_ABSOLUTE */, {"ax0"}, {481.92}, 0.0, 0.0, 0, 0, 0, 0, 0, 0, {}, {}, 0, 0},
      Step{Op::kJogStop, 2, 3 /* JOG */, {"ax0"}, {54.14}, 0.0, 0.0, 0, 0, 0, 0, 5 /* ESTOP */, 0, {}, {}, 0, 0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

// A slow UC57 move to its upper limit (6 u), halted 140 ms after its start, ran on for 2.1 s and
// ended 309 counts past the limit.
TEST(RandomLabRegression, Seed7085Uc57HaltNeverPassesTheTarget) {
  LabSpec spec;
  spec.can_bitrate = 125000;
  spec.rs485_baud = 19200;
  spec.rs232_baud = 115200;
  spec.rs485_parity = "odd";
  spec.axes.push_back(
      AxisSpec{"ax0", DriveSpec{"adam-modbus", "rs485", 64, 0}, 12.5, -188, 1879, 742.5, 5702.5, false, 0, 0, 0});
  spec.axes.push_back(AxisSpec{"ax1", DriveSpec{"uim342", "can0", 37, 109}, 8.8888888888888893, -919, 2147, 1086.5,
                               2931.5, false, 0, 0, 0});
  spec.axes.push_back(AxisSpec{"ax2", DriveSpec{"uc57", "can0", 85, 0}, 320, -4, 6, 8.5, 27, true, -0.5, 0, 0});
  spec.axes.push_back(AxisSpec{"ax3", DriveSpec{"adam-modbus", "rs485", 55, 0}, 33.333333333333336, -248, 508, 323.5,
                               672, true, 499.75, 0, 0});
  const std::vector<Step> steps = {
      Step{Op::kRequest,
           0,
           7 /* ENABLE */,
           {"ax0", "ax1", "ax2", "ax3"},
           {0.0, 0.0, 0.0, 0.0},
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
           0 /* none */,
           0},
      Step{Op::kConflict,
           2,
           1 /* MOVE_ABSOLUTE */,
           {"ax1", "ax3"},
           {2147.0, 508.0},
           0.11700000000000001,
           0.0,
           120000,
           0,
           0,
           0,
           5 /* ESTOP */,
           13 /* SET_POSITION */,
           {"ax1"},
           {-0.11249999999999999},
           0 /* none */,
           0},
      Step{Op::kConflict,
           2,
           1 /* MOVE_ABSOLUTE */,
           {"ax2", "ax3"},
           {6.0, 508.0},
           0.10300000000000001,
           0.0,
           120000,
           0,
           0,
           0,
           4 /* STOP */,
           1 /* MOVE_ABSOLUTE */,
           {"ax2"},
           {5.21},
           0 /* none */,
           0},
      Step{Op::kConflict,
           1,
           1 /* MOVE_ABSOLUTE */,
           {"ax2", "ax0"},
           {6.0, 1879.0},
           0.13300000000000001,
           0.0,
           120000,
           0,
           0,
           2,
           4 /* STOP */,
           13 /* SET_POSITION */,
           {"ax2"},
           {-0.0031250000000000002},
           0 /* none */,
           0},
  };
  const auto result = run_case(spec, steps);
  EXPECT_TRUE(result.ok) << result.failure << "\n" << result.log;
}

}  // namespace
}  // namespace motion::random_lab
