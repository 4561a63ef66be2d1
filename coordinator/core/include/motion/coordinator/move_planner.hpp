// The coordinator's MovePlanner for a configuration: the synchronized planner (motion::planner)
// with one quantizer per DRIVE, built from its family and set-up so that the realized values the
// planner predicts are exactly what that drive's gateway stack programs (the gateway re-quantizes
// the realized values it receives and lands on the same integers). Units and ranges come from the
// family codecs, never re-typed:
//   UIM342  SP integer pulse/s (uim342::value_range SP); AC/DC (uim342::acceleration_to_wire):
//           IC[4] rate = integer pulse/s^2, or IC[4] time = integer ms ramping from `cut_in_speed`
//           (pulse/s) to SP; the unit is the set-up's `acceleration_unit` (default rate, as the
//           stack's).
//   UC57    6081h profile velocity integer rpm at the node's pulses/rev (the gateway's set-up rule,
//           cia402::uc57::setup_subdivision: pulses_per_revolution or micro_steps x 200 -> 2006h,
//           else the drive's factory 10000),
//           range from the object dictionary; 6083h/6084h ramp time integer ms from the start
//           speed 200Eh (factory default from the OD, which the gateway does not change) to the
//           speed (conflict C-02 in uc57_units.hpp).
//   ADAM    0x00D8 target speed in 0.01 rpm at the drive's pulses/rev (adam::setup_pulses_per_revolution,
//           else the factory kDefaultSubdivision); 0x0098/0x0099 ramp times in integer ms from 0
//           (the stack's start/stop speed) to the target speed.
//   UIM242  SPD integer pulse/s (1..65535), MAC/MDE integer pulse/s^2 (value mode; the ranges of
//           uim242's instruction table).
#pragma once

#include <memory>
#include <string>
#include <variant>

#include "motion/config/config.hpp"
#include "motion/coordinator/coordinator.hpp"
#include "motion/planner/quantizer.hpp"

namespace motion::coordinator {

// The quantizer of one drive of `config`, or the reason it cannot be built (e.g. a subdivision the
// drive refuses). Exposed for the tests that check it against each stack's own conversion.
[[nodiscard]] std::variant<std::shared_ptr<const planner::DriveQuantizer>, std::string> make_drive_quantizer(
    const config::Config& config, const config::Drive& drive);

// The counts per motor revolution the coordinator assumes for an ADAM / UC57 drive (0 for the
// other families): what the gateway writes at start-up, else the drive's factory value.
[[nodiscard]] std::uint32_t assumed_pulses_per_revolution(const config::Config& config, const config::Drive& drive);

[[nodiscard]] MovePlanner make_move_planner(const config::Config& config);

}  // namespace motion::coordinator
