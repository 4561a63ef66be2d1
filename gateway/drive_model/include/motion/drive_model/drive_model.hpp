// The drive model of one axis (motionlcm::drive_model_t): the grids and ranges of what its drive
// executes, its resolution, its start mechanisms with the wire time of each start frame, built
// from the family codec (units and ranges: the same functions the stack programs with), the
// configuration (set-up keys, bus bit/baud rate) and what the stack read from the drive
// (gateway::DriveFacts). Per family:
//   UIM342  SP integer pulse/s (uim342::value_range SP); AC/DC as uim342::acceleration_to_wire
//           writes them for the set-up's IC[4] (`acceleration_unit`, default rate): integer
//           pulse/s^2, or integer ms ramping from `cut_in_speed` to SP (UIM342 manual §5.13, §5.19).
//           Starts: BG to the group id (a group is configured) or to the node (manual §5.15).
//   UC57    6081h profile velocity in integer rpm at the resolution in force: 2006h as read back
//           (UC57 manual §5.1), else the set-up rule (cia402::uc57::setup_subdivision), else the
//           factory 10000; 6083h/6084h integer ms ramps from the start speed 200Eh as read (else
//           its object-dictionary default) to the speed. Start: synchronous RPDO + one SYNC
//           (CiA 301 §7.2.5); START_SINGLE (its own RPDO1)
//           instead when the stack found that the drive applies RPDO1 on reception (DriveFacts).
//   ADAM    0x00D8 target speed in 0.01 rpm at the pulses/rev of the set-up (else the factory
//           subdivision); 0x0098/0x0099 integer ms ramps from 0. Start: broadcast table execute
//           0x00DD (ADAM manual §5, §8.54).
//   UIM242  SPD integer pulse/s, MAC/MDE integer pulse/s^2 (value mode), ranges from the
//           instruction table. Start: global gSPD through the RS232-CAN gateway, else SPD per
//           controller (the wire time given is the longest global form, gSPD 65535;). A drive that
//           does not hold a move loaded at speed 0 (DriveFacts::crawl_start) also lists
//           START_UIM242_CRAWL: the line time of its crawl (ADR, SPD -1, STP n, with answers),
//           which goes out before the start it joins.
// Pure: values in, a message or the reason it cannot be made out. Thread-safe.
#pragma once

#include <cstdint>
#include <string>
#include <variant>

#include <motionlcm/arm_timing_t.hpp>
#include <motionlcm/drive_model_t.hpp>

#include "motion/config/config.hpp"
#include "motion/gateway/bus_driver.hpp"

namespace motion::drive_model {

// The counts per motor revolution the configuration implies for an ADAM / UC57 drive (0 for the
// other families): what the gateway writes at start-up, else the drive's factory value.
[[nodiscard]] std::uint32_t assumed_pulses_per_revolution(const config::Drive& drive);

// The model of `axis` (of `config`), given what its stack read from the drive. utime is left 0.
[[nodiscard]] std::variant<motionlcm::drive_model_t, std::string> build(const config::Config& config,
                                                                        const config::Axis& axis,
                                                                        const gateway::DriveFacts& facts = {});

// How long arming a move of `axis` takes on its bus (ARM_TIMING): ADAM from the frames its stack
// sends (the preload, a Save and its flash erase; each other drive's neutral table entry); 0 for
// the families whose arming is a few frames. utime is left 0.
[[nodiscard]] std::variant<motionlcm::arm_timing_t, std::string> arming(const config::Config& config,
                                                                        const config::Axis& axis);

}  // namespace motion::drive_model
