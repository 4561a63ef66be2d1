// The lab generator, the steps as text and C++, and the reference model of the randomized whole-lab
// test (step_generator.cpp makes the steps).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <sstream>

#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>
#include <motionlcm/sim_control_t.hpp>

#include "motion/client/client.hpp"
#include "motion/config/config.hpp"
#include "motion/lcm/reply_error.hpp"
#include "motion/lcm/request_kinds.hpp"
#include "motion/testing/lab_keys.hpp"
#include "random_choice.hpp"
#include "random_lab.hpp"

namespace motion::random_lab {
namespace {

using motionlcm::reply_t;
using motionlcm::request_t;

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  std::string s = buf;
  if (s.find_first_of(".einn") == std::string::npos) s += ".0";
  return s;
}

const char* kind_name(std::int8_t kind) { return lcm::request_kind_name(kind); }

std::string list(const std::vector<std::string>& v) {
  std::string out = "{";
  for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", \"" : "\"") + v[i] + "\"";
  return out + "}";
}
std::string list(const std::vector<double>& v) {
  std::string out = "{";
  for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + num(v[i]);
  return out + "}";
}

bool valid_scale(double s) { return std::isfinite(s) && s >= 0 && s <= 1; }

}  // namespace

// --------------------------------------------------------------------------- lab

const AxisSpec* LabSpec::find(const std::string& axis) const {
  for (const auto& a : axes)
    if (a.name == axis) return &a;
  return nullptr;
}

// Timeouts are generous (CAN requests 100 ms, serial 250 ms, UC57 heartbeat 250 ms, lost after
// three): the test checks behaviour, and a loaded 2-core machine (parallel builds and tests) can
// hold a simulator or gateway for a few hundred milliseconds.
// The UC57s' tpdo_mode: sync, or RANDOM_LAB_UC57_TPDO_MODE (staggered: the same seeds with
// staggered TPDOs; any other value is the configuration's to refuse).
static std::string uc57_tpdo_mode() {
  const char* mode = std::getenv("RANDOM_LAB_UC57_TPDO_MODE");
  return mode != nullptr && *mode != '\0' ? mode : "sync";
}

std::string LabSpec::yaml() const {
  std::set<std::string> buses;
  for (const auto& a : axes) buses.insert(a.drive.bus);
  std::ostringstream y;
  y << "lcm:\n  url: \"udpm://239.255.76.67:7667?ttl=0\"\n  channel_prefix: \"MOTION_\"\nbuses:\n";
  if (buses.contains("can0")) {
    y << "  - {name: can0, transport: simcan:can0, bitrate: " << can_bitrate
      << ", bus_timing: true, request_timeout_ms: 100, retries: 2, poll_hz: 20}\n";
  }
  if (buses.contains("rs485")) {
    y << "  - {name: rs485, transport: simserial:rs485, baud: " << rs485_baud << ", parity: " << rs485_parity
      << ", request_timeout_ms: 250, retries: 1, poll_hz: 10}\n";
  }
  if (buses.contains("rs232")) {
    y << "  - {name: rs232, transport: simserial:rs232, baud: " << rs232_baud
      << ", request_timeout_ms: 250, retries: 1, poll_hz: 10}\n";
  }
  y << "drives:\n";
  for (const auto& a : axes) {
    const auto& d = a.drive;
    y << "  - {name: " << a.name << "-drive, family: " << d.family << ", bus: " << d.bus << ", node_id: " << d.node_id;
    if (d.group_id != 0) y << ", group_id: " << d.group_id;
    if (d.family == "uim342") y << ", setup: {micro_steps: 16, current_a: 1.5, acceleration_unit: rate}";
    if (d.family == "uc57")
      y << ", setup: {micro_steps: 16, current_a: 2.0, tpdo_mode: " << uc57_tpdo_mode() << ", heartbeat_ms: 250}";
    if (d.family == "adam-modbus") y << ", setup: {subdivision: 16, current_a: 2.0}";
    if (d.family == "uim242") y << ", setup: {micro_steps: 16, current_a: 1.0}";
    y << "}\n";
  }
  y << "axes:\n";
  for (const auto& a : axes) {
    y << "  - {name: " << a.name << ", drive: " << a.name
      << "-drive, unit: u, steps_per_unit: " << num(a.steps_per_unit) << ", limits: {min: " << num(a.min)
      << ", max: " << num(a.max) << ", velocity: " << num(a.velocity) << ", acceleration: " << num(a.acceleration)
      << "}";
    if (a.homing && a.home_input != 0) {
      y << ", homing: {method: switch, input: " << a.home_input << ", velocity: " << num(a.home_velocity)
        << ", offset: " << num(a.home_offset) << "}";
    } else if (a.homing) {
      y << ", homing: {method: current-position, offset: " << num(a.home_offset) << "}";
    }
    y << "}\n";
  }
  y << "coordinator: {default_timeout_ms: 20000, progress_period_ms: 200, trigger_lead_ms: 30, gateway_timeout_ms: "
       "1500}\n"
       "simulation: {reply_latency_us: 200, serial_link: "
    << serial_link << "}\n";
  // The key files are the runner's, next to the configuration (paths relative to it).
  if (security) { y << motion::testing::enforced_security(5000); }
  return y.str();
}

