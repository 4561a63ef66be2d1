#include "motion/config/setup_schema.hpp"

namespace motion::config {
namespace {

const std::vector<long long> kMicrostepsUim = {1, 2, 4, 8, 16, 32, 64};

// UIM342: MT (driver), IC (initial configuration), QE (encoder) of SimpleCAN 3.0 §5.2, §5.7, §5.9.
const std::vector<SetupKey> kUim342 = {
    {"micro_steps",
     SetupType::kInt,
     1,
     64,
     kMicrostepsUim,
     {},
     "MT[0] micro-stepping resolution (manual §5.9: 1..64 in powers of two)"},
    {"current_a",
     SetupType::kNumber,
     0.5,
     8.0,
     {},
     {},
     "MT[1] working current, amperes (manual §5.9: 5..80 tenths = 0.5..8.0 A)"},
    {"idle_current_percent", SetupType::kInt, 0, 100, {}, {}, "MT[2] standby current, % of working current"},
    {"auto_enable", SetupType::kBool, 0, 0, {}, {}, "IC[0] driver on at power-up"},
    {"direction", SetupType::kChoice, 0, 0, {}, {"cw", "ccw"}, "IC[1] direction in which the counter increases"},
    {"acceleration_unit", SetupType::kChoice, 0, 0, {}, {"rate", "time"}, "IC[4] AC/DC as pulse/s^2 or ms"},
    {"closed_loop", SetupType::kBool, 0, 0, {}, {}, "IC[6] encoder feedback control"},
    {"software_limits", SetupType::kBool, 0, 0, {}, {}, "IC[7] software position limits"},
    {"encoder_resolution", SetupType::kInt, 0, 65535, {}, {}, "QE[0] encoder lines per revolution"},
    {"stall_tolerance", SetupType::kInt, 0, 65535, {}, {}, "QE[1] stall detection tolerance, counts"},
    {"cut_in_speed", SetupType::kInt, 0, 100000, {}, {}, "SS cut-in (start/stop) speed, pulse/s"},
    {"stop_deceleration", SetupType::kInt, 0, 2000000000, {}, {}, "SD stop deceleration"},
    {"backlash", SetupType::kInt, 0, 65535, {}, {}, "BL backlash compensation, pulses"},
};

// UC57 (CANopen): manufacturer objects of the UC57 manual, written by SDO and read back. 2006h takes
// one of 16 resolutions (manual §5.1), so micro_steps (× 200 full steps) and pulses_per_revolution
// are lists, not ranges; 2005h takes 1..25 tenths of an ampere RMS (§5.1).
const std::vector<SetupKey> kUc57 = {
    {"micro_steps",
     SetupType::kInt,
     1,
     200,
     {1, 2, 4, 5, 8, 10, 16, 20, 25, 32, 40, 50, 64, 100, 128, 200},
     {},
     "2006h micro-stepping resolution (micro-steps per full step)"},
    {"current_a", SetupType::kNumber, 0.1, 2.5, {}, {}, "2005h run current, amperes RMS (0.1 A steps)"},
    {"pulses_per_revolution",
     SetupType::kInt,
     200,
     40000,
     {200, 400, 800, 1000, 1600, 2000, 3200, 4000, 5000, 6400, 8000, 10000, 12800, 20000, 25600, 40000},
     {},
     "2006h pulses per motor revolution"},
    {"closed_loop", SetupType::kBool, 0, 0, {}, {}, "encoder feedback control"},
    {"tpdo_mode",
     SetupType::kChoice,
     0,
     0,
     {},
     {"sync", "staggered", "event"},
     "axis state from TPDOs at every SYNC, at every G-th SYNC in a slot of the node's own, or event-driven"},
    {"heartbeat_ms", SetupType::kInt, 0, 65535, {}, {}, "producer heartbeat time (1017h)"},
    {"rpdo_sync",
     SetupType::kChoice,
     0,
     0,
     {},
     {"detect", "honoured", "on_reception"},
     "whether the drive applies a synchronous RPDO at the SYNC (honoured) or on reception; detect: set-up tests it "
     "(the answer is used only where the test cannot run)"},
};

// ADAM Modbus RTU steppers: holding registers of the manual, written and read back.
const std::vector<SetupKey> kAdamModbus = {
    {"subdivision", SetupType::kInt, 1, 256, {}, {}, "micro-steps per full step (0x0024 = 200 × subdivision)"},
    {"current_a",
     SetupType::kNumber,
     0.1,
     6.5,
     {},
     {},
     "0x000D rated current, amperes (manual §8.10: 10..650 × 0.01 A)"},
    {"pulses_per_revolution",
     SetupType::kInt,
     200,
     1000000,
     {},
     {},
     "0x0024 pulses per motor revolution (manual §8.29)"},
    {"closed_loop", SetupType::kBool, 0, 0, {}, {}, "encoder feedback control"},
    {"table_save",
     SetupType::kBool,
     0,
     0,
     {},
     {},
     "Save (0x00DC) after loading a move's table entry (manual §8.54 step 2; default true: one 0.1 s flash erase per "
     "move, §8.69)"},
};

// UIM242 through a UIM2501/2502 gateway: MCS/CUR/ICFG/MCFG/ENC/STL instructions.
const std::vector<SetupKey> kUim242 = {
    {"micro_steps", SetupType::kInt, 1, 16, {1, 2, 4, 8, 16}, {}, "MCS micro-stepping"},
    {"current_a",
     SetupType::kNumber,
     0.1,
     8.0,
     {},
     {},
     "CUR phase current, amperes (0..80 tenths; the model's own range applies)"},
    {"icfg", SetupType::kInt, 0, 65535, {}, {}, "ICFG initial configuration bits"},
    {"mcfg", SetupType::kInt, 0, 65535, {}, {}, "MCFG motion configuration bits (RTCN enables)"},
    {"encoder_lines", SetupType::kInt, 0, 65535, {}, {}, "ENC encoder lines"},
    {"stall_tolerance", SetupType::kInt, 0, 65535, {}, {}, "STL stall tolerance"},
    {"spd0_position_move",
     SetupType::kChoice,
     0,
     0,
     {},
     {"detect", "holds", "runs_at_last_speed", "refused"},
     "what the controller does with a position move (STP) loaded at desired speed 0; detect: the first move tests "
     "it (one count); anything but holds: moves start with a 1 pps crawl (docs/protocols.md, UIM242 #3)"},
};

}  // namespace

std::span<const SetupKey> setup_schema(Family family) {
  switch (family) {
    case Family::kUim342: return kUim342;
    case Family::kUc57: return kUc57;
    case Family::kAdamModbus: return kAdamModbus;
    case Family::kUim242: return kUim242;
  }
  return {};
}

const SetupKey* find_setup_key(Family family, std::string_view key) {
  for (const auto& k : setup_schema(family)) {
    if (k.key == key) return &k;
  }
  return nullptr;
}

}  // namespace motion::config
