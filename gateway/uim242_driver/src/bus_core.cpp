#include "motion/uim242_driver/bus_core.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <limits>
#include <optional>

#include <fmt/format.h>
#include <motionlcm/event_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>
#include <motionlcm/param_t.hpp>

#include "motion/gateway/serial_line.hpp"
#include "motion/lcm/reply_error.hpp"

namespace motion::uim242_driver {

using motionlcm::event_t;
using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using uim242::Frame;
using uim242::Instruction;
using uim242::Mnemonic;

namespace {

using namespace std::chrono_literals;

// reply_t error codes: the one list in motion/lcm/reply_error.hpp.
constexpr std::int32_t kMalformed = error_code(ReplyError::kMalformedRequest);
constexpr std::int32_t kUnknownAxis = error_code(ReplyError::kUnknownAxis);
constexpr std::int32_t kOutsideLimits = error_code(ReplyError::kOutsideLimits);
constexpr std::int32_t kAxisDisabled = error_code(ReplyError::kAxisDisabled);
constexpr std::int32_t kAxisOffline = error_code(ReplyError::kAxisOffline);
constexpr std::int32_t kDriveError = error_code(ReplyError::kDriveError);
constexpr std::int32_t kTimeout = error_code(ReplyError::kTimeout);
constexpr std::int32_t kStopped = error_code(ReplyError::kStopped);
constexpr std::int32_t kGroupFault = error_code(ReplyError::kAxisFault);
constexpr std::int32_t kUnsupported = error_code(ReplyError::kUnsupported);

// MCFG (EN/CN §5.4): CM (ramps) + STLIE + STPIE + S3IE..S1IE. Input RTCNs still need a non-zero
// action code in S12CON/S34CON, so enabling them all changes nothing until an input is bound.
constexpr std::int64_t kDefaultMcfg = 0x0400 | 0x0040 | 0x0010 | 0x0007;
constexpr Duration kIdentifyRetry = 1s;
constexpr std::int64_t kSpeedMax = 65535;              // SPD range (#37)
constexpr std::int64_t kAccelerationMax = 65'000'000;  // MAC/MDE value mode (#15)
constexpr std::uint8_t kResetAndEmergencyStop = 0xC;   // sensor action 1100 (EN/CN §8.4)
// S34CON.STALL (bits 15..12): 0000 sends no stall notification whatever STLIE says (EN/CN §8.7,
// §10.2; the stall message id is undocumented); 0001 = no action, notification per STLIE.
constexpr std::uint16_t kStallField = 0xF000;
constexpr std::uint16_t kStallNotifyOnly = 0x1000;
constexpr int kStillPollsBeforeFailure = 2;
// Settling (waiting for rest after a stop or before loading a move): how often `FBK;` asks, and
// how long a motor may take to come to rest.
constexpr Duration kRestCheck = 10ms;
constexpr Duration kRestLimit = 10s;

Instruction set(Mnemonic m, std::int64_t v) { return Instruction{m, false, v, false}; }
Instruction bare(Mnemonic m) { return Instruction{m, false, std::nullopt, false}; }

std::int64_t steady_us(TimePoint t) {
  return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
}

std::int64_t field(const Frame& f, uim242::Layout layout, std::size_t index) {
  const auto fields = uim242::decode_fields(f.data, layout);
  return fields && index < fields->size() ? (*fields)[index] : 0;
}

std::int64_t clamp_rate(double counts_per_s2) {
  return std::clamp<std::int64_t>(std::llround(std::abs(counts_per_s2)), 1, kAccelerationMax);
}

// Duration of a trapezoidal (or, when too short to reach `speed`, triangular) run of `distance`
// counts: a slow short move shows no position change between polls while it still runs.
Duration trapezoid_duration(std::int64_t distance, std::int64_t speed, std::int64_t acceleration, std::int64_t deceleration) {
  const double d = static_cast<double>(std::llabs(distance));
  const double v = static_cast<double>(std::max<std::int64_t>(speed, 1));
  const double a = static_cast<double>(std::max<std::int64_t>(acceleration, 1));
  const double b = static_cast<double>(std::max<std::int64_t>(deceleration, 1));
  const double ramps = v * v / (2 * a) + v * v / (2 * b);
  const double seconds = d >= ramps ? d / v + v / (2 * a) + v / (2 * b) : [&] {
    const double peak = std::sqrt(2 * d * a * b / (a + b));
    return peak / a + peak / b;
  }();
  return std::chrono::duration_cast<Duration>(std::chrono::duration<double>(seconds));
}

}  // namespace

struct Uim242BusCore::Drive {
  const config::Drive* config = nullptr;
  const config::Axis* axis = nullptr;  // null when no axis uses the drive
  std::string name;
  std::string axis_name;
  int node = 0;
  bool identifying = false;
  bool set_up = false;
  gateway::DriveStatus status;
  std::optional<std::int64_t> last_polled_position;
  int still_polls = 0;
  // Homing by switch: the command waiting for the edge, the register to restore, the offset.
  std::int64_t homing_command = 0;
  uim242::Event homing_edge = uim242::Event::s1_falling;
  uim242::ScfWrite homing_restore;
  std::int64_t homing_offset = 0;
};

struct Uim242BusCore::Command {
  gateway_command_t command;
  std::size_t outstanding = 0;
};

struct Uim242BusCore::Move {
  struct Axis {
    Drive* drive = nullptr;
    std::int64_t target = 0;
    std::int64_t speed = 0;
    std::int64_t acceleration = 0;
    std::int64_t deceleration = 0;
    bool loaded = false;   // armed (or already at the target)
    bool arrived = false;
    Duration planned{};    // the trapezoid's duration from where the drive stood at the start
  };
  enum class Phase { arming, armed, starting, moving };
  std::int64_t command_id = 0;
  std::int64_t trigger_id = 0;
  Phase phase = Phase::arming;
  std::vector<Axis> axes;
  std::optional<TimePoint> first_start;
  TimePoint last_start{};
};

Uim242BusCore::Uim242BusCore(const config::Config& config, const std::string& bus, CoreContext context)
    : bus_(bus),
      context_(std::move(context)),
      poll_period_(std::chrono::duration_cast<Duration>(std::chrono::duration<double>(1.0 / 10.0))),
      channel_([this](std::span<const std::uint8_t> b) { context_.send(b); }, ChannelSettings{}) {
  const config::Bus* b = config.find_bus(bus);
  if (b) {
    transport_ = b->transport;
    poll_period_ = std::chrono::duration_cast<Duration>(std::chrono::duration<double>(1.0 / std::max(b->poll_hz, 0.1)));
    channel_ = RequestChannel([this](std::span<const std::uint8_t> bytes) { context_.send(bytes); },
                              ChannelSettings{std::chrono::milliseconds(b->request_timeout_ms), b->retries,
                                              gateway::serial_line_settings(*b).wire_time(1)});
  }
  for (const auto& d : config.drives) {
    if (d.bus != bus || d.family != config::Family::kUim242) continue;
    auto drive = std::make_unique<Drive>();
    drive->config = &d;
    drive->name = d.name;
    drive->node = d.node_id;
    for (const auto& a : config.axes) {
      if (a.drive == d.name) {
        drive->axis = &a;
        drive->axis_name = a.name;
      }
    }
    drives_.push_back(std::move(drive));
  }
}

Uim242BusCore::~Uim242BusCore() = default;

std::vector<std::string> Uim242BusCore::axes() const {
  std::vector<std::string> out;
  for (const auto& d : drives_) {
    if (!d->axis_name.empty()) out.push_back(d->axis_name);
  }
  return out;
}

bool Uim242BusCore::ready() const {
  return std::all_of(drives_.begin(), drives_.end(), [](const auto& d) { return d->status.online && d->set_up; });
}

motionlcm::bus_stats_t Uim242BusCore::statistics() const {
  const auto& s = channel_.statistics();
  motionlcm::bus_stats_t out{};
  out.name = bus_;
  out.transport = transport_;
  out.state = started_ ? "open" : "closed";
  out.tx_frames = s.tx_frames;
  out.rx_frames = s.rx_frames;
  out.tx_bytes = s.tx_bytes;
  out.rx_bytes = s.rx_bytes;
  out.errors = s.errors + s.unexpected + protocol_errors_;
  out.timeouts = s.timeouts;
  out.retries = s.retries;
  out.drives_online = static_cast<std::int32_t>(
      std::count_if(drives_.begin(), drives_.end(), [](const auto& d) { return d->status.online; }));
  out.drives_total = static_cast<std::int32_t>(drives_.size());
  return out;
}

// ---- plumbing ----------------------------------------------------------------------------------

void Uim242BusCore::submit(Drive& d, Instruction in, std::int64_t group,
                           std::function<void(const Frame&, TimePoint)> on_reply, bool front) {
  Request r;
  r.drive = d.name;
  r.node = d.node;
  r.instruction = in;
  r.group = group;
  r.on_reply = std::move(on_reply);
  r.on_failure = [this, &d, group](const std::string& reason, bool timed_out, TimePoint now) {
    if (timed_out) {
      event(d, event_t::TIMEOUT, event_t::WARNING, 0, reason);
      mark_offline(d, reason, now);
    } else {
      event(d, event_t::ERROR_REPORT, event_t::ERROR, 0, reason);
    }
    if (group != 0) finish(group, false, reason, timed_out ? kTimeout : kDriveError);
  };
  channel_.submit(std::move(r), front);
}

void Uim242BusCore::run_sequence(Command& c, Drive& d, std::vector<Instruction> steps, std::function<void(TimePoint)> done) {
  const std::int64_t id = c.command.command_id;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const bool last = i + 1 == steps.size();
    submit(d, steps[i], id, last ? std::function<void(const Frame&, TimePoint)>{[done](const Frame&, TimePoint now) { done(now); }}
                                 : std::function<void(const Frame&, TimePoint)>{});
  }
  if (steps.empty()) done(TimePoint{});
}

