#include "motion/adam_driver/master_core.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include <fmt/format.h>

#include <motionlcm/event_t.hpp>

#include "motion/adam/commands.hpp"
#include "motion/adam/registers.hpp"
#include "motion/adam/table.hpp"
#include "motion/adam/units.hpp"

namespace motion::adam_driver {

using adam::Reg;
namespace rtu = adam::rtu;
using Reply = motionlcm::gateway_reply_t;
using Event = motionlcm::event_t;

namespace {

// Status polling reads position and status in one frame (0x0004…0x0007, §8.3, §8.4) and outputs +
// alarm in another.
constexpr std::uint16_t kPositionStatusWords = 4;
constexpr std::uint16_t kOutputsAlarmWords = 2;
// Where the driver keeps each drive's one-entry table: register 300 + 200 = 500, clear of a stored
// program at 300…499 (the manual's own §8.54 layout).
constexpr std::uint16_t kTableStartOffset = 200;
// A drive seen idle (and not where it should be) this many polls after a start has stopped short.
constexpr int kIdlePollsBeforeShortStop = 3;
// An offline drive is polled this many times less often, without retries, so that it does not
// take the line from the drives that answer.
constexpr int kOfflinePollDivider = 10;
// Default homing speed when the command gives none (assumed: §8.48 gives no default).
constexpr std::uint16_t kDefaultHomingRpm = 60;
constexpr std::uint8_t kMaxOutputs = 8;  // Y0…Y7 (§8.51)
// 0x0017 above any real encoder's lines forces open loop (§8.18).
constexpr std::uint16_t kForceOpenLoopLines = 0xFFFF;
// Reply latency assumed (the manual gives none) for the predicted skew of a sequential start.
constexpr auto kAssumedDriveLatency = std::chrono::milliseconds(1);

std::string hex16(std::uint32_t value) { return fmt::format("0x{:04X}", value); }

std::string register_name(std::uint16_t address) {
  const auto* info = adam::register_containing(address);
  return info ? " (" + std::string(info->name) + ")" : std::string{};
}

std::int64_t setup_int(const config::SetupValue& v) {
  if (const auto* i = std::get_if<long long>(&v)) return *i;
  if (const auto* d = std::get_if<double>(&v)) return std::llround(*d);
  if (const auto* b = std::get_if<bool>(&v)) return *b ? 1 : 0;
  return 0;
}
double setup_number(const config::SetupValue& v) {
  if (const auto* d = std::get_if<double>(&v)) return *d;
  return static_cast<double>(setup_int(v));
}

}  // namespace

MasterSettings settings_from_config(const config::Config& config, const config::Bus& bus) {
  MasterSettings s;
  s.bus = bus.name;
  s.transport = bus.transport;
  s.format.baud = static_cast<std::uint32_t>(bus.baud);
  s.format.parity = bus.parity == 'E' ? rtu::Parity::even : bus.parity == 'O' ? rtu::Parity::odd : rtu::Parity::none;
  s.format.stop_bits = static_cast<std::uint8_t>(bus.stop_bits);
  s.poll_period = std::chrono::duration_cast<Duration>(std::chrono::duration<double>(1.0 / std::max(bus.poll_hz, 0.1)));
  for (const auto& d : config.drives) {
    if (d.bus != bus.name || d.family != config::Family::kAdamModbus) continue;
    DriveSettings ds;
    ds.drive = d.name;
    ds.unit = static_cast<std::uint8_t>(d.node_id);
    ds.request_timeout = std::chrono::milliseconds(d.request_timeout_ms.value_or(bus.request_timeout_ms));
    ds.retries = d.retries.value_or(bus.retries);
    for (const auto& a : config.axes) {
      if (a.drive != d.name) continue;
      ds.axis = a.name;
      ds.home_input = a.homing.input;
      ds.homing_method = a.homing.method;
    }
    if (const auto pulses = adam::setup_pulses_per_revolution(d.setup_integer("pulses_per_revolution"),
                                                                d.setup_integer("subdivision"))) {
      const auto w = adam::encode32(static_cast<std::uint32_t>(*pulses));
      ds.setup_writes.push_back({adam::address(Reg::subdivision), {w[0], w[1]}});
    }
    if (const auto it = d.setup.find("current_a"); it != d.setup.end()) {
      ds.setup_writes.push_back(
          {adam::address(Reg::rated_current), {static_cast<std::uint16_t>(std::lround(setup_number(it->second) * 100))}});
    }
    if (const auto it = d.setup.find("closed_loop"); it != d.setup.end() && setup_int(it->second) == 0) {
      ds.setup_writes.push_back({adam::address(Reg::min_encoder_lines), {kForceOpenLoopLines}});
    }
    s.drives.push_back(std::move(ds));
  }
  return s;
}

// ---- State --------------------------------------------------------------------------------------

struct MasterCore::Drive {
  DriveSettings cfg;
  bool online = false;
  bool ever_answered = false;
  bool set_up = false;
  bool setup_running = false;
  bool enabled = true;  // until 0x0012 bit 4 is read
  bool homed = false;
  std::uint32_t pulses_per_rev = adam::kDefaultSubdivision;
  std::optional<std::int32_t> position;
  std::optional<adam::DriveStatus> status;
  adam::AlarmState alarm{};
  std::uint16_t outputs = 0;
  double velocity = 0;
  TimePoint position_time{};
  std::int64_t sample_utime = 0;
  std::int64_t target = 0;
  std::optional<std::int32_t> table_entry;  // what this driver loaded as table entry 0
  bool poll_queued = false;
  int poll_skips = 0;
  std::int64_t motion_owner = 0;  // command holding the axis (armed or moving), 0 = none
};

struct MasterCore::Transaction {
  Transaction(rtu::Request r, Drive* d, std::int64_t id = 0) : request(std::move(r)), drive(d), command_id(id) {}
  rtu::Request request;
  Drive* drive = nullptr;  // nullptr: broadcast
  std::int64_t command_id = 0;  // 0: polling / start-up
  std::function<void(const rtu::Response&, TimePoint now, TimePoint frame_end)> on_reply;
  std::function<void(const std::string& reason, std::int32_t code)> on_fail;
  int attempts = 0;
  int max_retries = 0;
  bool is_poll = false;
  TimePoint frame_end{};
};

struct MasterCore::Operation {
  motionlcm::gateway_command_t command;
  std::vector<Drive*> drives;  // aligned with command.axes
  std::size_t outstanding = 0;
  std::function<void(TimePoint)> on_transferred;
  enum class Phase { transferring, armed, moving } phase = Phase::transferring;
  enum class Goal { none, reach_target, reach_home, stand_still } goal = Goal::none;
  std::set<Drive*> arrived;
  std::map<Drive*, int> idle_polls;
  std::set<Drive*> seen_moving;
  std::int64_t trigger_utime = 0;
};

MasterCore::MasterCore(MasterSettings settings, Send send, gateway::GatewayOutput& out, WallClock wall_clock)
    : settings_(std::move(settings)),
      send_(std::move(send)),
      out_(out),
      wall_clock_(wall_clock ? std::move(wall_clock) : WallClock{&wall_time_us}),
      timing_(rtu::frame_timing(settings_.format)),
      framer_(timing_.t3_5) {
  for (const auto& d : settings_.drives) {
    auto drive = std::make_unique<Drive>();
    drive->cfg = d;
    drives_.push_back(std::move(drive));
  }
}

MasterCore::~MasterCore() = default;

// ---- Line ---------------------------------------------------------------------------------------

void MasterCore::enqueue(Transaction t, bool urgent) {
  if (t.drive && !t.is_poll) t.max_retries = t.drive->cfg.retries;
  if (urgent) {
    queue_.push_front(std::move(t));
  } else if (t.is_poll) {
    queue_.push_back(std::move(t));
  } else {
    // Commands (and set-up) go before the polls already queued, in their own order: with N
    // drives a poll round queues 2N reads, which a command must not wait behind.
    const auto first_poll = std::find_if(queue_.begin(), queue_.end(), [](const Transaction& q) { return q.is_poll; });
    queue_.insert(first_poll, std::move(t));
  }
}

std::string MasterCore::describe(const Transaction& t) const {
  if (const auto* read = std::get_if<rtu::ReadRegisters>(&t.request.pdu)) {
    const std::uint32_t last = std::uint32_t{read->start} + read->quantity - 1;
    return "reading register " + hex16(read->start) + (last != read->start ? "…" + hex16(last) : "") +
           register_name(read->start);
  }
  const std::uint16_t reg = std::holds_alternative<rtu::WriteRegister>(t.request.pdu)
                                ? std::get<rtu::WriteRegister>(t.request.pdu).address
                                : std::get<rtu::WriteRegisters>(t.request.pdu).start;
  return "writing register " + hex16(reg) + register_name(reg);
}

void MasterCore::send_next(TimePoint now) {
  while (!in_flight_ && !queue_.empty() && now >= line_free_at_) {
    Transaction t = std::move(queue_.front());
    queue_.pop_front();
    auto frame = rtu::encode_request(t.request);
    if (!frame) {  // only a programming error gets here (the builders validate)
      if (t.on_fail) t.on_fail("cannot encode " + describe(t) + ": " + frame.error().message(), error_code(ReplyError::kMalformedRequest));
      continue;
    }
    const auto& bytes = frame.value();
    if (!line_open_ || !send_(bytes)) {
      ++errors_;
      if (t.on_fail) t.on_fail("serial line of bus " + settings_.bus + " not writable while " + describe(t), error_code(ReplyError::kTimeout));
      continue;
    }
    ++tx_frames_;
    tx_bytes_ += static_cast<std::int64_t>(bytes.size());
    const Duration on_wire = rtu::transmission_time(settings_.format, bytes.size());
    busy_time_ += on_wire;
    if (first_activity_ == kNever) first_activity_ = now;
    last_activity_ = now;
    t.frame_end = now + on_wire;
    ++t.attempts;
    framer_.clear();  // anything before our request is not its reply
    if (t.drive == nullptr) {
      // Broadcast: executed by every drive, answered by none (§5). Keep the line silent long
      // enough for every drive to see the frame end and act before the next one.
      line_free_at_ = t.frame_end + timing_.t3_5 + settings_.broadcast_guard;
      if (t.on_reply) t.on_reply(rtu::Response{}, now, t.frame_end);
      continue;
    }
    if (!adam::expects_reply(t.request)) {  // restart (§8.67): no reply even when addressed
      line_free_at_ = t.frame_end + timing_.t3_5 + settings_.broadcast_guard;
      if (t.on_reply) t.on_reply(rtu::Response{}, now, t.frame_end);
      continue;
    }
    reply_deadline_ = t.frame_end + t.drive->cfg.request_timeout;
    in_flight_ = std::make_unique<Transaction>(std::move(t));
  }
}

std::optional<std::size_t> MasterCore::expected_reply_size(std::span<const std::uint8_t> pending) const {
  if (!in_flight_ || pending.size() < 2) return std::nullopt;
  if ((pending[1] & rtu::kExceptionFlag) != 0) return 5;  // unit, function|0x80, code, CRC
  if (const auto* read = std::get_if<rtu::ReadRegisters>(&in_flight_->request.pdu)) return 5U + 2U * read->quantity;
  return 8;  // FC 0x06 echo, FC 0x10 start + quantity
}

void MasterCore::on_bytes(std::span<const std::uint8_t> bytes, TimePoint now) {
  framer_.push(bytes, now);
  const auto pending = framer_.pending();
  // A pty delivers a frame at once; closing it at its known length saves the t3.5 wait. A frame
  // of the right length with a bad CRC waits for the silence (more garbage may follow).
  if (const auto size = expected_reply_size(pending); size && pending.size() == *size && rtu::crc_ok(pending)) {
    on_reply_frame(framer_.complete_now(), now);
  }
}

void MasterCore::on_reply_frame(std::vector<std::uint8_t> frame, TimePoint now) {
  ++rx_frames_;
  rx_bytes_ += static_cast<std::int64_t>(frame.size());
  busy_time_ += rtu::transmission_time(settings_.format, frame.size());
  last_activity_ = now;
  line_free_at_ = std::max(line_free_at_, now + timing_.t3_5);
  if (!in_flight_) {
    ++errors_;
    event(nullptr, Event::PROTOCOL_ERROR, Event::WARNING, 0,
          "unsolicited " + std::to_string(frame.size()) + "-byte frame on bus " + settings_.bus + " dropped");
    return;
  }
  auto decoded = rtu::decode_response(frame, in_flight_->request);
  Drive& d = *in_flight_->drive;
  const std::string who = "drive " + d.cfg.drive + " (slave " + std::to_string(d.cfg.unit) + ")";
  if (!decoded) {
    ++errors_;
    const bool crc = decoded.error() == rtu::FrameErrc::bad_crc;
    const std::string what = (crc ? "CRC error in the reply of " : "malformed reply (" + decoded.error().message() + ") from ") +
                             who + " " + describe(*in_flight_);
    event(&d, Event::PROTOCOL_ERROR, Event::WARNING, decoded.error().value(), what);
    retry_or_fail(what, error_code(ReplyError::kDriveError), now);
    return;
  }
  set_online(d, true, {});
  if (const auto* exception = std::get_if<rtu::ExceptionReply>(&decoded.value().pdu)) {
    const auto code = make_error_code(exception->code);
    const std::string what = who + " refused " + describe(*in_flight_) + ": Modbus exception " +
                             std::to_string(static_cast<int>(exception->code)) + " (" + code.message() + ")";
    event(&d, Event::ERROR_REPORT, Event::ERROR, static_cast<std::int32_t>(exception->code), what);
    auto t = std::move(in_flight_);
    reply_deadline_ = kNever;
    if (t->on_fail) t->on_fail(what, error_code(ReplyError::kDriveError));
    return;
  }
  complete_in_flight(decoded.value(), now);
}

void MasterCore::complete_in_flight(const rtu::Response& response, TimePoint now) {
  auto t = std::move(in_flight_);
  reply_deadline_ = kNever;
  if (t->on_reply) t->on_reply(response, now, t->frame_end);
}

void MasterCore::on_timeout(TimePoint now) {
  ++timeouts_;
  Drive& d = *in_flight_->drive;
  const std::string what = "drive " + d.cfg.drive + " (slave " + std::to_string(d.cfg.unit) + ") did not answer " +
                           describe(*in_flight_) + " within " +
                           std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(d.cfg.request_timeout).count()) +
                           " ms";
  line_free_at_ = now;  // the silence has long elapsed
  retry_or_fail(what, error_code(ReplyError::kTimeout), now);
}