LabSpec generate_lab(std::mt19937_64& rng, const GenOptions& options) {
  LabSpec lab;
  lab.can_bitrate = pick(rng, std::vector<int>{125000, 250000, 500000, 1000000});
  // Both serial families at the rates their manuals list (ADAM §2, UIM2501 gateway's RS232 side).
  lab.rs485_baud = pick(rng, std::vector<int>{9600, 19200, 38400, 57600, 115200});
  lab.rs232_baud = pick(rng, std::vector<int>{9600, 19200, 38400, 57600, 115200});
  if (options.parity) lab.rs485_parity = pick(rng, std::vector<std::string>{"none", "even", "odd"});
  const int n = uniform_int(rng, options.min_drives, options.max_drives);
  const std::vector<std::string> families{"uim342", "uc57", "adam-modbus", "uim242"};
  std::map<std::string, std::set<int>> used;  // family -> node ids (and uim342 group ids)
  int group_id = 0;
  std::vector<std::string> order = families;
  std::shuffle(order.begin(), order.end(), rng);
  for (int i = 0; i < n; ++i) {
    AxisSpec a;
    a.name = "ax" + std::to_string(i);
    // The first four drives cover every family (in a seeded order); the rest are random.
    std::string family = order[static_cast<std::size_t>(i % 4)];
    if (i >= 4 || chance(rng, 0.25)) family = pick(rng, families);
    a.drive.family = family;
    a.drive.bus = family == "adam-modbus" ? "rs485" : family == "uim242" ? "rs232" : "can0";
    const auto fam = config::parse_family(family);
    const auto range = config::node_id_range(*fam);
    auto& ids = used[family];
    int id = 0;
    do {
      const int r = uniform_int(rng, 0, 3);
      id = r == 0 ? range.min : r == 1 ? range.max : uniform_int(rng, range.min, range.max);
    } while (ids.contains(id));
    ids.insert(id);
    a.drive.node_id = id;
    if (family == "uim342" && chance(rng, 0.6)) {
      if (group_id == 0) {
        do group_id = chance(rng, 0.5) ? 126 : uniform_int(rng, 5, 126);
        while (ids.contains(group_id));
      }
      a.drive.group_id = group_id;
    }
    a.steps_per_unit = pick(rng, std::vector<double>{1.0, 8.888888888888889, 12.5, 33.333333333333336, 160.0, 320.0,
                                                     640.0, 533.3333333333334});
    // A speed the drives take (pulses/s), a travel the axis crosses in 1-3 s.
    const double pps = uniform(rng, 1600, 12800);
    a.velocity = round_to(pps / a.steps_per_unit, 0.5);
    if (a.velocity <= 0) a.velocity = 0.5;
    const double travel = std::max(4.0, round_to(a.velocity * uniform(rng, 1.0, 3.0), 1.0));
    a.min = -round_to(travel * uniform(rng, 0.0, 0.5), 1.0);
    a.max = a.min + travel;
    a.acceleration = round_to(a.velocity * uniform(rng, 2.0, 8.0), 0.5);
    a.homing = chance(rng, 0.5);
    if (a.homing && (family != "uc57" || chance(rng, 0.3))) a.home_offset = round_to(uniform(rng, a.min, a.max), 0.25);
    // Half of the UIM342 axes with homing search a switch (input 1-3) toward min at 20-80 % of the
    // velocity limit.
    if (a.homing && family == "uim342" && chance(rng, 0.5)) {
      a.home_input = uniform_int(rng, 1, 3);
      a.home_velocity = -std::max(0.5, round_to(a.velocity * uniform(rng, 0.2, 0.8), 0.5));
    }
    lab.axes.push_back(a);
  }
  // A group id must not collide with a node id added after it was chosen.
  for (auto& a : lab.axes) {
    if (a.drive.group_id != 0 && used["uim342"].contains(a.drive.group_id)) a.drive.group_id = 0;
  }
  return lab;
}

// --------------------------------------------------------------------------- steps