void Uim242BusCore::reply(const gateway_command_t& command, std::int8_t status, const std::string& reason,
                          std::int32_t error_code) {
  if (!context_.out) return;
  gateway_reply_t r{};
  r.bus = bus_;
  r.command_id = command.command_id;
  r.status = status;
  r.reason = reason;
  r.error_code = error_code;
  context_.out->command_reply(r);
}

void Uim242BusCore::finish(std::int64_t command_id, bool ok, const std::string& reason, std::int32_t error_code,
                           std::optional<motionlcm::param_t> param) {
  const auto it = commands_.find(command_id);
  if (it == commands_.end()) return;  // already ended: exactly one terminal reply
  const auto command = std::move(it->second->command);
  commands_.erase(it);
  channel_.cancel(command_id);
  std::erase_if(moves_, [command_id](const auto& m) { return m->command_id == command_id; });
  std::erase_if(rest_checks_, [command_id](const RestCheck& r) { return r.group == command_id; });
  for (auto& d : drives_) {
    if (d->homing_command != command_id) continue;
    d->homing_command = 0;
    // Ended before the switch (stopped, failed, timed out): unbind the reset + e-stop action, or
    // a later pass over the switch would zero the position and stop the axis unasked.
    if (started_) submit(*d, uim242::make_scf(d->homing_restore), 0, {}, true);
  }
  if (!context_.out) return;
  gateway_reply_t r{};
  r.bus = bus_;
  r.command_id = command_id;
  r.status = ok ? std::int8_t{gateway_reply_t::DONE} : std::int8_t{gateway_reply_t::FAILED};
  r.reason = reason;
  r.error_code = ok ? 0 : error_code;
  if (param) r.param = *param;
  context_.out->command_reply(r);
}

void Uim242BusCore::part_done(std::int64_t command_id) {
  const auto it = commands_.find(command_id);
  if (it == commands_.end()) return;
  if (it->second->outstanding > 0 && --it->second->outstanding > 0) return;
  finish(command_id, true);
}

void Uim242BusCore::event(const Drive& d, std::int16_t kind, std::int8_t severity, std::int32_t code,
                          const std::string& text) {
  if (!context_.out) return;
  context_.out->axis_event(d.axis_name, gateway::DriveEvent{kind, severity, code, text});
}

void Uim242BusCore::publish(Drive& d, TimePoint now) {
  d.status.sample_utime = context_.utime_of ? context_.utime_of(now) : steady_us(now);
  if (context_.out && !d.axis_name.empty()) context_.out->axis_status(d.axis_name, d.status);
}

// ---- bytes in ------------------------------------------------------------------------------------

void Uim242BusCore::on_bytes(std::span<const std::uint8_t> bytes, TimePoint now) {
  channel_.count_received(bytes.size());
  const auto noise_before = framer_.noise_bytes() + framer_.oversize_frames();
  for (const auto& raw : framer_.push(bytes)) {
    const auto frame = uim242::parse_frame(raw);
    if (!frame) {
      ++protocol_errors_;
      continue;
    }
    on_frame(*frame, now);
  }
  if (framer_.noise_bytes() + framer_.oversize_frames() != noise_before) ++protocol_errors_;
}

void Uim242BusCore::on_frame(const Frame& frame, TimePoint now) {
  if (const auto n = uim242::as_notification(frame)) {
    on_notification(*n, now);
    return;
  }
  if (uim242::as_greeting(frame)) return;  // the gateway (re)started: nothing to answer
  if (!channel_.on_frame(frame, now)) ++protocol_errors_;
}