void MasterCore::retry_or_fail(const std::string& why, std::int32_t code, TimePoint now) {
  framer_.clear();
  reply_deadline_ = kNever;
  auto t = std::move(in_flight_);
  if (t->attempts <= t->max_retries) {
    ++retries_;
    queue_.push_front(std::move(*t));  // the same request again, before anything else
    send_next(now);
    return;
  }
  const std::string reason = why + " (" + std::to_string(t->attempts) + (t->attempts == 1 ? " attempt)" : " attempts)");
  // No reply, or only garbled ones (CRC, malformed) on every attempt: the drive cannot be heard,
  // so its last state (position, "moving") is no longer known; it is offline until a reply decodes.
  set_online(*t->drive, false, reason);
  if (t->on_fail) t->on_fail(reason, code);
}

TimePoint MasterCore::process(TimePoint now) {
  if (in_flight_) {
    if (auto frame = framer_.take_if_silent(now)) on_reply_frame(std::move(*frame), now);
  } else if (auto stray = framer_.take_if_silent(now)) {
    on_reply_frame(std::move(*stray), now);  // counted and reported as unsolicited
  }
  if (in_flight_ && now >= reply_deadline_) on_timeout(now);
  if (started_ && now >= next_poll_) {
    poll(now);
    // Fixed rate, but never a burst of catch-up polls after a long stall.
    next_poll_ = std::max(next_poll_ + settings_.poll_period, now);
  }
  send_next(now);

  TimePoint next = started_ ? next_poll_ : kNever;
  if (in_flight_) next = std::min({next, reply_deadline_, framer_.deadline()});
  else if (!queue_.empty()) next = std::min(next, line_free_at_);
  if (!in_flight_ && !framer_.pending().empty()) next = std::min(next, framer_.deadline());
  return next;
}