std::string Step::cpp() const {
  // Every member, in declaration order (an aggregate initializer that compiles at -Wextra).
  const char* op_name = op == Op::kRequest    ? "Op::kRequest"
                        : op == Op::kJogStop  ? "Op::kJogStop"
                        : op == Op::kConflict ? "Op::kConflict"
                                              : "Op::kFault";
  std::ostringstream s;
  s << "Step{" << op_name << ", " << client << ", " << int{kind} << " /* " << kind_name(kind) << " */, " << list(axes)
    << ", " << list(values) << ", " << num(velocity_scale) << ", " << num(acceleration_scale) << ", " << timeout_ms
    << ", " << output_mask << ", " << output_value << ", " << other_client << ", " << int{stop_kind} << " /* "
    << kind_name(stop_kind) << " */, " << int{second_kind} << " /* " << kind_name(second_kind) << " */, "
    << list(second_axes) << ", " << list(second_values) << ", " << int{fault} << " /* " << fault_name(fault) << " */, "
    << fault_value << "}";
  return s.str();
}

std::string describe(const Step& step) {
  std::ostringstream s;
  s << "client " << step.client << " " << kind_name(step.kind);
  for (std::size_t i = 0; i < step.axes.size(); ++i)
    s << " " << step.axes[i] << "=" << (i < step.values.size() ? num(step.values[i]) : "");
  if (step.axes.empty()) s << " (all axes)";
  if (step.velocity_scale != 0 || step.acceleration_scale != 0)
    s << " vs=" << num(step.velocity_scale) << " as=" << num(step.acceleration_scale);
  if (step.timeout_ms != 0) s << " timeout_ms=" << step.timeout_ms;
  if (step.op == Op::kJogStop) s << ", then client " << step.other_client << " " << kind_name(step.stop_kind);
  if (step.op == Op::kConflict) {
    s << ", while it runs client " << step.other_client << " " << kind_name(step.second_kind);
    for (std::size_t i = 0; i < step.second_axes.size(); ++i)
      s << " " << step.second_axes[i] << "=" << num(step.second_values[i]);
    s << ", then " << kind_name(step.stop_kind);
  }
  if (step.op == Op::kFault && !step.second_axes.empty()) {
    s << ", during it " << fault_name(step.fault) << " " << step.fault_value << " on the drive of "
      << step.second_axes[0] << " for 1 s";
  }
  return s.str();
}

const char* fault_name(std::int8_t action) {
  using motionlcm::sim_control_t;
  switch (action) {
    case sim_control_t::STALL: return "STALL";
    case sim_control_t::SILENCE: return "SILENCE";
    case sim_control_t::POWER_CYCLE: return "POWER_CYCLE";
    case sim_control_t::CRC_ERRORS: return "CRC_ERRORS";
    case sim_control_t::REPLY_LATENCY: return "REPLY_LATENCY";
    case sim_control_t::BUS_DROP: return "BUS_DROP";
    case sim_control_t::LINE_NOISE: return "LINE_NOISE";
    default: return "none";
  }
}

std::string Outcome::text() const {
  std::string out;
  for (auto s : statuses) out += std::string(out.empty() ? "" : "|") + client::status_name(s);
  if (!codes.empty()) {
    out += " code ";
    for (std::size_t i = 0; i < codes.size(); ++i) out += (i ? "|" : "") + std::to_string(codes[i]);
  }
  return out;
}

// --------------------------------------------------------------------------- model

Model::Model(const LabSpec& lab) : lab_(lab) {
  for (const auto& a : lab_.axes) {
    axes_[a.name] = AxisModel{false, 0, 0.0};
    busy_[a.name] = false;
  }
}

std::int64_t Model::counts_of(const std::string& axis, double units) const {
  return std::llround(units * lab_.find(axis)->steps_per_unit);
}

void Model::observe(const std::string& axis, std::int64_t counts) {
  auto& a = axes_.at(axis);
  a.counts = counts;
  // An axis standing within one count (the coordinator's default position tolerance) of a finished
  // move's target keeps that target, in user units, as the base of a relative move; elsewhere
  // (stopped part-way, jogged, homed, position set) the base is where it stands.
  if (!a.at_target || std::llabs(counts - counts_of(axis, a.commanded)) > 1) {
    a.commanded = static_cast<double>(counts) / lab_.find(axis)->steps_per_unit;
    a.at_target = false;
  }
}

void Model::set_busy(const std::vector<std::string>& axes, bool busy) {
  for (const auto& a : axes) busy_.at(a) = busy;
}