void Uim242BusCore::on_notification(const uim242::Notification& n, TimePoint now) {
  const auto it = std::find_if(drives_.begin(), drives_.end(), [&](const auto& d) { return d->node == n.node; });
  if (it == drives_.end()) {
    ++protocol_errors_;
    return;
  }
  Drive& d = **it;
  switch (n.event) {
    case uim242::Event::displacement_complete:
      if (n.position) d.status.position_counts = d.status.target_counts;
      move_axis_arrived(d, now);
      return;
    case uim242::Event::stall: {
      const std::string reason = fmt::format("{} (node {}): stall notification", d.name, d.node);
      d.status.fault = true;
      d.status.fault_code = static_cast<std::int32_t>(uim242::message::kDefaultStall);
      d.status.fault_text = "stall";
      event(d, event_t::STALL, event_t::ERROR, d.status.fault_code, reason);
      fail_moves_of(d, reason, kGroupFault);
      publish(d, now);
      return;
    }
    case uim242::Event::position_zero:
    case uim242::Event::p4_high_to_low:
    case uim242::Event::p4_low_to_high:
      event(d, event_t::INPUT_EDGE, event_t::INFO, static_cast<std::int32_t>(n.event),
            fmt::format("{} (node {}): notification 0x{:02X}", d.name, d.node, static_cast<int>(n.event)));
      return;
    default: break;
  }
  // S1..S3 edges (A0..A5).
  const int input = (static_cast<int>(n.event) - 0xA0) / 2 + 1;
  const bool rising = (static_cast<int>(n.event) & 1) != 0;
  d.status.inputs = rising ? (d.status.inputs | (1 << (input - 1))) : (d.status.inputs & ~(1 << (input - 1)));
  event(d, event_t::INPUT_EDGE, event_t::INFO, input,
        fmt::format("{} (node {}): input S{} {}", d.name, d.node, input, rising ? "rising" : "falling"));
  if (d.homing_command != 0 && n.event == d.homing_edge) {
    // The switch fired: the drive reset its position and stopped (action 1100). Restore the
    // sensor register, drop the homing speed (an e-stop keeps the desired speed: the next `ENA;`
    // would run on), and apply the home offset.
    const std::int64_t id = d.homing_command;
    d.homing_command = 0;
    const auto c = commands_.find(id);
    if (c == commands_.end()) return;
    const std::int64_t offset = d.homing_offset;
    run_sequence(*c->second, d, {uim242::make_scf(d.homing_restore), set(Mnemonic::SPD, 0), set(Mnemonic::ORG, offset)},
                 [this, id, &d, offset](TimePoint t) {
                   homed(d, offset, t);
                   part_done(id);  // DONE when every axis of the command is home
                 });
  }
}

// ---- start-up and polling -----------------------------------------------------------------------

void Uim242BusCore::start(TimePoint now) {
  started_ = true;
  next_poll_ = now + poll_period_;
  for (auto& d : drives_) identify(*d, now);
  next_identify_ = now + kIdentifyRetry;
}

void Uim242BusCore::line_lost(const std::string& why, TimePoint now) {
  const std::string reason = fmt::format("serial line of bus {} lost: {}", bus_, why);
  started_ = false;
  if (context_.out) context_.out->axis_event({}, gateway::DriveEvent{event_t::OFFLINE, event_t::ERROR, 0, reason});
  std::vector<std::int64_t> running;
  for (const auto& [id, c] : commands_) running.push_back(id);
  for (const auto id : running) finish(id, false, reason, kTimeout);
  // Nothing sent before the loss will be answered: forget it, and any half-received frame.
  channel_.reset();
  framer_.reset();
  polls_outstanding_ = 0;
  for (auto& d : drives_) {
    d->identifying = false;
    mark_offline(*d, reason, now);
  }
}

void Uim242BusCore::identify(Drive& d, TimePoint /*now*/) {
  if (d.identifying) return;
  d.identifying = true;
  Request r;
  r.drive = d.name;
  r.node = d.node;
  r.instruction = set(Mnemonic::MDL, d.node);
  r.on_reply = [this, &d](const Frame& f, TimePoint now) {
    d.identifying = false;
    const auto fields = uim242::decode_fields(f.data, uim242::Layout::model);
    if (!fields || (*fields)[0] != 0x18 || (*fields)[1] != 0x02) {
      event(d, event_t::CONFIG_MISMATCH, event_t::WARNING, 0,
            fmt::format("{} (node {}): 'MDL {};' reports a model other than UIM242 (18 02)", d.name, d.node, d.node));
    }
    d.status.online = true;
    event(d, event_t::ONLINE, event_t::INFO, 0,
          fmt::format("{} (node {}): UIM242, firmware {}", d.name, d.node, fields ? (*fields)[4] : 0));
    set_up(d);
    publish(d, now);
  };
  r.on_failure = [this, &d](const std::string& reason, bool, TimePoint now) {
    d.identifying = false;
    mark_offline(d, reason, now);
  };
  channel_.submit(std::move(r));
}