void MasterCore::line_lost(const std::string& why, TimePoint now) {
  (void)now;
  line_open_ = false;
  event(nullptr, Event::OFFLINE, Event::ERROR, 0, "serial line of bus " + settings_.bus + " lost: " + why);
  std::vector<std::int64_t> ids;
  for (const auto& [id, op] : operations_) ids.push_back(id);
  for (const auto id : ids) finish(id, Reply::FAILED, "serial line of bus " + settings_.bus + " lost: " + why, error_code(ReplyError::kTimeout));
  queue_.clear();
  in_flight_.reset();
  reply_deadline_ = kNever;
  for (auto& d : drives_) {
    d->poll_queued = false;
    set_online(*d, false, why);
  }
}

// ---- Drives and polling -------------------------------------------------------------------------

void MasterCore::start(TimePoint now) {
  started_ = true;
  line_open_ = true;
  line_free_at_ = now;
  next_poll_ = now;
  for (auto& d : drives_) run_setup(*d);
  send_next(now);
}

void MasterCore::run_setup(Drive& d) {
  Drive* drive = &d;
  drive->setup_running = true;
  const auto setup_failed = [this, drive](const std::string& reason, std::int32_t) {
    drive->setup_running = false;
    event(drive, Event::CONFIG_MISMATCH, Event::ERROR, 0, "set-up of " + drive->cfg.drive + " failed: " + reason);
  };
  Transaction power_on{adam::read(drive->cfg.unit, Reg::protection_bits), drive};
  power_on.on_reply = [drive](const rtu::Response& r, TimePoint, TimePoint) {
    const auto& v = std::get<rtu::ReadRegistersReply>(r.pdu).values;
    drive->enabled = (v.at(0) & static_cast<std::uint16_t>(adam::ProtectionBit::disabled_at_power_on)) == 0;
  };
  power_on.on_fail = setup_failed;
  enqueue(std::move(power_on));
  for (const auto& [reg, words] : drive->cfg.setup_writes) {
    rtu::Request request{drive->cfg.unit, words.size() == 1 ? rtu::RequestPdu{rtu::WriteRegister{reg, words[0]}}
                                                            : rtu::RequestPdu{rtu::WriteRegisters{reg, words}}};
    Transaction write{request, drive};
    write.on_fail = setup_failed;
    enqueue(std::move(write));
  }
  Transaction subdivision{adam::read(drive->cfg.unit, Reg::subdivision), drive};
  subdivision.on_reply = [this, drive](const rtu::Response& r, TimePoint, TimePoint) {
    const auto& v = std::get<rtu::ReadRegistersReply>(r.pdu).values;
    const std::uint32_t ppr = adam::decode32(v.at(0), v.at(1));
    drive->setup_running = false;
    if (!adam::check_subdivision(ppr)) {
      event(drive, Event::CONFIG_MISMATCH, Event::ERROR, 0,
            drive->cfg.drive + " reports subdivision " + std::to_string(ppr) + " outside 200…1000000 pulses/rev");
      return;
    }
    drive->pulses_per_rev = ppr;
    drive->set_up = true;
  };
  subdivision.on_fail = setup_failed;
  enqueue(std::move(subdivision));
}

void MasterCore::poll(TimePoint now) {
  (void)now;
  for (auto& d : drives_) {
    Drive* drive = d.get();
    if (drive->poll_queued) continue;
    // A drive that was not there at start-up (or failed its set-up) is set up once it answers.
    if (drive->online && !drive->set_up && !drive->setup_running) run_setup(*drive);
    if (!drive->online && drive->ever_answered && ++drive->poll_skips % kOfflinePollDivider != 0) continue;
    drive->poll_queued = true;
    Transaction position{{drive->cfg.unit, rtu::ReadRegisters{adam::address(Reg::position), kPositionStatusWords}}, drive};
    position.is_poll = true;
    position.on_reply = [this, drive](const rtu::Response& r, TimePoint at, TimePoint) {
      on_position_status(*drive, std::get<rtu::ReadRegistersReply>(r.pdu).values, at);
    };
    position.on_fail = [drive](const std::string&, std::int32_t) { drive->poll_queued = false; };
    Transaction alarm{{drive->cfg.unit, rtu::ReadRegisters{adam::address(Reg::output_state), kOutputsAlarmWords}}, drive};
    alarm.is_poll = true;
    alarm.on_reply = [this, drive](const rtu::Response& r, TimePoint at, TimePoint) {
      drive->poll_queued = false;
      on_outputs_alarm(*drive, std::get<rtu::ReadRegistersReply>(r.pdu).values, at);
    };
    alarm.on_fail = position.on_fail;
    const bool answering = drive->online || !drive->ever_answered;
    // An offline drive gets one try per poll; a live one its configured retries.
    position.max_retries = answering ? drive->cfg.retries : 0;
    alarm.max_retries = position.max_retries;
    enqueue(std::move(position));
    enqueue(std::move(alarm));
  }
}