Outcome Model::request(std::int8_t kind, const std::vector<std::string>& axes_in, const std::vector<double>& values,
                       double velocity_scale, double acceleration_scale, std::int32_t timeout_ms, bool apply) {
  const auto rejected = [](std::vector<std::int32_t> codes) { return Outcome{{reply_t::REJECTED}, std::move(codes)}; };
  const bool stop = kind == request_t::STOP || kind == request_t::ESTOP;
  std::vector<std::string> axes = axes_in;
  if (axes.empty() && stop)
    for (const auto& a : lab_.axes) axes.push_back(a.name);
  if (!valid_scale(velocity_scale) || !valid_scale(acceleration_scale) || timeout_ms < 0)
    return rejected({error_code(ReplyError::kMalformedRequest)});
  if (stop) {
    if (apply) {
      for (const auto& name : axes) {
        auto& a = axes_.at(name);
        a.counts.reset();  // wherever it stopped: read back
        if (kind == request_t::ESTOP) a.enabled = false;
      }
    }
    return Outcome{{reply_t::DONE}, {}};
  }
  // Every reason to refuse, in no particular order: the product may name any of them.
  std::vector<std::int32_t> reasons;
  const bool need_enabled = kind == request_t::MOVE_ABSOLUTE || kind == request_t::MOVE_RELATIVE ||
                            kind == request_t::JOG || kind == request_t::HOME;
  std::vector<double> targets(axes.size(), 0.0);
  for (std::size_t i = 0; i < axes.size(); ++i) {
    const auto& spec = *lab_.find(axes[i]);
    const auto& a = axes_.at(axes[i]);
    const double v = i < values.size() ? values[i] : 0.0;
    if (busy_.at(axes[i])) reasons.push_back(error_code(ReplyError::kAxisBusy));
    if (need_enabled && !a.enabled) reasons.push_back(error_code(ReplyError::kAxisDisabled));
    if (kind == request_t::MOVE_ABSOLUTE || kind == request_t::MOVE_RELATIVE || kind == request_t::SET_POSITION) {
      targets[i] = kind == request_t::MOVE_RELATIVE ? a.commanded + v : v;
      if (targets[i] < spec.min || targets[i] > spec.max) reasons.push_back(error_code(ReplyError::kOutsideLimits));
    }
    // A UC57 sets its present position to zero only (2012h): another value is unsupported (the
    // coordinator's limit check comes first).
    const bool beyond = kind == request_t::SET_POSITION && (v < spec.min || v > spec.max);
    if (kind == request_t::SET_POSITION && !beyond && spec.drive.family == "uc57" && counts_of(axes[i], v) != 0) {
      reasons.push_back(error_code(ReplyError::kUnsupported));
    }
    if (kind == request_t::JOG && std::abs(v) > spec.velocity)
      reasons.push_back(error_code(ReplyError::kOutsideLimits));
    // A jog with less than one whole count left before the limit in its direction, in counts.
    if (kind == request_t::JOG && v != 0 && a.counts) {
      const double limit = (v > 0 ? spec.max : spec.min) * spec.steps_per_unit;
      const auto at = static_cast<double>(*a.counts);
      if ((v > 0 ? limit - at : at - limit) < 1.0) reasons.push_back(error_code(ReplyError::kOutsideLimits));
    }
    if (kind == request_t::HOME && !spec.homing) reasons.push_back(error_code(ReplyError::kUnsupported));
    // A UC57 sets its present position to zero only (2012h): another offset is unsupported.
    if (kind == request_t::HOME && spec.homing && spec.drive.family == "uc57" &&
        counts_of(axes[i], spec.home_offset) != 0) {
      reasons.push_back(error_code(ReplyError::kUnsupported));
    }
  }
  if (!reasons.empty()) {
    std::sort(reasons.begin(), reasons.end());
    reasons.erase(std::unique(reasons.begin(), reasons.end()), reasons.end());
    // No homing method is found out by the gateway on some families: FAILED, with nothing changed.
    if (reasons.back() == error_code(ReplyError::kUnsupported))
      return Outcome{{reply_t::REJECTED, reply_t::FAILED}, reasons};
    return rejected(reasons);
  }
  if (apply) {
    for (std::size_t i = 0; i < axes.size(); ++i) {
      auto& a = axes_.at(axes[i]);
      const auto& spec = *lab_.find(axes[i]);
      switch (kind) {
        case request_t::MOVE_ABSOLUTE:
        case request_t::MOVE_RELATIVE:
          a.commanded = targets[i];
          a.counts = counts_of(axes[i], targets[i]);
          a.at_target = true;
          break;
        case request_t::SET_POSITION:
        case request_t::HOME: {
          // No move's target: the next relative move counts from the position the drive reports.
          const double at = kind == request_t::HOME ? spec.home_offset : targets[i];
          a.counts = counts_of(axes[i], at);
          a.commanded = static_cast<double>(*a.counts) / spec.steps_per_unit;
          a.at_target = false;
          break;
        }
        case request_t::JOG:
          a.counts.reset();
          a.at_target = false;
          break;
        case request_t::ENABLE: a.enabled = true; break;
        case request_t::DISABLE: a.enabled = false; break;
        default: break;
      }
    }
  }
  return Outcome{{reply_t::DONE}, {}};
}

}  // namespace motion::random_lab