void Uim242BusCore::set_up(Drive& d) {
  const auto& setup = d.config->setup;
  const auto integer = [&](const char* key) -> std::optional<std::int64_t> {
    const auto it = setup.find(key);
    if (it == setup.end()) return std::nullopt;
    if (const auto* v = std::get_if<long long>(&it->second)) return *v;
    if (const auto* v = std::get_if<double>(&it->second)) return std::llround(*v);
    return std::nullopt;
  };
  std::vector<Instruction> steps;
  if (const auto m = integer("micro_steps")) steps.push_back(set(Mnemonic::MCS, *m));
  if (const auto it = setup.find("current_a"); it != setup.end()) {
    const double amps = std::holds_alternative<double>(it->second) ? std::get<double>(it->second)
                                                                   : static_cast<double>(std::get<long long>(it->second));
    steps.push_back(set(Mnemonic::CUR, std::llround(amps * 10)));  // tenths of an ampere (#6)
  }
  steps.push_back(set(Mnemonic::MCF, integer("mcfg").value_or(kDefaultMcfg)));
  if (const auto v = integer("icfg")) steps.push_back(set(Mnemonic::ICF, *v));
  if (const auto v = integer("encoder_lines")) steps.push_back(set(Mnemonic::QER, *v));
  if (const auto v = integer("stall_tolerance")) steps.push_back(set(Mnemonic::SQT, *v));
  steps.push_back(set(Mnemonic::MMS, 0));  // no non-linear jumps: the planner's exact trapezoid
  steps.push_back(set(Mnemonic::MMD, 0));
  steps.push_back(set(Mnemonic::STP, 0));  // velocity mode, desired speed 0
  const auto submit_step = [this, &d](Instruction in, std::function<void(const Frame&, TimePoint)> on_reply, bool front) {
    Request r;
    r.drive = d.name;
    r.node = d.node;
    r.instruction = in;
    r.on_reply = std::move(on_reply);
    r.on_failure = [this, &d](const std::string& reason, bool timed_out, TimePoint now) {
      event(d, event_t::CONFIG_MISMATCH, event_t::ERROR, 0, "set-up failed: " + reason);
      if (timed_out) mark_offline(d, reason, now);
    };
    channel_.submit(std::move(r), front);
  };
  // STLIE alone sends no stall notification: a STALL action of 0000 silences it. Keep a configured
  // action, else bind "notify only" (the sensor bits of S34CON stay as they are).
  submit_step(bare(Mnemonic::SCF), [submit_step](const Frame& f, TimePoint) {
    const auto s34con = static_cast<std::uint16_t>(static_cast<std::uint32_t>(field(f, uim242::Layout::scf, 0)) >> 16);
    if ((s34con & kStallField) != 0) return;
    submit_step(uim242::make_scf({uim242::SensorRegister::S34CON, static_cast<std::uint16_t>(s34con | kStallNotifyOnly)}), {}, true);
  }, false);
  for (std::size_t i = 0; i < steps.size(); ++i) {
    std::function<void(const Frame&, TimePoint)> on_reply;
    if (i + 1 == steps.size()) {
      on_reply = [this, &d](const Frame&, TimePoint now) {
        d.set_up = true;
        publish(d, now);
      };
    }
    submit_step(steps[i], std::move(on_reply), false);
  }
}

void Uim242BusCore::mark_offline(Drive& d, const std::string& reason, TimePoint now) {
  d.set_up = false;
  if (!d.status.online) return;
  d.status.online = false;
  event(d, event_t::OFFLINE, event_t::ERROR, 0, reason);
  fail_moves_of(d, reason, kAxisOffline);
  publish(d, now);
}

void Uim242BusCore::poll(TimePoint now) {
  if (now >= next_identify_) {
    next_identify_ = now + kIdentifyRetry;
    for (auto& d : drives_) {
      if (!d->status.online) identify(*d, now);
    }
  }
  if (now < next_poll_ || polls_outstanding_ > 0) return;
  next_poll_ = now + poll_period_;
  for (auto& dp : drives_) {
    Drive& d = *dp;
    if (!d.status.online || !d.set_up) continue;
    const auto poll_request = [&](Instruction in, std::function<void(const Frame&, TimePoint)> on_reply) {
      ++polls_outstanding_;
      Request r;
      r.drive = d.name;
      r.node = d.node;
      r.instruction = in;
      r.on_reply = [this, on_reply](const Frame& f, TimePoint t) {
        --polls_outstanding_;
        on_reply(f, t);
      };
      r.on_failure = [this, &d](const std::string& reason, bool timed_out, TimePoint t) {
        --polls_outstanding_;
        if (timed_out) {
          event(d, event_t::TIMEOUT, event_t::WARNING, 0, reason);
          mark_offline(d, reason, t);
        }
      };
      channel_.submit(std::move(r));
    };
    poll_request(bare(Mnemonic::FBK), [&d](const Frame& f, TimePoint) {
      if (const auto s = uim242::decode_status(f)) {
        d.status.enabled = s->enabled;
        d.status.velocity_counts = s->speed;
        d.status.moving = s->speed != 0;
      }
    });
    poll_request(bare(Mnemonic::QEC), [this, &d](const Frame& f, TimePoint t) {
      const std::int64_t position = field(f, uim242::Layout::s32, 0);
      const bool still = !d.status.moving && d.last_polled_position == position;
      d.status.position_counts = position;
      d.last_polled_position = position;
      // The move of this drive that is under way, and when its run should have ended.
      std::optional<TimePoint> due;
      for (const auto& m : moves_) {
        if (m->phase != Move::Phase::moving) continue;
        for (const auto& a : m->axes) {
          if (a.drive == &d && !a.arrived) due = m->last_start + a.planned;
        }
      }
      const bool moving_to_target = due.has_value();
      d.status.in_position = !moving_to_target || (position == d.status.target_counts && !d.status.moving);
      if (moving_to_target) {
        if (position == d.status.target_counts && !d.status.moving) {
          move_axis_arrived(d, t);
        } else if (still && t >= *due && ++d.still_polls >= kStillPollsBeforeFailure) {
          fail_moves_of(d, fmt::format("{} (node {}): stopped at {} before the target {}", d.name, d.node, position,
                                       d.status.target_counts),
                        kGroupFault);
        }
      }
      if (!still) d.still_polls = 0;
      publish(d, t);
    });
  }
}

TimePoint Uim242BusCore::process(TimePoint now) {
  if (started_) poll(now);
  // Due rest checks leave the list before they ask again (settle() may add to it).
  const auto split = std::stable_partition(rest_checks_.begin(), rest_checks_.end(), [now](const RestCheck& r) { return r.due > now; });
  std::vector<RestCheck> due(std::make_move_iterator(split), std::make_move_iterator(rest_checks_.end()));
  rest_checks_.erase(split, rest_checks_.end());
  for (auto& r : due) settle(*r.drive, r.group, r.give_up, std::move(r.then));
  const TimePoint channel_deadline = channel_.process(now);
  if (!started_) return channel_deadline;
  TimePoint next = std::min(channel_deadline, next_poll_);
  for (const auto& r : rest_checks_) next = std::min(next, r.due);
  if (std::any_of(drives_.begin(), drives_.end(), [](const auto& d) { return !d->status.online; })) {
    next = std::min(next, next_identify_);
  }
  return next;
}

// ---- commands -------------------------------------------------------------------------------------

Uim242BusCore::Drive* Uim242BusCore::drive_of_axis(const std::string& axis) {
  for (auto& d : drives_) {
    if (d->axis_name == axis) return d.get();
  }
  return nullptr;
}

bool Uim242BusCore::for_each_axis(const gateway_command_t& command,
                                  const std::function<void(Drive&, const motionlcm::axis_command_t&)>& f) {
  for (const auto& a : command.axes) {
    Drive* d = drive_of_axis(a.axis);
    if (!d) {
      finish(command.command_id, false, fmt::format("axis '{}' is not on bus {}", a.axis, bus_), kUnknownAxis);
      return false;
    }
    if (!d->status.online) {
      finish(command.command_id, false, fmt::format("{} (node {}) of axis '{}' is offline", d->name, d->node, a.axis),
             kAxisOffline);
      return false;
    }
  }
  for (const auto& a : command.axes) f(*drive_of_axis(a.axis), a);
  return true;
}