void MasterCore::on_position_status(Drive& d, std::span<const std::uint16_t> words, TimePoint now) {
  const std::int32_t position = adam::decode32_signed(words[0], words[1]);
  const adam::DriveStatus status = adam::decode_status(words[2], words[3]);
  if (d.position) {
    const double dt = std::chrono::duration<double>(now - d.position_time).count();
    if (dt > 0) d.velocity = (position - *d.position) / dt;
  }
  if (!status.moving()) d.velocity = 0;
  const bool limit_before = d.status && d.status->at_limit();
  d.position = position;
  d.position_time = now;
  d.sample_utime = wall_clock_();
  d.status = status;
  if (status.at_limit() && !limit_before) {
    event(&d, Event::LIMIT, Event::WARNING, status.negative_limit ? -1 : 1,
          d.cfg.drive + " at its " + (status.negative_limit ? "negative" : "positive") + " limit, position " +
              std::to_string(position));
  }
  publish_status(d);
  std::vector<Operation*> watching;
  for (auto& [id, op] : operations_) {
    if (op->phase == Operation::Phase::moving &&
        std::find(op->drives.begin(), op->drives.end(), &d) != op->drives.end())
      watching.push_back(op.get());
  }
  for (Operation* op : watching) check_motion(*op, d, now);  // may finish (erase) ops: iterate a copy
}

void MasterCore::on_outputs_alarm(Drive& d, std::span<const std::uint16_t> words, TimePoint now) {
  (void)now;
  d.outputs = words[0];
  const adam::AlarmState alarm = adam::decode_alarms(words[1]);
  const bool new_alarm = alarm.active() && alarm.current != d.alarm.current;
  d.alarm = alarm;
  if (new_alarm) {
    const std::string text = d.cfg.drive + " alarm " + std::to_string(static_cast<int>(alarm.current)) + ": " +
                             std::string(adam::alarm_text(alarm.current));
    event(&d, Event::ALARM, Event::ERROR, static_cast<std::int32_t>(alarm.current), text);
    fail_motion_of(d, text, error_code(ReplyError::kAxisFaulted));
  }
  publish_status(d);
}

void MasterCore::publish_status(const Drive& d) const {
  if (d.cfg.axis.empty()) return;
  gateway::DriveStatus s;
  s.sample_utime = d.sample_utime;
  s.position_counts = d.position.value_or(0);
  s.velocity_counts = d.velocity;
  s.target_counts = d.target;
  // Online for the axis's users once its position and status are known (a set-up reply alone
  // would publish position 0, and a relative move would be planned from it).
  s.online = d.online && d.position.has_value() && d.status.has_value();
  s.enabled = d.enabled;
  s.moving = d.status && d.status->moving();
  s.in_position = d.status && d.status->in_position;
  s.homed = d.homed;
  s.fault = d.alarm.active();
  s.fault_code = static_cast<std::int32_t>(d.alarm.current);
  s.fault_text = d.alarm.active() ? std::string(adam::alarm_text(d.alarm.current)) : std::string{};
  s.inputs = d.status ? d.status->inputs : 0;  // bit n = Xn = input n+1
  s.outputs = d.outputs & 0xFF;                // bit n = Yn = output n+1
  out_.axis_status(d.cfg.axis, s);
}

void MasterCore::set_online(Drive& d, bool online, const std::string& why) {
  if (online) d.ever_answered = true;
  if (d.online == online) return;
  d.online = online;
  d.poll_skips = 0;
  if (online) {
    event(&d, Event::ONLINE, Event::INFO, 0, d.cfg.drive + " (slave " + std::to_string(d.cfg.unit) + ") answers");
  } else {
    event(&d, Event::OFFLINE, Event::ERROR, 0, d.cfg.drive + " (slave " + std::to_string(d.cfg.unit) + ") offline: " + why);
  }
  publish_status(d);
}

void MasterCore::event(const Drive* d, std::int16_t kind, std::int8_t severity, std::int32_t code,
                       const std::string& text) const {
  gateway::DriveEvent e;
  e.kind = kind;
  e.severity = severity;
  e.code = code;
  e.text = text;
  out_.axis_event(d ? d->cfg.axis : std::string{}, e);
}

MasterCore::Drive* MasterCore::drive_of_axis(const std::string& axis) {
  for (auto& d : drives_) {
    if (!axis.empty() && d->cfg.axis == axis) return d.get();
  }
  return nullptr;
}

double MasterCore::rpm_of(const Drive& d, double counts_per_s) const {
  return adam::pps_to_rpm(counts_per_s, d.pulses_per_rev);
}

motionlcm::bus_stats_t MasterCore::statistics() const {
  motionlcm::bus_stats_t s{};
  s.name = settings_.bus;
  s.transport = settings_.transport;
  s.state = line_open_ ? (started_ ? "open" : "closed") : "lost";
  s.tx_frames = tx_frames_;
  s.rx_frames = rx_frames_;
  s.tx_bytes = tx_bytes_;
  s.rx_bytes = rx_bytes_;
  s.errors = errors_;
  s.timeouts = timeouts_;
  s.retries = retries_;
  if (first_activity_ != kNever && last_activity_ > first_activity_) {
    s.bus_load = std::min(1.0, std::chrono::duration<double>(busy_time_).count() /
                                   std::chrono::duration<double>(last_activity_ - first_activity_).count());
  }
  s.drives_total = static_cast<std::int32_t>(drives_.size());
  s.drives_online = static_cast<std::int32_t>(std::count_if(drives_.begin(), drives_.end(), [](const auto& d) { return d->online; }));
  return s;
}

bool MasterCore::ready() const {
  return started_ && line_open_ && std::all_of(drives_.begin(), drives_.end(), [](const auto& d) { return d->online && d->set_up; });
}

// ---- Commands -----------------------------------------------------------------------------------

MasterCore::Operation& MasterCore::open_operation(const motionlcm::gateway_command_t& command, std::vector<Drive*> drives) {
  auto op = std::make_unique<Operation>();
  op->command = command;
  op->drives = std::move(drives);
  auto& ref = *op;
  operations_[command.command_id] = std::move(op);
  return ref;
}

void MasterCore::add_write(Operation& op, Drive& d, const rtu::Request& request, std::function<void(TimePoint)> after) {
  ++op.outstanding;
  const std::int64_t id = op.command.command_id;
  Transaction t{request, &d, id};
  t.on_reply = [this, id, after = std::move(after)](const rtu::Response&, TimePoint now, TimePoint) {
    const auto it = operations_.find(id);
    if (it == operations_.end()) return;
    Operation& o = *it->second;
    if (after) after(now);  // may add writes: count them before this one is taken off
    if (--o.outstanding == 0 && o.on_transferred) std::exchange(o.on_transferred, {})(now);
  };
  t.on_fail = [this, id](const std::string& reason, std::int32_t code) { finish(id, Reply::FAILED, reason, code); };
  enqueue(std::move(t));
}

void MasterCore::when_transferred(Operation& op, std::function<void(TimePoint)> next) {
  op.on_transferred = std::move(next);
}

