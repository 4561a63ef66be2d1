// Power-up parameters of a simulated UIM342 from the configuration: the drive's `setup:` keys
// (services/config setup_schema, family uim342) are what the drive's EEPROM holds, so a
// simulated drive starts as a configured real one would; its identity (ML, SN, PP[5]) is derived.
#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <variant>

#include "motion/config/sim_variants.hpp"
#include "motion/sim/uim342_drive.hpp"
#include "motion/uim342/parameters.hpp"
#include "uim342_setup.hpp"

namespace motion::sim {
namespace {

namespace u = uim342;

std::uint16_t word(double value) { return static_cast<std::uint16_t>(std::clamp(std::lround(value), 0L, 65535L)); }
std::uint32_t dword(double value) {
  return static_cast<std::uint32_t>(std::clamp(std::llround(value), 0LL, 0xFFFFFFFFLL));
}
template <typename E>
std::size_t at(E e) {
  return static_cast<std::size_t>(e);
}

// One set-up key: how it lands in the parameters (numbers already converted; choices by text).
struct SetupRule {
  std::string_view key;
  void (*apply)(Uim342Drive::Parameters& p, double value, std::string_view text);
};

constexpr SetupRule kRules[] = {
    {"micro_steps",
     [](Uim342Drive::Parameters& p, double v, std::string_view) {
       p.driver[at(u::MotorDriver::kMicrostepping)] = word(v);
       // CPR follows the micro-steps (§3.5): QE[4] = micro-steps x 200.
       p.encoder[at(u::QuadratureEncoder::kCountsPerRevolution)] = word(v * u::kFullStepsPerRevolution);
     }},
    {"current_a", [](Uim342Drive::Parameters& p, double v,
                     std::string_view) { p.driver[at(u::MotorDriver::kWorkingCurrent)] = word(v * 10.0); }},
    {"idle_current_percent", [](Uim342Drive::Parameters& p, double v,
                                std::string_view) { p.driver[at(u::MotorDriver::kIdleCurrentPercent)] = word(v); }},
    {"auto_enable", [](Uim342Drive::Parameters& p, double v,
                       std::string_view) { p.initial_config[at(u::InitialConfig::kAutoDriverOn)] = word(v); }},
    {"direction",
     [](Uim342Drive::Parameters& p, double, std::string_view t) {
       p.initial_config[at(u::InitialConfig::kPositiveDirection)] = t == "ccw" ? 1 : 0;
     }},
    {"acceleration_unit",
     [](Uim342Drive::Parameters& p, double, std::string_view t) {
       p.initial_config[at(u::InitialConfig::kAccelerationUnit)] = t == "time" ? 1 : 0;
     }},
    {"closed_loop", [](Uim342Drive::Parameters& p, double v,
                       std::string_view) { p.initial_config[at(u::InitialConfig::kClosedLoop)] = word(v); }},
    {"software_limits", [](Uim342Drive::Parameters& p, double v,
                           std::string_view) { p.initial_config[at(u::InitialConfig::kSoftwareLimits)] = word(v); }},
    {"encoder_resolution",
     [](Uim342Drive::Parameters& p, double v, std::string_view) {
       p.encoder[at(u::QuadratureEncoder::kLinesPerRevolution)] = word(v);
     }},
    {"stall_tolerance", [](Uim342Drive::Parameters& p, double v,
                           std::string_view) { p.encoder[at(u::QuadratureEncoder::kStallTolerance)] = word(v); }},
    {"cut_in_speed", [](Uim342Drive::Parameters& p, double v, std::string_view) { p.cut_in_speed = dword(v); }},
    {"stop_deceleration",
     [](Uim342Drive::Parameters& p, double v, std::string_view) { p.stop_deceleration = dword(v); }},
    {"backlash", [](Uim342Drive::Parameters& p, double v, std::string_view) { p.backlash = dword(v); }},
};

// §5.4 model bytes of the UIM342C variants; d1 is the peak current in 0.1 A.
constexpr std::array<std::array<std::uint8_t, 4>, 3> kCModels{
    {{0x22, 0x14, 0x13, 0x00}, {0x22, 0x28, 0x13, 0x00}, {0x22, 0x50, 0x13, 0x00}}};

}  // namespace

Uim342Drive::Parameters setup_parameters(const config::Drive& drive, const Uim342Identity& identity) {
  Uim342Drive::Parameters p;
  p.bit_rate_code = identity.bit_rate_code;
  p.node_id = static_cast<std::uint8_t>(drive.node_id);
  p.group_id = static_cast<std::uint8_t>(drive.group_id);
  // IL default: no action, wait for a real edge (manual §5.26: bytes 0x80/0x80).
  for (std::size_t port = 0; port < p.input_logic.size(); ++port) {
    p.input_logic[port] = u::InputActions{static_cast<std::uint8_t>(port), {}, {}};
  }
  for (const auto& rule : kRules) {
    if (!drive.setup.contains(std::string(rule.key))) continue;
    const auto text = drive.setup_text(rule.key);
    rule.apply(p, drive.setup_number(rule.key).value_or(0.0), text ? std::string_view(*text) : std::string_view{});
  }
  return p;
}

Uim342Identity uim342_identity(const config::Drive& drive, int bus_bitrate) {
  Uim342Identity identity;
  double current = 2.0;
  current = drive.setup_number("current_a").value_or(current);
  identity.model_bytes = kCModels.back();
  for (const auto& model : kCModels) {
    if (model[1] >= std::lround(current * 10.0)) {
      identity.model_bytes = model;
      break;
    }
  }
  // Distinct per node so that a bus scan can tell drives apart.
  identity.serial = 0x03420000U + static_cast<std::uint32_t>(drive.node_id);
  for (std::uint8_t code = 0; code <= static_cast<std::uint8_t>(u::BitRate::kKbps125); ++code) {
    if (u::bits_per_second(static_cast<u::BitRate>(code)) == static_cast<std::uint32_t>(bus_bitrate))
      identity.bit_rate_code = code;
  }
  return identity;
}

std::optional<Uim342HomeSwitch> uim342_home_switch(const config::Config& config, const config::Drive& drive) {
  return home_switch(config, drive);
}

CanDriveFactory uim342_factory(const config::Config& config) {
  std::map<std::string, int> bitrates;
  for (const auto& bus : config.buses) bitrates[bus.name] = bus.bitrate;
  std::map<std::string, std::optional<Uim342HomeSwitch>> switches;
  std::map<std::string, std::string> variants;
  for (const auto& d : config.drives) {
    switches[d.name] = uim342_home_switch(config, d);
    variants[d.name] = config::sim_variant(config, d, "micro_steps_apply");
  }
  return [bitrates, switches, variants](const config::Drive& drive,
                                        SimDriveContext context) -> std::unique_ptr<CanDriveSim> {
    const auto bus = bitrates.find(drive.bus);
    const auto identity = uim342_identity(drive, bus == bitrates.end() ? 0 : bus->second);
    const auto sw = switches.find(drive.name);
    const auto apply =
        variants.at(drive.name) == "immediately" ? MicroStepsApply::kImmediately : MicroStepsApply::kAfterRestart;
    return std::make_unique<Uim342Drive>(drive, std::move(context), identity,
                                         sw == switches.end() ? std::nullopt : sw->second, apply);
  };
}

}  // namespace motion::sim