void Uim242BusCore::execute(const gateway_command_t& command, TimePoint now) {
  const std::int64_t id = command.command_id;
  if (commands_.contains(id)) {
    // As the CAN stacks and the ADAM master: a reused id is refused, the running command goes on.
    reply(command, gateway_reply_t::FAILED, fmt::format("command id {} is already in progress", id), kMalformed);
    return;
  }
  auto owned = std::make_unique<Command>();
  owned->command = command;
  owned->outstanding = command.axes.size();
  Command& c = *owned;
  commands_[id] = std::move(owned);
  if (command.axes.empty() && command.kind != gateway_command_t::DISARM) {
    finish(id, false, "command names no axis", kMalformed);
    return;
  }
  // One instruction sequence per axis; DONE when every axis finished it. The state it led to
  // goes out before DONE: whoever acts on the reply (the coordinator planning the next move from
  // the position, checking "enabled") has it by then.
  // `after` runs when the drive answered, long after execute() returned: it gets its own copy of
  // the axis's command (the caller's `command` is gone by then; random lab seeds 2 and 4).
  using After = std::function<void(Drive&, const motionlcm::axis_command_t&)>;
  const auto per_axis = [&](const std::function<std::vector<Instruction>(Drive&, const motionlcm::axis_command_t&)>& steps,
                            const After& after = {}) {
    for_each_axis(command, [&](Drive& d, const motionlcm::axis_command_t& a) {
      run_sequence(c, d, steps(d, a), [this, id, &d, after, a](TimePoint t) {
        if (after) {
          after(d, a);
          if (t != TimePoint{}) publish(d, t);  // TimePoint{}: nothing was sent, nothing changed
        }
        part_done(id);
      });
    });
  };
  switch (command.kind) {
    case gateway_command_t::ENABLE:
      per_axis([](Drive&, const auto&) { return std::vector{bare(Mnemonic::ENA)}; },
               [](Drive& d, const auto&) { d.status.enabled = true; });
      return;
    case gateway_command_t::DISABLE:
    case gateway_command_t::ESTOP: {
      const bool estop = command.kind == gateway_command_t::ESTOP;
      const std::string why = estop ? "stopped by ESTOP" : "axis disabled";
      for (const auto& a : command.axes) {
        if (Drive* d = drive_of_axis(a.axis)) fail_moves_of(*d, fmt::format("{} (node {}): {}", d->name, d->node, why), kStopped);
      }
      const bool every_drive = estop && command.axes.size() == drives_.size() &&
                               std::all_of(drives_.begin(), drives_.end(), [](const auto& d) { return d->status.online; });
      // After OFF the desired speed is set to 0: a controller keeps it while disabled, and ENA
      // runs the motor at it again (manual, ENA H-Bridge Enable; the "SPD 5000; ENA;" example), so
      // a later enable would resume the interrupted jog or move.
      if (every_drive) {
        // One `gOFF;` frame disables every controller at once (Summary), one `gSPD 0;` zeroes
        // every desired speed.
        const auto broadcast = [this, id](Instruction in, std::function<void()> then) {
          Request r;
          r.drive = "gateway";
          r.instruction = in;
          r.group = id;
          r.on_reply = [then = std::move(then)](const Frame&, TimePoint) { then(); };
          r.on_failure = [this, id](const std::string& reason, bool timed_out, TimePoint) {
            finish(id, false, reason, timed_out ? kTimeout : kDriveError);
          };
          channel_.submit(std::move(r), true);
        };
        broadcast(Instruction{Mnemonic::OFF, true, std::nullopt, false}, [this, id, broadcast] {
          for (auto& d : drives_) d->status.enabled = false;
          broadcast(Instruction{Mnemonic::SPD, true, 0, false}, [this, id] { finish(id, true); });
        });
        return;
      }
      per_axis([](Drive&, const auto&) { return std::vector{bare(Mnemonic::OFF), set(Mnemonic::SPD, 0)}; },
               [](Drive& d, const auto&) { d.status.enabled = false; });
      return;
    }
    case gateway_command_t::STOP:
      for (const auto& a : command.axes) {
        if (Drive* d = drive_of_axis(a.axis)) {
          fail_moves_of(*d, fmt::format("{} (node {}): stopped by STOP", d->name, d->node), kStopped);
        }
      }
      // Ramped stop, DONE at rest with the real position published (settle).
      for_each_axis(command, [&](Drive& d, const motionlcm::axis_command_t&) {
        run_sequence(c, d, {set(Mnemonic::STP, 0)}, [this, id, &d](TimePoint t) {
          settle(d, id, t + kRestLimit, [this, id](TimePoint) { part_done(id); });
        });
      });
      return;
    case gateway_command_t::JOG:
      for (const auto& a : command.axes) {
        if (std::llround(std::abs(a.velocity)) > kSpeedMax) {
          finish(id, false, fmt::format("axis '{}': jog velocity {} above the UIM242 maximum {} pps", a.axis, a.velocity, kSpeedMax),
                 kOutsideLimits);
          return;
        }
      }
      per_axis([](Drive&, const motionlcm::axis_command_t& a) {
        const std::int64_t v = std::llround(a.velocity);
        if (v == 0) return std::vector{set(Mnemonic::STP, 0)};
        return std::vector{set(Mnemonic::STP, 0), set(Mnemonic::MAC, clamp_rate(a.acceleration)),
                           set(Mnemonic::MDE, clamp_rate(a.deceleration > 0 ? a.deceleration : a.acceleration)),
                           set(Mnemonic::SPD, v)};
      });
      return;
    case gateway_command_t::FAULT_RESET:
      per_axis([](Drive&, const auto&) { return std::vector{bare(Mnemonic::FBK)}; },
               [](Drive& d, const auto&) {
                 d.status.fault = false;
                 d.status.fault_code = 0;
                 d.status.fault_text.clear();
               });
      return;
    case gateway_command_t::SET_OUTPUTS:
      for (const auto& a : command.axes) {
        if ((a.output_mask & ~1) != 0) {
          finish(id, false, fmt::format("axis '{}': the UIM242 has one output (1 = P4), mask 0x{:X}", a.axis, a.output_mask),
                 kUnsupported);
          return;
        }
      }
      per_axis(
          [](Drive&, const motionlcm::axis_command_t& a) {
            return a.output_mask & 1 ? std::vector{set(Mnemonic::DOU, a.output_value & 1)} : std::vector<Instruction>{};
          },
          [](Drive& d, const motionlcm::axis_command_t& a) {
            if (a.output_mask & 1) d.status.outputs = a.output_value & 1;
          });
      return;
    case gateway_command_t::SET_POSITION:
      per_axis([](Drive&, const motionlcm::axis_command_t& a) { return std::vector{set(Mnemonic::ORG, a.target_counts)}; },
               [](Drive& d, const motionlcm::axis_command_t& a) { d.status.position_counts = a.target_counts; });
      return;
    case gateway_command_t::HOME:
      for_each_axis(command, [&](Drive& d, const motionlcm::axis_command_t& a) { home(c, d, *d.axis, a); });
      return;
    case gateway_command_t::PARAM_READ:
    case gateway_command_t::PARAM_WRITE:
      for_each_axis(command, [&](Drive& d, const auto&) { param(command, d, command.kind == gateway_command_t::PARAM_WRITE); });
      return;
    case gateway_command_t::ARM_MOVE:
      arm(command, now);
      return;
    case gateway_command_t::DISARM: {
      // Forget armed moves (by trigger id, or naming these axes) and clear their loaded targets.
      std::vector<Drive*> loaded;
      std::vector<std::int64_t> disarmed;
      for (const auto& m : moves_) {
        const bool by_trigger = command.trigger_id != 0 && m->trigger_id == command.trigger_id;
        const bool by_axis = std::any_of(m->axes.begin(), m->axes.end(), [&](const auto& a) {
          return std::any_of(command.axes.begin(), command.axes.end(), [&](const auto& ca) { return ca.axis == a.drive->axis_name; });
        });
        if ((m->phase != Move::Phase::arming && m->phase != Move::Phase::armed) || !(by_trigger || by_axis)) continue;
        disarmed.push_back(m->command_id);
        for (const auto& a : m->axes) {
          if (a.loaded && !a.arrived) loaded.push_back(a.drive);
        }
      }
      for (const auto mid : disarmed) finish(mid, false, "disarmed before the trigger", kStopped);
      c.outstanding = loaded.size();
      if (loaded.empty()) {
        finish(id, true);
        return;
      }
      for (Drive* d : loaded) run_sequence(c, *d, {set(Mnemonic::STP, 0)}, [this, id](TimePoint) { part_done(id); });
      return;
    }
    default:
      finish(id, false, fmt::format("unknown command kind {}", command.kind), kMalformed);
      return;
  }
}