void MasterCore::reply(const Operation& op, std::int8_t status, const std::string& reason, std::int32_t code,
                       std::function<void(Reply&)> fill) {
  Reply r{};
  r.command_id = op.command.command_id;
  r.status = status;
  r.reason = reason;
  r.error_code = code;
  if (fill) fill(r);
  out_.command_reply(std::move(r));
}

void MasterCore::finish(std::int64_t command_id, std::int8_t status, const std::string& reason, std::int32_t code,
                        std::function<void(Reply&)> fill) {
  const auto it = operations_.find(command_id);
  if (it == operations_.end()) return;  // already ended: exactly one terminal reply
  auto op = std::move(it->second);
  operations_.erase(it);
  std::erase_if(queue_, [command_id](const Transaction& t) { return t.command_id == command_id; });
  for (Drive* d : op->drives) {
    if (d->motion_owner == command_id) d->motion_owner = 0;
  }
  reply(*op, status, reason, code, std::move(fill));
}

void MasterCore::fail_motion_of(const Drive& d, const std::string& reason, std::int32_t code) {
  if (d.motion_owner != 0) finish(d.motion_owner, Reply::FAILED, reason, code);
  // A jog or homing whose writes are still queued: they would start the motor after the stop.
  std::vector<std::int64_t> queued;
  for (const auto& [id, op] : operations_) {
    const auto kind = op->command.kind;
    const bool motion = kind == motionlcm::gateway_command_t::JOG || kind == motionlcm::gateway_command_t::HOME ||
                        kind == motionlcm::gateway_command_t::ARM_MOVE;
    if (motion && op->phase == Operation::Phase::transferring && std::find(op->drives.begin(), op->drives.end(), &d) != op->drives.end()) {
      queued.push_back(id);
    }
  }
  for (const auto id : queued) finish(id, Reply::FAILED, reason, code);
}

std::optional<std::string> MasterCore::busy_reason(const std::vector<Drive*>& drives) const {
  for (const Drive* d : drives) {
    if (d->motion_owner != 0)
      return "axis " + d->cfg.axis + " is busy with command " + std::to_string(d->motion_owner);
    if (d->alarm.active())
      return "axis " + d->cfg.axis + " is faulted: " + std::string(adam::alarm_text(d->alarm.current));
  }
  return std::nullopt;
}

