#include "motion/drive_model/drive_model.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "motion/adam/rtu.hpp"
#include "motion/adam/table.hpp"
#include "motion/adam/units.hpp"
#include "motion/can_frame/bit_timing.hpp"
#include "motion/canopen/cob_id.hpp"
#include "motion/canopen/sync.hpp"
#include "motion/cia402/uc57_od.hpp"
#include "motion/cia402/uc57_units.hpp"
#include "motion/gateway/serial_line.hpp"
#include "motion/uim242/feedback.hpp"
#include "motion/uim242/instruction.hpp"
#include "motion/uim342/instructions.hpp"
#include "motion/uim342/parameters.hpp"

namespace motion::drive_model {
namespace {

using Model = motionlcm::drive_model_t;
using ModelOrError = std::variant<Model, std::string>;

// Every family's position registers are 32-bit signed (UIM342 PA, UC57 607Ah, ADAM table
// targets, UIM242 POS).
constexpr std::int64_t kPositionMin = std::numeric_limits<std::int32_t>::min();
constexpr std::int64_t kPositionMax = std::numeric_limits<std::int32_t>::max();

double micros(Duration d) { return std::chrono::duration<double, std::micro>(d).count(); }

void add_start(Model& m, std::int8_t kind, std::int32_t address, double wire_us) {
  m.start_kinds.push_back(kind);
  m.start_addresses.push_back(address);
  m.start_wire_us.push_back(wire_us);
  m.num_starts = static_cast<std::int32_t>(m.start_kinds.size());
}

void rate(Model& m, double step, std::int64_t min, std::int64_t max) {
  m.acceleration_kind = Model::ACCEL_RATE;
  m.acceleration_step = step;
  m.acceleration_min = min;
  m.acceleration_max = max;
  m.ramp_from = 0;
}

void ramp_time(Model& m, double seconds_per_step, double from, std::int64_t min, std::int64_t max) {
  m.acceleration_kind = Model::ACCEL_RAMP_TIME;
  m.acceleration_step = seconds_per_step;
  m.acceleration_min = min;
  m.acceleration_max = max;
  m.ramp_from = from;
}

std::optional<std::string> uim342(Model& m, const config::Drive& drive, const config::Bus& bus) {
  namespace u = uim342;
  const bool time = drive.setup_text("acceleration_unit").value_or("rate") == "time";
  const auto unit = time ? u::AccelerationUnit::kMilliseconds : u::AccelerationUnit::kPulsesPerS2;
  const auto speed = u::value_range(u::FunctionCode::kSP);
  const auto ramp = u::value_range(u::FunctionCode::kAC, 0, unit);
  if (!speed || !ramp) return std::string("the UIM342 parameter table lacks SP/AC");
  m.grid = time ? "uim342 pps+ramp ms" : "uim342 pps+pps/s";
  // SP is 1 pulse/s per step (manual §5.19).
  m.velocity_step = 1.0;
  m.velocity_min = 1;
  m.velocity_max = speed->max;
  if (time) {
    const double cut_in = static_cast<double>(drive.setup_integer("cut_in_speed").value_or(0));
    // acceleration_from_wire(1 ms) over a 1 pulse/s change = 1 / seconds per step.
    ramp_time(m, 1.0 / u::acceleration_from_wire(1, unit, cut_in + 1.0, cut_in), cut_in, ramp->min, ramp->max);
  } else {
    rate(m, u::acceleration_from_wire(1, unit), ramp->min, ramp->max);
  }
  // BG (manual §5.11) to the group id, which every member accepts (§1, CAN IDs), and to the drive
  // alone: a move that holds only part of the group starts its members one BG each.
  const auto bg = [&](int target, std::int8_t kind) -> std::optional<std::string> {
    const auto frame = u::instruction_frame(static_cast<std::uint8_t>(target), u::request::begin());
    if (!frame.ok()) return "no BG frame to " + std::to_string(target);
    add_start(m, kind, target, micros(can::frame_duration(*frame, static_cast<std::uint32_t>(bus.bitrate))));
    return std::nullopt;
  };
  if (drive.group_id != 0) {
    if (auto why = bg(drive.group_id, Model::START_UIM342_GROUP_BG)) return why;
  }
  return bg(drive.node_id, Model::START_SINGLE);
}

std::optional<std::string> uc57(Model& m, const config::Drive& drive, const config::Bus& bus,
                                const gateway::DriveFacts& facts) {
  namespace od = cia402::uc57;
  const std::uint32_t assumed = assumed_pulses_per_revolution(drive);
  const std::uint32_t ppr = facts.counts_per_revolution.value_or(assumed);
  m.resolution_source = facts.counts_per_revolution ? Model::RESOLUTION_READ_BACK : Model::RESOLUTION_CONFIGURED;
  m.counts_per_revolution = static_cast<std::int32_t>(ppr);
  m.assumed_counts_per_revolution = static_cast<std::int32_t>(assumed);
  if (ppr == 0) return "drive " + drive.name + ": its set-up gives no UC57 resolution (2006h)";
  const auto* velocity = od::find_entry(od::index::kProfileVelocity, 0);
  const auto* acceleration = od::find_entry(od::index::kProfileAcceleration, 0);
  const auto* deceleration = od::find_entry(od::index::kProfileDeceleration, 0);
  const auto* start_speed = od::find_entry(od::index::kStartSpeed, 0);
  if (velocity == nullptr || acceleration == nullptr || deceleration == nullptr || start_speed == nullptr) {
    return std::string("UC57 object dictionary lacks 6081h/6083h/6084h/200Eh");
  }
  m.grid = "uc57 rpm+ramp ms";
  m.velocity_step = od::rpm_to_pulses_per_second(1.0, ppr);
  m.velocity_min = velocity->min;
  m.velocity_max = velocity->max;
  // The rate of a 1 ms ramp over a 1 pulse/s change is 1 / (seconds per ramp step).
  const double start_rpm = facts.start_speed_rpm.value_or(static_cast<double>(start_speed->default_value));
  ramp_time(m, 1.0 / od::ramp_acceleration(od::RampUnit::kMilliseconds, 1, 1.0, ppr),
            od::rpm_to_pulses_per_second(start_rpm, ppr), std::max(acceleration->min, deceleration->min),
            std::min(acceleration->max, deceleration->max));
  if (facts.one_frame_start == false) {
    // The drive applies RPDO1 on reception (or refused transmission type 1): its own RPDO1
    // starts it (CiA 301 §7.2.2; docs/protocols.md UC57 #1). Wire time of the longer RPDO1
    // layout (the manual's default 1600h: 6040h + 60FFh + 6060h, 7 bytes), zero data.
    const std::array<std::uint8_t, 7> data{};
    const auto rpdo =
        can::Frame::make(canopen::rpdo_cob_id(1, static_cast<canopen::NodeId>(drive.node_id)), false, data);
    if (!rpdo) return "drive " + drive.name + ": no RPDO1 frame for node " + std::to_string(drive.node_id);
    add_start(m, Model::START_SINGLE, drive.node_id,
              micros(can::frame_duration(*rpdo, static_cast<std::uint32_t>(bus.bitrate))));
    return std::nullopt;
  }
  add_start(m, Model::START_CANOPEN_SYNC, static_cast<std::int32_t>(canopen::kSyncCobId),
            micros(can::frame_duration(canopen::encode_sync({}), static_cast<std::uint32_t>(bus.bitrate))));
  return std::nullopt;
}

std::optional<std::string> adam(Model& m, const config::Drive& drive, const config::Bus& bus) {
  const std::uint32_t ppr = assumed_pulses_per_revolution(drive);
  m.resolution_source = Model::RESOLUTION_CONFIGURED;
  m.counts_per_revolution = static_cast<std::int32_t>(ppr);
  m.assumed_counts_per_revolution = static_cast<std::int32_t>(ppr);
  if (!adam::check_subdivision(ppr)) {
    return "drive " + drive.name + ": subdivision " + std::to_string(ppr) +
           " pulses/rev is outside what the ADAM drive accepts";
  }
  // Whole rpm up to 1000: a table entry's speed goes to 0x009A (§8.44, whole rpm 0…1000) and to
  // 0x00D8 (§8.64, 0.01 rpm); the manual does not say which one a table entry runs at
  // (docs/protocols.md), so the plan must fit both.
  m.grid = "adam 1 rpm+ramp ms";
  m.velocity_step = static_cast<double>(ppr) / 60.0;
  m.velocity_min = 1;
  m.velocity_max = 1000;
  ramp_time(m, adam::kRampSecondsPerStep, 0.0, 1, adam::kMaxRampMs);
  const auto request = adam::table_execute_broadcast();
  const auto bytes =
      request.ok() ? adam::rtu::encode_request(*request) : Result<std::vector<std::uint8_t>>{request.error()};
  if (!bytes.ok()) return std::string("no ADAM table-execute broadcast frame");
  add_start(m, Model::START_ADAM_BROADCAST, adam::rtu::kBroadcastUnit,
            micros(gateway::serial_line_settings(bus).wire_time(bytes->size())));
  return std::nullopt;
}

// The line time of arming an ADAM axis as the stack does it (adam_stack.hpp, ARM_MOVE): the
// working speed 0x009A, the preload (profile, table entry 0, §8.54) and, with setup table_save
// (default true), a Save with its flash erase (§8.69); each other drive of the line gets its entry
// 0 at its own position (and a Save) so that the broadcast start moves it nowhere. Frame lengths
// do not depend on the values, so any valid ones stand in.
std::optional<std::string> adam_arming(motionlcm::arm_timing_t& t, const config::Drive& drive, const config::Bus& bus) {
  adam::rtu::SerialFormat format;
  format.baud = static_cast<std::uint32_t>(bus.baud);
  format.parity = bus.parity == 'E'   ? adam::rtu::Parity::kEven
                  : bus.parity == 'O' ? adam::rtu::Parity::kOdd
                                      : adam::rtu::Parity::kNone;
  format.stop_bits = static_cast<std::uint8_t>(bus.stop_bits);
  const auto unit = static_cast<std::uint8_t>(drive.node_id);
  const bool save = drive.setup_flag("table_save").value_or(true);
  const auto line_us = [&](std::vector<adam::rtu::Request> requests) {
    if (save) requests.push_back(adam::command(unit, adam::SaveCommand::kSave));
    double us = 0;
    for (const auto& r : requests) us += micros(adam::transaction_time(format, r));
    return us;
  };
  adam::SyncMovePreload preload;
  auto own = adam::sync_move_preload(unit, preload);
  auto bystander = adam::single_entry_writes(unit, preload.start_offset, 0);
  if (!own || !bystander) return "drive " + drive.name + ": no ADAM preload frames";
  own.value().push_back(adam::write16(unit, adam::Reg::kWorkingSpeed, 1));
  t.arm_line_us = line_us(std::move(own.value()));
  t.arm_bystander_us = line_us(std::move(bystander.value()));
  return std::nullopt;
}

// The line time of a UIM242 crawl as Uim242Stack::start_move sends it: `ADR η;` (the axis is
// another controller than the last one addressed), `SPD -1;` and `STP n;` at the longest n, each
// with its answer (the request channel sends the next instruction after the answer).
std::optional<double> uim242_crawl_us(const config::Drive& drive, const serial::SerialSettings& line) {
  const std::int64_t node = drive.node_id;
  const std::vector<uim242::Instruction> crawl{
      {uim242::Mnemonic::kADR, false, node, false},
      {uim242::Mnemonic::kSPD, false, -1, false},
      {uim242::Mnemonic::kSTP, false, uim242::spec(uim242::Mnemonic::kSTP).min, false}};
  double us = 0;
  for (const auto& in : crawl) {
    const auto bytes = uim242::encode(in);
    if (!bytes.ok()) return std::nullopt;
    const auto form = uim242::reply_form(in);
    // header, id, [message id], data, terminator (EN/CN §12.2)
    const std::size_t reply = 3 + (form.message_id ? 1 : 0) + uim242::data_length(form.layout);
    us += micros(line.wire_time(bytes->size())) + micros(line.wire_time(reply));
  }
  return us;
}

std::optional<std::string> uim242(Model& m, const config::Drive& drive, const config::Bus& bus,
                                  const gateway::DriveFacts& facts) {
  const auto& speed = uim242::spec(uim242::Mnemonic::kSPD);
  const auto& acceleration = uim242::spec(uim242::Mnemonic::kMAC);
  const auto& deceleration = uim242::spec(uim242::Mnemonic::kMDE);
  m.grid = "uim242 pps+pps/s";
  m.velocity_step = 1.0;
  m.velocity_min = 1;
  m.velocity_max = speed.max;
  rate(m, 1.0, std::max(acceleration.min, deceleration.min), std::min(acceleration.max, deceleration.max));
  const auto global = uim242::encode_global(uim242::Mnemonic::kSPD, speed.max);
  const auto single = uim242::encode_set(uim242::Mnemonic::kSPD, speed.max);
  if (!global.ok() || !single.ok()) return std::string("no UIM242 SPD instruction");
  const auto line = gateway::serial_line_settings(bus);
  add_start(m, Model::START_UIM242_GLOBAL, 0, micros(line.wire_time(global->size())));
  add_start(m, Model::START_SINGLE, 0, micros(line.wire_time(single->size())));
  if (facts.crawl_start) {
    const auto crawl = uim242_crawl_us(drive, line);
    if (!crawl) return std::string("no UIM242 crawl instructions");
    add_start(m, Model::START_UIM242_CRAWL, drive.node_id, *crawl);
  }
  return std::nullopt;
}

}  // namespace

std::uint32_t assumed_pulses_per_revolution(const config::Drive& drive) {
  switch (drive.family) {
    case config::Family::kAdamModbus: {
      const auto pulses = adam::setup_pulses_per_revolution(drive.setup_integer("pulses_per_revolution"),
                                                            drive.setup_integer("subdivision"));
      if (!pulses) return adam::kDefaultSubdivision;
      return *pulses > 0 && *pulses <= std::numeric_limits<std::uint32_t>::max() ? static_cast<std::uint32_t>(*pulses)
                                                                                 : 0;
    }
    case config::Family::kUc57: {
      // The gateway's own rule (2006h code from the set-up); no code: the drive keeps its factory one.
      const auto setup = cia402::uc57::setup_subdivision(drive.setup_integer("pulses_per_revolution"),
                                                         drive.setup_integer("micro_steps"));
      if (setup.status != cia402::uc57::SetupSubdivision::Status::kCode) {
        return drive.setup.contains("pulses_per_revolution") || drive.setup.contains("micro_steps")
                   ? 0
                   : cia402::uc57::kDefaultPulsesPerRevolution;
      }
      return cia402::uc57::pulses_per_revolution(setup.code).value_or(0);
    }
    default: return 0;
  }
}

ModelOrError build(const config::Config& config, const config::Axis& axis, const gateway::DriveFacts& facts) {
  const config::Drive* drive = config.drive_of(axis);
  if (drive == nullptr) return "axis " + axis.name + " has no drive";
  const config::Bus* bus = config.find_bus(drive->bus);
  if (bus == nullptr) return "drive " + drive->name + " is on no configured bus";
  Model m{};
  m.bus = bus->name;
  m.axis = axis.name;
  m.drive = drive->name;
  m.family = std::string(config::to_string(drive->family));
  m.node_id = drive->node_id;
  m.group_id = drive->group_id;
  m.resolution_source = Model::RESOLUTION_UNKNOWN;
  m.counts_per_unit = axis.steps_per_unit;
  m.firmware = facts.firmware;
  m.position_min = kPositionMin;
  m.position_max = kPositionMax;
  std::optional<std::string> why;
  switch (drive->family) {
    case config::Family::kUim342: why = uim342(m, *drive, *bus); break;
    case config::Family::kUc57: why = uc57(m, *drive, *bus, facts); break;
    case config::Family::kAdamModbus: why = adam(m, *drive, *bus); break;
    case config::Family::kUim242: why = uim242(m, *drive, *bus, facts); break;
  }
  if (why) return "axis " + axis.name + ": " + *why;
  if (m.grid.empty()) return "drive " + drive->name + ": unknown drive family";
  return m;
}

std::variant<motionlcm::arm_timing_t, std::string> arming(const config::Config& config, const config::Axis& axis) {
  const config::Drive* drive = config.drive_of(axis);
  if (drive == nullptr) return "axis " + axis.name + " has no drive";
  const config::Bus* bus = config.find_bus(drive->bus);
  if (bus == nullptr) return "drive " + drive->name + " is on no configured bus";
  motionlcm::arm_timing_t t{};
  t.bus = bus->name;
  t.axis = axis.name;
  t.drive = drive->name;
  if (drive->family == config::Family::kAdamModbus) {
    if (auto why = adam_arming(t, *drive, *bus)) return "axis " + axis.name + ": " + *why;
  }
  return t;
}

}  // namespace motion::drive_model