void Uim242BusCore::arm(const gateway_command_t& command, TimePoint now) {
  const std::int64_t id = command.command_id;
  auto move = std::make_unique<Move>();
  move->command_id = id;
  move->trigger_id = command.trigger_id;
  for (const auto& a : command.axes) {
    Drive* d = drive_of_axis(a.axis);
    if (!d) return (void)finish(id, false, fmt::format("axis '{}' is not on bus {}", a.axis, bus_), kUnknownAxis);
    if (!d->status.online) return (void)finish(id, false, fmt::format("{} (node {}) is offline", d->name, d->node), kAxisOffline);
    if (!d->status.enabled) return (void)finish(id, false, fmt::format("{} (node {}) of axis '{}' is disabled", d->name, d->node, a.axis), kAxisDisabled);
    const std::int64_t speed = std::llround(std::abs(a.velocity));
    if (speed < 1 || speed > kSpeedMax) {
      return (void)finish(id, false, fmt::format("axis '{}': speed {} pps outside 1..{} (SPD)", a.axis, a.velocity, kSpeedMax),
                          kOutsideLimits);
    }
    move->axes.push_back({d, a.target_counts, speed, clamp_rate(a.acceleration),
                          clamp_rate(a.deceleration > 0 ? a.deceleration : a.acceleration), false, false});
  }
  Move& m = *move;
  moves_.push_back(std::move(move));
  Command& c = *commands_.at(id);
  const auto loaded = [this, id, &m](TimePoint t) {
    if (std::any_of(m.axes.begin(), m.axes.end(), [](const auto& a) { return !a.loaded; })) return;
    m.phase = Move::Phase::armed;
    reply(commands_.at(id)->command, gateway_reply_t::ARMED);
    if (m.trigger_id == 0) start_move(m, t);
  };
  for (auto& axis : m.axes) {
    Drive& d = *axis.drive;
    // Ramps and zero speed first (`SPD 0;` brakes a motor still running), then at rest the
    // position the relative STP is computed from (settle: EN/CN #44 counts STP from the
    // position at its receipt, which must be the position read).
    run_sequence(c, d, {set(Mnemonic::MAC, axis.acceleration), set(Mnemonic::MDE, axis.deceleration), set(Mnemonic::SPD, 0)},
                 [this, &c, &d, &axis, loaded, id](TimePoint t0) {
    settle(d, id, t0 + kRestLimit, [this, &c, &d, &axis, loaded](TimePoint t) {
      const std::int64_t position = d.status.position_counts;
      const std::int64_t displacement = axis.target - position;
      if (displacement == 0) {  // already there: `STP 0;` would mean "leave PT", not "move 0"
        axis.loaded = axis.arrived = true;
        loaded(t);
        return;
      }
      if (std::abs(displacement) > std::numeric_limits<std::int32_t>::max()) {
        finish(c.command.command_id, false, fmt::format("{} (node {}): displacement {} beyond STP's range", d.name, d.node, displacement),
               kOutsideLimits);
        return;
      }
      run_sequence(c, d, {set(Mnemonic::STP, displacement)}, [&axis, loaded](TimePoint t2) {
        axis.loaded = true;
        loaded(t2);
      });
    });
                 });
  }
  (void)now;
}

void Uim242BusCore::fire(std::int64_t trigger_id, TimePoint now) {
  // start_move() may end a move at once (every axis already at its target: DONE), and finish()
  // erases it from moves_: walk a list of the command ids, and look each one up again.
  std::vector<std::int64_t> ids;
  for (const auto& m : moves_) {
    if (m->phase == Move::Phase::armed && m->trigger_id == trigger_id) ids.push_back(m->command_id);
  }
  for (const auto id : ids) {
    const auto it = std::find_if(moves_.begin(), moves_.end(), [id](const auto& m) { return m->command_id == id; });
    if (it != moves_.end() && (*it)->phase == Move::Phase::armed) start_move(**it, now);
  }
}