void MasterCore::execute(const motionlcm::gateway_command_t& command, TimePoint now) {
  const auto refuse = [&](const std::string& reason, std::int32_t code) {
    Reply r{};
    r.command_id = command.command_id;
    r.status = Reply::FAILED;
    r.reason = reason;
    r.error_code = code;
    out_.command_reply(std::move(r));
  };
  if (operations_.contains(command.command_id)) return refuse("duplicate command id", error_code(ReplyError::kMalformedRequest));
  std::vector<Drive*> drives;
  for (const auto& a : command.axes) {
    Drive* d = drive_of_axis(a.axis);
    if (!d) return refuse("axis '" + a.axis + "' is not an ADAM axis of bus " + settings_.bus, error_code(ReplyError::kUnknownAxis));
    drives.push_back(d);
  }
  const bool needs_axes = command.kind != motionlcm::gateway_command_t::DISARM;
  if (needs_axes && drives.empty()) return refuse("command names no axis", error_code(ReplyError::kMalformedRequest));
  const std::string id_text = std::to_string(command.command_id);

  switch (command.kind) {
    case motionlcm::gateway_command_t::ENABLE:
    case motionlcm::gateway_command_t::DISABLE: {
      const bool enable = command.kind == motionlcm::gateway_command_t::ENABLE;
      auto& op = open_operation(command, drives);
      for (Drive* d : drives) {
        if (!enable) fail_motion_of(*d, "axis " + d->cfg.axis + " disabled by command " + id_text, error_code(ReplyError::kStopped));
        add_write(op, *d, adam::command(d->cfg.unit, enable ? adam::EnableCommand::enable : adam::EnableCommand::release),
                  [this, d, enable](TimePoint) {
                    d->enabled = enable;
                    publish_status(*d);
                  });
      }
      when_transferred(op, [this, id = command.command_id](TimePoint) { finish(id, Reply::DONE); });
      break;
    }
    case motionlcm::gateway_command_t::STOP:
    case motionlcm::gateway_command_t::ESTOP: {
      const bool emergency = command.kind == motionlcm::gateway_command_t::ESTOP;
      for (Drive* d : drives) {
        fail_motion_of(*d, "axis " + d->cfg.axis + " stopped by command " + id_text, error_code(ReplyError::kStopped));
      }
      auto& op = open_operation(command, drives);
      op.goal = Operation::Goal::stand_still;
      for (Drive* d : drives) {
        add_write(op, *d, adam::command(d->cfg.unit, emergency ? adam::VelocityCommand::emergency_stop
                                                               : adam::VelocityCommand::ramped_stop));
        // An e-stop leaves the motor released, as on every family (CiA 402 quick stop ends in
        // "switch on disabled").
        if (emergency) {
          add_write(op, *d, adam::command(d->cfg.unit, adam::EnableCommand::release), [this, d](TimePoint) {
            d->enabled = false;
            publish_status(*d);
          });
        }
      }
      // Urgent: a stop goes before queued polls and set-up (but after the frame on the line).
      std::stable_partition(queue_.begin(), queue_.end(),
                            [id = command.command_id](const Transaction& t) { return t.command_id == id; });
      when_transferred(op, [this, id = command.command_id](TimePoint) {
        if (auto it = operations_.find(id); it != operations_.end()) it->second->phase = Operation::Phase::moving;
      });
      break;
    }
    case motionlcm::gateway_command_t::JOG: {
      if (auto busy = busy_reason(drives)) return refuse(*busy, error_code(ReplyError::kAxisBusy));
      auto& op = open_operation(command, drives);
      for (std::size_t i = 0; i < drives.size(); ++i) {
        Drive& d = *drives[i];
        const auto& a = command.axes[i];
        const double rpm = std::abs(rpm_of(d, a.velocity));
        const auto speed = adam::jog_speed(rpm);
        if (!speed || (a.velocity != 0 && speed.value().value == 0)) {
          return finish(command.command_id, Reply::FAILED,
                        "axis " + a.axis + ": jog speed " + std::to_string(rpm) + " rpm outside 1…511 rpm (0x00CA, §8.65②)",
                        error_code(ReplyError::kMalformedRequest));
        }
        if (a.acceleration > 0 && speed.value().value > 0) {
          const double rate = std::abs(rpm_of(d, a.acceleration));
          const auto ramp = adam::ramp_time_ms(0, speed.value().realized, rate);
          if (ramp) {
            add_write(op, d, {d.cfg.unit, rtu::WriteRegisters{adam::address(Reg::start_speed),
                                                              {0, 0, ramp.value().value, ramp.value().value}}});
          }
        }
        adam::JogCommand jog;
        jog.direction = a.velocity < 0 ? adam::Rotation::ccw : adam::Rotation::cw;
        jog.speed_rpm = speed.value().value;
        jog.stop = adam::StopMethod::decelerate;
        jog.run = speed.value().value > 0;
        add_write(op, d, adam::write16(d.cfg.unit, Reg::jog_command, adam::encode(jog).value()));
      }
      when_transferred(op, [this, id = command.command_id](TimePoint) { finish(id, Reply::DONE); });
      break;
    }
    case motionlcm::gateway_command_t::HOME: {
      if (auto busy = busy_reason(drives)) return refuse(*busy, error_code(ReplyError::kAxisBusy));
      auto& op = open_operation(command, drives);
      op.goal = Operation::Goal::reach_home;
      bool any_switch = false;
      for (std::size_t i = 0; i < drives.size(); ++i) {
        Drive& d = *drives[i];
        const auto& a = command.axes[i];
        d.motion_owner = command.command_id;
        if (d.cfg.homing_method == config::HomingMethod::kNone) {
          return finish(command.command_id, Reply::FAILED, "axis " + a.axis + " has no homing method configured", error_code(ReplyError::kUnsupported));
        }
        if (d.cfg.homing_method == config::HomingMethod::kCurrentPosition) {
          add_write(op, d, adam::move(d.cfg.unit, adam::MoveCommand::preset_position, static_cast<std::int32_t>(a.target_counts)),
                    [&d](TimePoint) { d.homed = true; });
          op.arrived.insert(&d);
          continue;
        }
        any_switch = true;
        adam::InputPair inputs;  // high byte: enable input (off); low byte: home input (§8.48)
        inputs.low = {true, true, static_cast<std::uint8_t>(std::clamp(d.cfg.home_input - 1, 0, 15))};
        add_write(op, d, adam::write16(d.cfg.unit, Reg::enable_home_inputs, adam::encode(inputs).value()));
        const double rpm = std::abs(rpm_of(d, a.velocity));
        adam::HomingCommand home;
        home.direction = a.velocity < 0 ? adam::Travel::reverse : adam::Travel::forward;
        home.speed_rpm = a.velocity == 0 ? kDefaultHomingRpm
                                         : static_cast<std::uint16_t>(std::clamp(std::lround(rpm), 1L, long{adam::kMaxJogSpeedRpm}));
        home.stop = adam::StopMethod::immediate;  // stop ON the sensor: the position is zeroed there
        home.secondary_speed_code = 0;
        add_write(op, d, adam::write16(d.cfg.unit, Reg::homing_command, adam::encode(home).value()));
      }
      when_transferred(op, [this, id = command.command_id, any_switch](TimePoint) {
        if (!any_switch) return finish(id, Reply::DONE);
        if (auto it = operations_.find(id); it != operations_.end()) it->second->phase = Operation::Phase::moving;
      });
      break;
    }
    case motionlcm::gateway_command_t::ARM_MOVE: {
      if (auto busy = busy_reason(drives)) return refuse(*busy, error_code(ReplyError::kAxisBusy));
      for (Drive* d : drives) {
        if (d->status && d->status->moving())
          return refuse("axis " + d->cfg.axis + " is moving; stop it before arming a move", error_code(ReplyError::kAxisBusy));
      }
      auto& op = open_operation(command, drives);
      arm_move(op, now);
      break;
    }
    case motionlcm::gateway_command_t::FAULT_RESET: {
      auto& op = open_operation(command, drives);
      for (Drive* d : drives) add_write(op, *d, adam::clear_alarm(d->cfg.unit));
      when_transferred(op, [this, id = command.command_id](TimePoint) { finish(id, Reply::DONE); });
      break;
    }
    case motionlcm::gateway_command_t::SET_OUTPUTS: {
      auto& op = open_operation(command, drives);
      for (std::size_t i = 0; i < drives.size(); ++i) {
        const auto& a = command.axes[i];
        if ((a.output_mask & ~((1 << kMaxOutputs) - 1)) != 0) {
          return finish(command.command_id, Reply::FAILED,
                        "axis " + a.axis + ": output mask " + hex16(static_cast<std::uint32_t>(a.output_mask)) +
                            " names outputs beyond Y0…Y7",
                        error_code(ReplyError::kMalformedRequest));
        }
        const auto on = static_cast<std::uint16_t>(a.output_mask & a.output_value);
        const auto off = static_cast<std::uint16_t>(a.output_mask & ~a.output_value);
        if (on != 0) add_write(op, *drives[i], adam::write16(drives[i]->cfg.unit, Reg::outputs_on, on));
        if (off != 0) add_write(op, *drives[i], adam::write16(drives[i]->cfg.unit, Reg::outputs_off, off));
      }
      when_transferred(op, [this, id = command.command_id](TimePoint) { finish(id, Reply::DONE); });
      if (op.outstanding == 0) finish(command.command_id, Reply::DONE);
      break;
    }
    case motionlcm::gateway_command_t::SET_POSITION: {
      if (auto busy = busy_reason(drives)) return refuse(*busy, error_code(ReplyError::kAxisBusy));
      auto& op = open_operation(command, drives);
      for (std::size_t i = 0; i < drives.size(); ++i) {
        const auto target = command.axes[i].target_counts;
        if (target < std::numeric_limits<std::int32_t>::min() || target > std::numeric_limits<std::int32_t>::max()) {
          return finish(command.command_id, Reply::FAILED, "axis " + command.axes[i].axis + ": position outside INT32", error_code(ReplyError::kMalformedRequest));
        }
        add_write(op, *drives[i], adam::move(drives[i]->cfg.unit, adam::MoveCommand::preset_position, static_cast<std::int32_t>(target)));
      }
      when_transferred(op, [this, id = command.command_id](TimePoint) { finish(id, Reply::DONE); });
      break;
    }
    case motionlcm::gateway_command_t::PARAM_READ:
    case motionlcm::gateway_command_t::PARAM_WRITE: {
      if (drives.size() != 1) return refuse("a parameter command names exactly one axis", error_code(ReplyError::kMalformedRequest));
      auto& op = open_operation(command, drives);
      param(op, command.param);
      break;
    }
    case motionlcm::gateway_command_t::DISARM: {
      std::vector<std::int64_t> disarmed;
      for (const auto& [id, op] : operations_) {
        if (op->command.kind != motionlcm::gateway_command_t::ARM_MOVE || op->phase == Operation::Phase::moving) continue;
        const bool by_trigger = command.trigger_id != 0 && op->command.trigger_id == command.trigger_id;
        const bool by_axis = std::any_of(op->drives.begin(), op->drives.end(), [&](Drive* d) {
          return std::find(drives.begin(), drives.end(), d) != drives.end();
        });
        if (by_trigger || by_axis) disarmed.push_back(id);
      }
      for (const auto id : disarmed) finish(id, Reply::FAILED, "disarmed by command " + id_text, error_code(ReplyError::kStopped));
      reply(open_operation(command, drives), Reply::DONE, std::to_string(disarmed.size()) + " armed move(s) disarmed");
      operations_.erase(command.command_id);
      break;
    }
    default: return refuse("command kind " + std::to_string(command.kind) + " is not supported by the ADAM driver", error_code(ReplyError::kUnsupported));
  }
  send_next(now);
}

void MasterCore::arm_move(Operation& op, TimePoint now) {
  (void)now;
  const std::int64_t id = op.command.command_id;
  op.goal = Operation::Goal::reach_target;
  // Other drives of the line are made neutral (table entry 0 = where they stand), so that the
  // broadcast "execute table entry" moves only the armed ones. Queued first: done by ARMED.
  for (auto& other : drives_) {
    Drive* d = other.get();
    if (std::find(op.drives.begin(), op.drives.end(), d) != op.drives.end()) continue;
    if (!d->online || !d->position || d->motion_owner != 0 || (d->status && d->status->moving())) continue;
    if (d->table_entry == d->position) continue;
    const std::int32_t here = *d->position;
    const std::int32_t entry[] = {here};
    auto writes = adam::table_data_writes(d->cfg.unit, kTableStartOffset, entry);
    if (!writes) continue;
    writes.value().push_back(adam::write16(d->cfg.unit, Reg::table_size, 1));
    writes.value().push_back(adam::write16(d->cfg.unit, Reg::table_pointer, 0));
    writes.value().push_back(adam::write16(d->cfg.unit, Reg::table_start, kTableStartOffset));
    for (std::size_t i = 0; i < writes.value().size(); ++i) {
      Transaction t{writes.value()[i], d};
      if (i + 1 == writes.value().size()) t.on_reply = [d, here](const rtu::Response&, TimePoint, TimePoint) { d->table_entry = here; };
      t.on_fail = [this, d](const std::string& reason, std::int32_t) {
        event(d, Event::ERROR_REPORT, Event::WARNING, 0, "could not neutralize the table of " + d->cfg.drive + ": " + reason);
      };
      enqueue(std::move(t));
    }
  }
  for (std::size_t i = 0; i < op.drives.size(); ++i) {
    Drive& d = *op.drives[i];
    const auto& a = op.command.axes[i];
    const auto fail = [&](const std::string& why) { finish(id, Reply::FAILED, "axis " + a.axis + ": " + why, error_code(ReplyError::kArmFailed)); };
    if (a.target_counts < std::numeric_limits<std::int32_t>::min() || a.target_counts > std::numeric_limits<std::int32_t>::max())
      return fail("target " + std::to_string(a.target_counts) + " outside INT32 pulses");
    if (!(a.velocity > 0) || !(a.acceleration > 0) || !(a.deceleration > 0))
      return fail("velocity, acceleration and deceleration must be positive");
    const auto speed = adam::target_speed_from_pps(a.velocity, d.pulses_per_rev);
    if (!speed || speed.value().value <= 0)
      return fail("speed " + std::to_string(a.velocity) + " counts/s is outside 0.01…9999.99 rpm (0x00D8)");
    const double rpm = speed.value().value * adam::kTargetSpeedRpmPerStep;
    // Start and stop speed 0 (§8.40, §8.41; ramp times per §8.42, §8.43): the ramps are then
    // exactly v/a, the planned trapezoid.
    const auto accel = adam::ramp_time_ms(0, rpm, std::abs(rpm_of(d, a.acceleration)));
    const auto decel = adam::ramp_time_ms(0, rpm, std::abs(rpm_of(d, a.deceleration)));
    if (!accel || !decel) return fail("ramp time outside 0…65535 ms (0x0098/0x0099)");
    adam::SyncMovePreload preload;
    preload.profile = {0, 0, accel.value().value, decel.value().value, speed.value().value};
    preload.target_pulses = static_cast<std::int32_t>(a.target_counts);
    preload.start_offset = kTableStartOffset;
    auto writes = adam::sync_move_preload(d.cfg.unit, preload);
    if (!writes) return fail("cannot preload: " + writes.error().message());
    d.motion_owner = id;
    for (std::size_t w = 0; w < writes.value().size(); ++w) {
      std::function<void(TimePoint)> after;
      if (w + 1 == writes.value().size()) after = [&d, target = preload.target_pulses](TimePoint) { d.table_entry = target; };
      add_write(op, d, writes.value()[w], std::move(after));
    }
  }
  when_transferred(op, [this, id](TimePoint at) {
    const auto it = operations_.find(id);
    if (it == operations_.end()) return;
    Operation& armed = *it->second;
    armed.phase = Operation::Phase::armed;
    reply(armed, Reply::ARMED);
    if (armed.command.trigger_id == 0) start_armed(armed, at);
  });
}

bool MasterCore::neutral_for(const Drive& d, const Operation& firing) const {
  if (std::find(firing.drives.begin(), firing.drives.end(), &d) != firing.drives.end()) return true;
  // Executing its table entry must move nothing: idle, entry = position, and no command of ours
  // pending on it. A drive that never answered cannot be vouched for.
  return d.motion_owner == 0 && d.status && !d.status->moving() && d.position && d.table_entry == d.position;
}

void MasterCore::fire(std::int64_t trigger_id, TimePoint now) {
  std::vector<std::int64_t> ids;
  for (const auto& [id, op] : operations_) {
    if (op->phase == Operation::Phase::armed && op->command.trigger_id == trigger_id) ids.push_back(id);
  }
  for (const auto id : ids) {
    if (auto it = operations_.find(id); it != operations_.end()) start_armed(*it->second, now);
  }
  send_next(now);
}

void MasterCore::start_armed(Operation& op, TimePoint now) {
  const std::int64_t id = op.command.command_id;
  op.phase = Operation::Phase::moving;  // no second fire
  for (Drive* d : op.drives) d->target = d->table_entry.value_or(0);
  const bool broadcast = std::all_of(drives_.begin(), drives_.end(), [&](const auto& d) { return neutral_for(*d, op); });
  if (broadcast) {
    Transaction start{adam::table_execute_broadcast().value(), nullptr, id};
    start.on_reply = [this, id](const rtu::Response&, TimePoint at, TimePoint frame_end) {
      const auto it = operations_.find(id);
      if (it == operations_.end()) return;
      it->second->trigger_utime = wall_clock_() + std::chrono::duration_cast<std::chrono::microseconds>(frame_end - at).count();
      reply(*it->second, Reply::STARTED, {}, 0, [&](Reply& r) {
        r.trigger_utime = it->second->trigger_utime;
        r.start_mechanism = "broadcast";
        r.predicted_skew_us = 0;
      });
    };
    enqueue(std::move(start), /*urgent=*/true);
  } else {
    // One absolute move per axis (0x00D0, §8.65⑥), in order, each acknowledged.
    const Duration per_axis = rtu::transmission_time(settings_.format, 13) + rtu::transmission_time(settings_.format, 8) +
                              2 * timing_.t3_5 + kAssumedDriveLatency;
    const double skew_us = std::chrono::duration<double, std::micro>(per_axis).count() * static_cast<double>(op.drives.size() - 1);
    op.outstanding = 0;
    std::vector<Transaction> starts;
    for (Drive* d : op.drives) {
      ++op.outstanding;
      Transaction t{adam::move(d->cfg.unit, adam::MoveCommand::absolute_at_standstill, static_cast<std::int32_t>(d->target)), d, id};
      t.max_retries = d->cfg.retries;
      t.on_reply = [this, id, skew_us](const rtu::Response&, TimePoint at, TimePoint frame_end) {
        const auto it = operations_.find(id);
        if (it == operations_.end()) return;
        Operation& o = *it->second;
        if (o.trigger_utime == 0)
          o.trigger_utime = wall_clock_() - std::chrono::duration_cast<std::chrono::microseconds>(at - frame_end).count();
        if (--o.outstanding == 0) {
          reply(o, Reply::STARTED, {}, 0, [&](Reply& r) {
            r.trigger_utime = o.trigger_utime;
            r.start_mechanism = "sequential";
            r.predicted_skew_us = skew_us;
          });
        }
      };
      t.on_fail = [this, id](const std::string& reason, std::int32_t code) { finish(id, Reply::FAILED, reason, code); };
      starts.push_back(std::move(t));
    }
    for (auto it = starts.rbegin(); it != starts.rend(); ++it) queue_.push_front(std::move(*it));
  }
  send_next(now);
}