void Uim242BusCore::start_move(Move& m, TimePoint /*now*/) {
  m.phase = Move::Phase::starting;
  const std::int64_t id = m.command_id;
  std::vector<Move::Axis*> to_start;
  for (auto& a : m.axes) {
    if (!a.arrived) to_start.push_back(&a);
  }
  const auto started = [this, id, &m](std::string mechanism) {
    m.phase = Move::Phase::moving;
    gateway_reply_t r{};
    r.bus = bus_;
    r.command_id = id;
    r.status = gateway_reply_t::STARTED;
    const TimePoint first = m.first_start.value_or(TimePoint{});
    r.trigger_utime = context_.utime_of ? context_.utime_of(first) : steady_us(first);
    r.start_mechanism = std::move(mechanism);
    // Measured spread between the first and the last start instruction on the wire.
    r.predicted_skew_us = std::chrono::duration<double, std::micro>(m.last_start - first).count();
    if (context_.out) context_.out->command_reply(r);
    if (std::all_of(m.axes.begin(), m.axes.end(), [](const auto& a) { return a.arrived; })) finish(id, true);
  };
  const auto on_sent = [&m](TimePoint sent) {
    if (!m.first_start) m.first_start = sent;
    m.last_start = sent;
  };
  for (auto* a : to_start) {
    a->planned = trapezoid_duration(a->target - a->drive->status.position_counts, a->speed, a->acceleration, a->deceleration);
    a->drive->status.target_counts = a->target;
    a->drive->status.in_position = false;
    a->drive->still_polls = 0;
  }
  if (to_start.empty()) {
    m.first_start = m.last_start = TimePoint{};
    started("none");
    return;
  }
  const bool every_drive = to_start.size() == drives_.size();
  const bool one_speed = std::all_of(to_start.begin(), to_start.end(), [&](const auto* a) { return a->speed == to_start.front()->speed; });
  if (every_drive && one_speed) {
    // Every controller is loaded with SPD 0 and its target: one global speed starts them all.
    Request r;
    r.drive = "gateway";
    r.instruction = Instruction{Mnemonic::SPD, true, to_start.front()->speed, false};
    r.group = id;
    r.on_sent = on_sent;
    r.on_reply = [started](const Frame&, TimePoint) { started("broadcast"); };
    r.on_failure = [this, id](const std::string& reason, bool timed_out, TimePoint) {
      finish(id, false, reason, timed_out ? kTimeout : kDriveError);
    };
    channel_.submit(std::move(r), true);
    return;
  }
  // Axis by axis, ahead of any queued poll (submitted in reverse: each goes to the front).
  for (std::size_t i = to_start.size(); i-- > 0;) {
    Move::Axis& a = *to_start[i];
    const bool last = i + 1 == to_start.size();
    Request r;
    r.drive = a.drive->name;
    r.node = a.drive->node;
    r.instruction = set(Mnemonic::SPD, a.speed);
    r.group = id;
    r.on_sent = on_sent;
    if (last) r.on_reply = [started](const Frame&, TimePoint) { started("sequential"); };
    Drive& d = *a.drive;
    r.on_failure = [this, id, &d](const std::string& reason, bool timed_out, TimePoint t) {
      if (timed_out) mark_offline(d, reason, t);
      finish(id, false, reason, timed_out ? kTimeout : kDriveError);
    };
    channel_.submit(std::move(r), true);
  }
}

void Uim242BusCore::move_axis_arrived(Drive& d, TimePoint now) {
  for (auto& m : moves_) {
    if (m->phase != Move::Phase::moving && m->phase != Move::Phase::starting) continue;
    for (auto& a : m->axes) {
      if (a.drive != &d || a.arrived) continue;
      a.arrived = true;
      d.status.in_position = true;
      d.status.position_counts = a.target;
      publish(d, now);
      event(d, event_t::MOTION_COMPLETE, event_t::INFO, 0, fmt::format("{} (node {}) at {}", d.name, d.node, a.target));
      if (m->phase == Move::Phase::moving &&
          std::all_of(m->axes.begin(), m->axes.end(), [](const auto& x) { return x.arrived; })) {
        finish(m->command_id, true);  // erases the move: stop iterating
      }
      return;
    }
  }
}

void Uim242BusCore::fail_moves_of(const Drive& d, const std::string& reason, std::int32_t code) {
  std::vector<std::int64_t> failed;
  for (const auto& m : moves_) {
    if (std::any_of(m->axes.begin(), m->axes.end(), [&](const auto& a) { return a.drive == &d && !a.arrived; })) {
      failed.push_back(m->command_id);
    }
  }
  if (d.homing_command != 0) failed.push_back(d.homing_command);
  for (const auto id : failed) finish(id, false, reason, code);
}

void Uim242BusCore::settle(Drive& d, std::int64_t group, TimePoint give_up, std::function<void(TimePoint)> then) {
  submit(d, bare(Mnemonic::FBK), group, [this, &d, group, give_up, then = std::move(then)](const Frame& f, TimePoint t) mutable {
    const auto s = uim242::decode_status(f);
    const std::int64_t speed = s ? s->speed : 0;
    if (speed != 0) {
      d.status.moving = true;
      d.status.velocity_counts = static_cast<double>(speed);
      if (t >= give_up) {
        finish(group, false, fmt::format("{} (node {}): still moving at {} pps, not at rest within {} s", d.name, d.node, speed,
                                         std::chrono::duration_cast<std::chrono::seconds>(kRestLimit).count()),
               kDriveError);
        return;
      }
      rest_checks_.push_back({t + kRestCheck, &d, group, give_up, std::move(then)});
      return;
    }
    // At rest: the real position, published not moving before anything plans from it.
    submit(d, bare(Mnemonic::QEC), group, [this, &d, then = std::move(then)](const Frame& q, TimePoint t2) {
      const std::int64_t position = field(q, uim242::Layout::s32, 0);
      d.status.position_counts = position;
      d.last_polled_position = position;
      d.status.moving = false;
      d.status.velocity_counts = 0;
      publish(d, t2);
      then(t2);
    }, true);
  }, true);
}

void Uim242BusCore::homed(Drive& d, std::int64_t offset, TimePoint now) {
  d.status.homed = true;
  d.status.position_counts = offset;
  d.status.moving = false;  // the drive took `ORG`: it refuses it while moving
  d.status.velocity_counts = 0;
  d.last_polled_position.reset();
  publish(d, now);  // before DONE (see execute)
}