void MasterCore::check_motion(Operation& op, const Drive& sampled, TimePoint now) {
  (void)now;
  const std::int64_t id = op.command.command_id;
  for (Drive* d : op.drives) {
    if (op.arrived.contains(d) || !d->status || !d->position) continue;
    const adam::DriveStatus& s = *d->status;
    const bool idle = s.phase == adam::MotionPhase::idle;
    if (!idle) {
      op.seen_moving.insert(d);
      continue;
    }
    bool reached = false;
    switch (op.goal) {
      case Operation::Goal::reach_target: reached = s.in_position && *d->position == d->target; break;
      case Operation::Goal::reach_home: reached = s.at_home; break;
      case Operation::Goal::stand_still: reached = true; break;
      case Operation::Goal::none: reached = true; break;
    }
    if (reached) {
      op.arrived.insert(d);
      continue;
    }
    // Idle but not there: give the drive a few polls to start (the broadcast has no ack), then
    // report where it stopped. Only a fresh sample of this drive counts: the others' samples
    // come in between and would count its old one again.
    if (d == &sampled && !op.seen_moving.contains(d)) ++op.idle_polls[d];
    if (op.seen_moving.contains(d) || op.idle_polls[d] >= kIdlePollsBeforeShortStop) {
      const std::string where = "axis " + d->cfg.axis + " stopped at " + std::to_string(*d->position);
      std::string reason;
      if (s.at_limit()) reason = where + " on its " + (s.negative_limit ? "negative" : "positive") + " limit";
      else if (op.goal == Operation::Goal::reach_home) reason = where + " without finding the home switch";
      else reason = where + ", short of its target " + std::to_string(d->target);
      return finish(id, Reply::FAILED, reason, s.at_limit() ? error_code(ReplyError::kAxisFault) : error_code(ReplyError::kDriveError));
    }
  }
  if (op.arrived.size() < op.drives.size()) return;
  if (op.goal == Operation::Goal::reach_home) {
    for (std::size_t i = 0; i < op.drives.size(); ++i) op.drives[i]->homed = true;
    // Home is position 0 on the drive (assumed: §8.48 only says positions are relative to home); a
    // non-zero home position is preset after.
    op.phase = Operation::Phase::transferring;
    op.goal = Operation::Goal::none;
    for (std::size_t i = 0; i < op.drives.size(); ++i) {
      const auto target = op.command.axes[i].target_counts;
      if (target != 0)
        add_write(op, *op.drives[i], adam::move(op.drives[i]->cfg.unit, adam::MoveCommand::preset_position, static_cast<std::int32_t>(target)));
    }
    if (op.outstanding == 0) return finish(id, Reply::DONE);
    when_transferred(op, [this, id](TimePoint) { finish(id, Reply::DONE); });
    return;
  }
  finish(id, Reply::DONE);
}

void MasterCore::param(Operation& op, const motionlcm::param_t& p) {
  const std::int64_t id = op.command.command_id;
  Drive& d = *op.drives[0];
  if (p.space != motionlcm::param_t::MODBUS_REGISTER)
    return finish(id, Reply::FAILED, "ADAM parameters are Modbus registers (param_t space MODBUS_REGISTER)", error_code(ReplyError::kUnsupported));
  if (p.index < 0 || p.index > 0xFFFF) return finish(id, Reply::FAILED, "register " + std::to_string(p.index) + " outside 0…0xFFFF", error_code(ReplyError::kMalformedRequest));
  const auto reg = static_cast<std::uint16_t>(p.index);
  const auto* info = adam::find_register(reg);
  const int width = p.width != 0 ? p.width : (info ? info->count() : 1);
  if (width != 1 && width != 2) return finish(id, Reply::FAILED, "width must be 1 or 2 registers", error_code(ReplyError::kMalformedRequest));
  const bool is_signed = p.is_signed || (info && (info->type == adam::RegType::i16 || info->type == adam::RegType::i32));
  if (op.command.kind == motionlcm::gateway_command_t::PARAM_READ) {
    Transaction t{{d.cfg.unit, rtu::ReadRegisters{reg, static_cast<std::uint16_t>(width)}}, &d, id};
    t.on_reply = [this, id, p, width, is_signed](const rtu::Response& r, TimePoint, TimePoint) {
      const auto& v = std::get<rtu::ReadRegistersReply>(r.pdu).values;
      motionlcm::param_t result = p;
      result.width = static_cast<std::int8_t>(width);
      if (width == 2) result.value = is_signed ? std::int64_t{adam::decode32_signed(v[0], v[1])} : std::int64_t{adam::decode32(v[0], v[1])};
      else result.value = is_signed ? std::int64_t{adam::decode16_signed(v[0])} : std::int64_t{v[0]};
      finish(id, Reply::DONE, {}, 0, [&](Reply& reply) { reply.param = result; });
    };
    t.on_fail = [this, id](const std::string& reason, std::int32_t code) { finish(id, Reply::FAILED, reason, code); };
    enqueue(std::move(t));
    return;
  }
  const std::int64_t lo = width == 1 ? (is_signed ? -32768 : 0) : (is_signed ? std::numeric_limits<std::int32_t>::min() : 0);
  const std::int64_t hi = width == 1 ? (is_signed ? 32767 : 0xFFFF)
                                     : (is_signed ? std::numeric_limits<std::int32_t>::max() : std::int64_t{0xFFFFFFFF});
  if (p.value < lo || p.value > hi)
    return finish(id, Reply::FAILED, "value " + std::to_string(p.value) + " does not fit " + std::to_string(width) + " register(s)", error_code(ReplyError::kMalformedRequest));
  const rtu::Request request =
      width == 1 ? rtu::Request{d.cfg.unit, rtu::WriteRegister{reg, static_cast<std::uint16_t>(p.value)}}
                 : rtu::Request{d.cfg.unit, rtu::WriteRegisters{reg, {adam::encode32(static_cast<std::uint32_t>(p.value))[0],
                                                                      adam::encode32(static_cast<std::uint32_t>(p.value))[1]}}};
  add_write(op, d, request);
  when_transferred(op, [this, id, p](TimePoint) { finish(id, Reply::DONE, {}, 0, [&](Reply& r) { r.param = p; }); });
}

}  // namespace motion::adam_driver