void Uim242BusCore::home(Command& c, Drive& d, const config::Axis& axis, const motionlcm::axis_command_t& a) {
  const std::int64_t id = c.command.command_id;
  // Offset and velocity in counts as the coordinator computed them (with the axis's direction).
  const std::int64_t offset = a.target_counts;
  if (axis.homing.method == config::HomingMethod::kNone) {
    finish(id, false, fmt::format("axis '{}' has no homing method configured", axis.name), kUnsupported);
    return;
  }
  if (axis.homing.method == config::HomingMethod::kCurrentPosition) {
    // No switch: the current position becomes the home position (ORG, #28/#29).
    run_sequence(c, d, {set(Mnemonic::ORG, offset)}, [this, id, &d, offset](TimePoint now) {
      homed(d, offset, now);
      part_done(id);
    });
    return;
  }
  const int input = axis.homing.input;
  if (input < 1 || input > 3) {
    finish(id, false, fmt::format("axis '{}': homing input {} is not S1..S3", axis.name, input), kOutsideLimits);
    return;
  }
  double velocity = a.velocity;
  if (velocity == 0) velocity = -0.1 * axis.limits.max_velocity * axis.steps_per_unit * (axis.invert ? -1.0 : 1.0);
  const std::int64_t speed = std::clamp<std::int64_t>(std::llround(velocity), -kSpeedMax, kSpeedMax);
  // Read the sensor registers, bind 1100 (reset position + emergency stop) to the switch's
  // configured edge (falling by default: a hit switch outputs 0 V, EN §8.10), then run towards
  // it. S12CON = S2RACT S2FACT S1RACT S1FACT, S34CON's low byte S3RACT S3FACT (EN/CN §8.6, §8.7).
  const bool rising = axis.homing.edge == config::HomingEdge::kRising;
  submit(d, bare(Mnemonic::SCF), id, [this, &c, &d, input, rising, speed, offset](const Frame& f, TimePoint) {
    const auto s34_s12 = static_cast<std::uint32_t>(field(f, uim242::Layout::scf, 0));
    const bool s3 = input == 3;
    const auto reg = static_cast<std::uint16_t>(s3 ? s34_s12 >> 16 : s34_s12 & 0xFFFF);
    const int shift = (input == 2 ? 8 : 0) + (rising ? 4 : 0);
    const auto bound = static_cast<std::uint16_t>((reg & ~(0xF << shift)) | (kResetAndEmergencyStop << shift));
    const auto which = s3 ? uim242::SensorRegister::S34CON : uim242::SensorRegister::S12CON;
    d.homing_restore = {which, reg};
    d.homing_edge = static_cast<uim242::Event>(0xA0 + 2 * (input - 1) + (rising ? 1 : 0));
    d.homing_offset = offset;
    d.homing_command = c.command.command_id;  // from here on, an end without the edge restores the register
    run_sequence(c, d, {uim242::make_scf({which, bound}), set(Mnemonic::STP, 0), set(Mnemonic::SPD, speed)}, [](TimePoint) {});
  });
}

void Uim242BusCore::param(const gateway_command_t& command, Drive& d, bool write) {
  const std::int64_t id = command.command_id;
  const auto& p = command.param;
  if (p.space != motionlcm::param_t::UIM242_INSTRUCTION) {
    finish(id, false, fmt::format("parameter space {} is not UIM242_INSTRUCTION", p.space), kMalformed);
    return;
  }
  const auto m = p.mnemonic.size() >= 3 ? uim242::parse_mnemonic(std::string_view(p.mnemonic).substr(0, 3)) : std::nullopt;
  if (!m || uim242::spec(*m).target != uim242::Target::controller || *m == Mnemonic::Null) {
    finish(id, false, fmt::format("'{}' is not a UIM242 controller instruction", p.mnemonic), kMalformed);
    return;
  }
  Instruction in = bare(*m);
  std::function<std::int64_t(const Frame&)> value_of;
  const auto layout = [](const Instruction& i) { return uim242::reply_form(i).layout; };
  if (write) {
    const auto out_of_range = [&] {
      finish(id, false, fmt::format("{} (node {}): value {} outside the range of {}", d.name, d.node, p.value, p.mnemonic),
             kOutsideLimits);
    };
    const bool by_register = (*m == Mnemonic::SCF || *m == Mnemonic::STG) && p.subindex >= 0;
    if (by_register) {
      // One 16-bit register (SCF 0..3, STG port 0..2): check before narrowing, or 70000 would
      // go out as 4464.
      const std::int32_t last = *m == Mnemonic::SCF ? 3 : 2;
      if (p.subindex > last) {
        finish(id, false, fmt::format("{} (node {}): {} has no register {} (0..{})", d.name, d.node, p.mnemonic, p.subindex, last),
               kOutsideLimits);
        return;
      }
      if (p.value < 0 || p.value > std::numeric_limits<std::uint16_t>::max()) return out_of_range();
      const auto value = static_cast<std::uint16_t>(p.value);
      in = *m == Mnemonic::SCF ? uim242::make_scf({static_cast<uim242::SensorRegister>(p.subindex), value})
                               : uim242::make_stg({static_cast<std::uint8_t>(p.subindex), value});
    } else {
      in = set(*m, p.value);
    }
    if (uim242::validate(in)) return out_of_range();
    const std::int64_t written = p.value;
    value_of = [written](const Frame&) { return written; };
  } else {
    switch (*m) {
      case Mnemonic::CUR:
      case Mnemonic::MCS:
        in = bare(Mnemonic::Null);  // their values come with the basic ACK (§2.4)
        value_of = [mm = *m](const Frame& f) {
          const auto s = uim242::decode_status(f);
          return s ? std::int64_t{mm == Mnemonic::CUR ? s->current_tenths : s->micro_steps} : 0;
        };
        break;
      case Mnemonic::ENA: in = Instruction{Mnemonic::ENA, false, 0xFFFF, true}; break;
      case Mnemonic::MDL: in = set(Mnemonic::MDL, d.node); break;
      case Mnemonic::OFF: case Mnemonic::ORG: case Mnemonic::STO:
        finish(id, false, fmt::format("{} has no read form (its bare form acts)", p.mnemonic), kUnsupported);
        return;
      default: break;
    }
    if (!value_of) {
      const Instruction sent = in;
      const std::int32_t sub = p.subindex;
      value_of = [sent, sub, layout](const Frame& f) -> std::int64_t {
        const auto l = layout(sent);
        switch (l) {
          case uim242::Layout::flag_u32: return field(f, l, 1);
          case uim242::Layout::model: return field(f, l, 4);
          case uim242::Layout::status: return field(f, l, 3);
          case uim242::Layout::stg: return field(f, l, static_cast<std::size_t>(std::max(sub, 0)));
          case uim242::Layout::sensors: return field(f, l, static_cast<std::size_t>(std::clamp(sub, 0, 3)));
          case uim242::Layout::scf: {
            const auto regs = field(f, l, 0);
            if (sub == 0) return regs & 0xFFFF;
            if (sub == 1) return (regs >> 16) & 0xFFFF;
            if (sub == 2 || sub == 3) return field(f, l, static_cast<std::size_t>(sub - 1));
            return regs;
          }
          default: return field(f, l, 0);
        }
      };
    }
  }
  submit(d, in, id, [this, id, p, value_of](const Frame& f, TimePoint) {
    motionlcm::param_t out = p;
    out.value = value_of(f);
    finish(id, true, {}, 0, out);
  });
}

}  // namespace motion::uim242_driver
