#include "motion/uim342_driver/uim342_stack.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <motionlcm/event_t.hpp>

#include "motion/can_frame/bit_timing.hpp"
#include "motion/gateway/power_up_watch.hpp"

namespace motion::gateway {
namespace {

using motionlcm::event_t;
using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using uim342::FunctionCode;
using uim342::Instruction;
namespace rq = uim342::request;

std::int64_t system_wall_time(TimePoint now) {
  // Steady -> wall: the offset between the two clocks at this moment.
  const auto steady_now = SteadyClock::now();
  return wall_time_us() - std::chrono::duration_cast<std::chrono::microseconds>(steady_now - now).count();
}

std::string command_name(std::int8_t kind) {
  switch (kind) {
    case gateway_command_t::ENABLE: return "ENABLE";
    case gateway_command_t::DISABLE: return "DISABLE";
    case gateway_command_t::ARM_MOVE: return "ARM_MOVE";
    case gateway_command_t::JOG: return "JOG";
    case gateway_command_t::STOP: return "STOP";
    case gateway_command_t::ESTOP: return "ESTOP";
    case gateway_command_t::HOME: return "HOME";
    case gateway_command_t::FAULT_RESET: return "FAULT_RESET";
    case gateway_command_t::SET_OUTPUTS: return "SET_OUTPUTS";
    case gateway_command_t::PARAM_READ: return "PARAM_READ";
    case gateway_command_t::PARAM_WRITE: return "PARAM_WRITE";
    case gateway_command_t::SET_POSITION: return "SET_POSITION";
    case gateway_command_t::DISARM: return "DISARM";
    default: return fmt::format("kind {}", kind);
  }
}

template <typename T>
T saturate(long long v) {
  return static_cast<T>(std::clamp<long long>(v, std::numeric_limits<T>::min(), std::numeric_limits<T>::max()));
}

}  // namespace

// ---- configuration -------------------------------------------------------------------------------

Uim342StackConfig Uim342StackConfig::from(const config::Config& config, std::string_view bus) {
  Uim342StackConfig out;
  out.bus = std::string(bus);
  const auto* b = config.find_bus(bus);
  if (b) {
    out.bitrate = static_cast<std::uint32_t>(std::max(b->bitrate, 1));
    out.poll_period = std::chrono::milliseconds(b->poll_hz > 0 ? static_cast<long>(std::lround(1000.0 / b->poll_hz)) : 1000);
  }
  for (const auto& d : config.drives) {
    if (d.family != config::Family::kUim342 || d.bus != bus) continue;
    Uim342NodeConfig n;
    n.drive = d.name;
    for (const auto& a : config.axes) {
      if (a.drive != d.name) continue;
      n.axis = a.name;
      n.homing = a.homing;
      n.travel_counts = std::llround((a.limits.max_position - a.limits.min_position) * a.steps_per_unit);
    }
    n.node_id = static_cast<std::uint8_t>(d.node_id);
    n.group_id = static_cast<std::uint8_t>(d.group_id);
    n.request_timeout = std::chrono::milliseconds(d.request_timeout_ms.value_or(b ? b->request_timeout_ms : 50));
    n.retries = d.retries.value_or(b ? b->retries : 2);
    n.setup = d.setup;
    out.nodes.push_back(std::move(n));
  }
  return out;
}

// ---- the stack -----------------------------------------------------------------------------------

struct Uim342Stack::Impl {
  enum class Phase { idle, identifying, setting_up, ready, setup_failed, offline, rebooting };

  // One shared BG frame for every member of a group start, sent once when all of them are free.
  struct GroupSend {
    std::uint8_t group_id = 0;
    std::vector<std::size_t> members;
  };

  struct Request {
    Instruction instruction;
    std::int64_t command_id = 0;  // 0: the stack's own (identify, setup, poll)
    std::shared_ptr<GroupSend> group;
    int attempts = 0;
    bool sent = false;
    TimePoint deadline{};
  };

  struct Node {
    Uim342NodeConfig cfg;
    Phase phase = Phase::idle;
    std::deque<Request> queue;
    DriveStatus status;
    TimePoint next_poll{};
    TimePoint retry_at{};
    std::chrono::milliseconds backoff{0};
    bool ever_online = false;
    bool offline_reported = false;
    bool setup_refused = false;   // the drive refused a set-up value (CONFIG_MISMATCH)
    bool group_ok = false;        // PP[8] reads back the configured group id
    bool rebooted_for_group = false;
    bool restarted_for_micro_steps = false;  // MT[0]/QE[4] were stored and the drive restarted
    std::uint16_t read_micro_steps = 0;      // MT[0] as read at set-up
    uim342::AccelerationUnit unit = uim342::AccelerationUnit::pulses_per_s2;
    double cut_in_pps = 0;
    std::int64_t offset = 0;      // reported position = drive counter + offset (SET_POSITION)
    // Power-cycle detection (see on_kinematics()): the drive counter's samples, and whether the
    // driver was on before the latest MS[0].
    PowerUpWatch power;
    bool was_enabled = false;
    std::int64_t move = 0;        // active ARM_MOVE command
    bool bg_acked = false;        // of the active move
    bool seen_moving = false;     // since the active move's BG
    // A HOME with a switch search (§5.26), one step after the other; see load_home().
    struct Homing {
      enum class Step { none, reading, searching_load, searching, returning_load, returning };
      std::int64_t command = 0;
      Step step = Step::none;
      uim342::InputPort port = uim342::InputPort::in1;
      bool rising = false;          // the armed edge
      double velocity = 0;          // of the search, counts/s; the sign is the direction
      double acceleration = 0;      // counts/s^2 of the command (0: the drive's)
      double deceleration = 0;
      std::int64_t offset = 0;      // the position of the switch edge (HOME target_counts)
      std::optional<uim342::InputActions> previous;  // IL[port] before arming, restored after
      bool armed = false;           // IL[port] holds the origin action
      bool seen_moving = false;     // in the present step
      bool edge_seen = false;       // the armed edge was notified
      TimePoint deadline = kNever;  // of the search
      Duration bound{};
    } homing;
    [[nodiscard]] std::string name() const { return fmt::format("{} (node {})", cfg.drive, cfg.node_id); }
    [[nodiscard]] const std::string& axis_or_drive() const { return cfg.axis.empty() ? cfg.drive : cfg.axis; }
    [[nodiscard]] bool busy() const { return !queue.empty() && queue.front().sent; }
  };

  enum class Stage { loading, armed, starting, moving };

  struct Command {
    gateway_command_t cmd;
    std::vector<std::size_t> nodes;
    std::set<std::size_t> waiting;  // nodes with requests of the current stage not yet answered
    Stage stage = Stage::loading;
    std::map<std::size_t, std::int64_t> targets;
    std::set<std::size_t> arrived;
    std::size_t start_frames_left = 0;
    std::int64_t trigger_utime = 0;
    std::string mechanism;
    double skew_us = 0;
    std::string unreached;  // a stop's offline nodes: the others are still stopped, then it fails
    std::vector<std::string> notes;  // the DONE reply's reason (what a HOME did, per axis)
  };

  Impl(Uim342StackConfig c, CanStackContext ctx, WallClock wc, Counters& shared_counters)
      : config(std::move(c)), context(std::move(ctx)), wall(wc ? std::move(wc) : WallClock{system_wall_time}), counters(shared_counters) {
    for (const auto& n : config.nodes) {
      Node node;
      node.cfg = n;
      nodes.push_back(std::move(node));
      exchange_time = std::max(exchange_time, poll_exchange_time(n.node_id, config.bitrate));
    }
    fit_poll_period();
  }

  // Wire time of one request and its ACK to `node`, for the longest of the poll's exchanges (the
  // MS[1] ACK carries 8 bytes); an upper bound for the ACK of any other instruction too.
  static Duration poll_exchange_time(std::uint8_t node, std::uint32_t bitrate) {
    const auto request = uim342::instruction_frame(node, rq::get(uim342::MotionStatusIndex::kinematics));
    const auto ack = uim342::reply_frame(node, uim342::Reply{FunctionCode::MS, uim342::MotionKinematics{-1, -1}});
    if (!request.ok() || !ack.ok()) return Duration::zero();
    return can::frame_duration(*request, bitrate) + can::frame_duration(*ack, bitrate);
  }

  // §5.24 polling within the bus capacity: N drives x (MS[0] + MS[1]) x poll rate may not take
  // more than kPollBusShare of the wire (the rest stays free for commands and notifications, and
  // requests do not queue up into timeouts). Beyond it every drive is polled less often, and the
  // configuration is told so at start().
  static constexpr double kPollBusShare = 0.75;
  void fit_poll_period() {
    poll_period = config.poll_period;
    const auto cycle = 2 * exchange_time * static_cast<std::int64_t>(nodes.size());  // one poll of every drive
    const auto needed = std::chrono::duration_cast<Duration>(std::chrono::duration<double, std::nano>(static_cast<double>(cycle.count()) / kPollBusShare));
    if (needed <= poll_period) return;
    poll_period = std::chrono::ceil<std::chrono::milliseconds>(needed);
    poll_warning = fmt::format(
        "bus {}: polling {} UIM342 drives at {:.1f} Hz needs {:.0f}% of {} bit/s; polling each at {:.1f} Hz instead (polls keep to {:.0f}% "
        "of the bus)",
        config.bus, nodes.size(), 1.0 / std::chrono::duration<double>(config.poll_period).count(),
        100.0 * std::chrono::duration<double>(cycle).count() / std::chrono::duration<double>(config.poll_period).count(), config.bitrate,
        1.0 / std::chrono::duration<double>(poll_period).count(), 100.0 * kPollBusShare);
  }

  // How long a request just handed to the transport may wait for the wire: every other request
  // in flight on this bus, and its ACK, may go first. Counted into its deadline so a long
  // transmit queue is not taken for a silent drive.
  [[nodiscard]] Duration queued_wire_time() const {
    const auto in_flight = std::count_if(nodes.begin(), nodes.end(), [](const Node& n) { return n.busy(); });
    return exchange_time * in_flight;
  }
  [[nodiscard]] TimePoint deadline_of(const Node& n, TimePoint now) const { return now + n.cfg.request_timeout + queued_wire_time(); }

  Uim342StackConfig config;
  CanStackContext context;
  WallClock wall;
  Counters& counters;
  std::vector<Node> nodes;
  Duration exchange_time{};   // wire time of the longest request + ACK (poll_exchange_time)
  Duration poll_period{};     // config.poll_period, or longer when the bus cannot carry it
  std::string poll_warning;   // why poll_period is longer (reported at start)
  std::map<std::int64_t, Command> commands;
  bool started = false;

  // ---- output helpers ----

  void publish(Node& n, TimePoint now) {
    if (n.cfg.axis.empty()) return;
    n.status.sample_utime = wall(now);
    context.out->axis_status(n.cfg.axis, n.status);
  }
  void event(const Node& n, std::int16_t kind, std::int8_t severity, std::int32_t code, std::string text) {
    DriveEvent e;
    e.kind = kind;
    e.severity = severity;
    e.code = code;
    e.text = std::move(text);
    context.out->axis_event(n.axis_or_drive(), e);
  }
  void reply(const Command& c, std::int8_t status, std::string reason = {}, std::int32_t code = 0) {
    gateway_reply_t r{};
    r.bus = config.bus;
    r.command_id = c.cmd.command_id;
    r.status = status;
    r.reason = std::move(reason);
    r.error_code = code;
    r.trigger_utime = c.trigger_utime;
    r.start_mechanism = c.mechanism;
    r.predicted_skew_us = c.skew_us;
    r.param = c.cmd.param;
    context.out->command_reply(r);
  }
  void reply_to(const gateway_command_t& cmd, std::int8_t status, std::string reason, std::int32_t code) {
    Command c;
    c.cmd = cmd;
    reply(c, status, std::move(reason), code);
  }

  // ---- command bookkeeping ----

  void finish(std::int64_t id, std::int8_t status, std::string reason = {}, std::int32_t code = 0) {
    auto it = commands.find(id);
    if (it == commands.end()) return;
    Command c = std::move(it->second);
    commands.erase(it);
    for (const auto i : c.nodes) {
      Node& n = nodes[i];
      if (n.move == id) n.move = 0;
      // Queued (unsent) requests of this command are dropped; an outstanding one runs out.
      std::erase_if(n.queue, [id](const Request& r) { return r.command_id == id && !r.sent; });
      if (n.homing.command == id) {
        // A homing that ends early leaves no origin action armed (§5.26): IL[i] as it was.
        if (n.homing.armed && n.homing.previous) enqueue(i, rq::set_input_logic(n.homing.port, n.homing.previous->falling, n.homing.previous->rising), 0);
        n.homing = {};
      }
    }
    reply(c, status, std::move(reason), code);
  }
  void fail(std::int64_t id, std::int32_t code, std::string reason) { finish(id, gateway_reply_t::FAILED, std::move(reason), code); }

  // Every command with work on node `i` (queued requests or an active move) fails.
  void fail_commands_of(std::size_t i, std::int32_t code, const std::string& reason, std::int64_t except = 0) {
    std::set<std::int64_t> ids;
    for (const auto& r : nodes[i].queue) {
      if (r.command_id != 0 && r.command_id != except) ids.insert(r.command_id);
    }
    if (nodes[i].move != 0 && nodes[i].move != except) ids.insert(nodes[i].move);
    for (const auto id : ids) fail(id, code, reason);
  }

  Request& enqueue(std::size_t i, Instruction instruction, std::int64_t command_id, bool front = false) {
    Request r;
    r.instruction = std::move(instruction);
    r.command_id = command_id;
    if (command_id != 0) {
      if (auto it = commands.find(command_id); it != commands.end()) it->second.waiting.insert(i);
    }
    auto& q = nodes[i].queue;
    if (!front) return q.emplace_back(std::move(r));
    // Behind the outstanding request (one at a time per node), ahead of everything queued.
    return *q.insert(q.begin() + (nodes[i].busy() ? 1 : 0), std::move(r));
  }

  void drop_requests(std::int64_t command_id) {
    for (auto& n : nodes) std::erase_if(n.queue, [command_id](const Request& r) { return r.command_id == command_id && !r.sent; });
  }

  [[nodiscard]] bool has_request_of(std::size_t i, std::int64_t command_id) const {
    return std::any_of(nodes[i].queue.begin(), nodes[i].queue.end(), [command_id](const Request& r) { return r.command_id == command_id; });
  }

  // ---- sending ----

  bool transmit(std::uint8_t target, const Instruction& instruction) {
    const auto frame = uim342::instruction_frame(target, instruction);
    return frame.ok() && context.send(*frame);
  }

  void pump(std::size_t i, TimePoint now) {
    Node& n = nodes[i];
    while (!n.queue.empty() && !n.queue.front().sent) {
      Request& r = n.queue.front();
      std::uint8_t target = n.cfg.node_id;
      if (r.group) {
        const auto group = r.group;  // keep alive while members are marked
        const bool all_free = std::all_of(group->members.begin(), group->members.end(), [&](std::size_t m) {
          const auto& q = nodes[m].queue;
          return !q.empty() && q.front().group == group && !q.front().sent;
        });
        if (!all_free) return;  // the last member to become free sends it
        if (!transmit(group->group_id, r.instruction)) return;
        const std::uint8_t group_target = group->group_id;
        for (const auto m : group->members) {
          Request& mr = nodes[m].queue.front();
          mr.sent = true;
          mr.attempts = 1;
          mr.deadline = deadline_of(nodes[m], now);
        }
        on_sent(r.command_id, group_target, now);
        return;
      }
      if (!transmit(target, r.instruction)) return;  // transport refused: retried at the next process()
      r.attempts = 1;
      r.sent = true;
      r.deadline = deadline_of(n, now);
      const std::int64_t command_id = r.command_id;
      const bool is_start = r.instruction.function == FunctionCode::BG;
      if (!uim342::expected_reply(r.instruction)) {
        // SY (never answered): done once sent.
        const Request done = std::move(r);
        n.queue.pop_front();
        completed(i, done, std::nullopt, now);
        continue;
      }
      if (is_start) on_sent(command_id, target, now);
      return;
    }
  }

  // A start frame (BG to `target`) of a move was handed to the transport; the driver dates the
  // STARTED reply by its echo when it can (CanStackContext::start_frame).
  void on_sent(std::int64_t command_id, std::uint8_t target, TimePoint now) {
    auto it = commands.find(command_id);
    if (it == commands.end() || it->second.cmd.kind != gateway_command_t::ARM_MOVE || it->second.start_frames_left == 0) return;
    Command& c = it->second;
    if (context.start_frame) {
      if (const auto frame = uim342::instruction_frame(target, rq::begin()); frame.ok()) context.start_frame(command_id, *frame);
    }
    if (c.trigger_utime == 0) c.trigger_utime = wall(now);
    if (--c.start_frames_left == 0) reply(c, gateway_reply_t::STARTED);
  }

  // ---- start-up: identify, set up, poll ----

  void identify(std::size_t i, TimePoint now) {
    Node& n = nodes[i];
    n.phase = Phase::identifying;
    n.queue.clear();
    enqueue(i, rq::get(FunctionCode::ML), 0);
    pump(i, now);
  }

  void set_up(std::size_t i) {
    Node& n = nodes[i];
    n.phase = Phase::setting_up;
    const auto& s = n.cfg.setup;
    using uim342::InitialConfig;
    using uim342::MotorDriver;
    using uim342::QuadratureEncoder;
    if (n.cfg.group_id != 0) enqueue(i, rq::get(uim342::ProtocolParameter::group_id), 0);
    if (config::setup_integer(s, "micro_steps")) {
      // §5.9, §5.7: MT[0] (with CPR QE[4]) takes effect only after it is stored with the driver
      // off and the drive restarted. Read first; a difference is written by
      // store_micro_steps_and_restart() once the QE[4] answer is in.
      enqueue(i, rq::get(MotorDriver::microstepping), 0);
      enqueue(i, rq::get(QuadratureEncoder::counts_per_revolution), 0);
    }
    if (const auto v = config::setup_number(s, "current_a")) {
      const auto tenths = uim342::current_to_wire(*v);
      enqueue(i, rq::set(MotorDriver::working_current, tenths ? *tenths : saturate<std::uint16_t>(std::lround(*v * 10))), 0);
    }
    if (const auto v = config::setup_integer(s, "idle_current_percent")) enqueue(i, rq::set(MotorDriver::idle_current_percent, saturate<std::uint16_t>(*v)), 0);
    if (const auto v = config::setup_flag(s, "auto_enable")) enqueue(i, rq::set(InitialConfig::auto_driver_on, *v ? 1 : 0), 0);
    if (const auto v = config::setup_text(s, "direction")) enqueue(i, rq::set(InitialConfig::positive_direction, *v == "ccw" ? 1 : 0), 0);
    if (const auto v = config::setup_text(s, "acceleration_unit")) {
      n.unit = *v == "time" ? uim342::AccelerationUnit::milliseconds : uim342::AccelerationUnit::pulses_per_s2;
      enqueue(i, rq::set(InitialConfig::acceleration_unit, static_cast<std::uint16_t>(n.unit)), 0);
    }
    if (const auto v = config::setup_flag(s, "closed_loop")) enqueue(i, rq::set(InitialConfig::closed_loop, *v ? 1 : 0), 0);
    if (const auto v = config::setup_flag(s, "software_limits")) enqueue(i, rq::set(InitialConfig::software_limits, *v ? 1 : 0), 0);
    if (const auto v = config::setup_integer(s, "encoder_resolution")) enqueue(i, rq::set(QuadratureEncoder::lines_per_revolution, saturate<std::uint16_t>(*v)), 0);
    if (const auto v = config::setup_integer(s, "stall_tolerance")) enqueue(i, rq::set(QuadratureEncoder::stall_tolerance, saturate<std::uint16_t>(*v)), 0);
    if (const auto v = config::setup_integer(s, "cut_in_speed")) {
      n.cut_in_pps = static_cast<double>(*v);
      enqueue(i, rq::set_cut_in_speed(saturate<std::uint32_t>(*v)), 0);
    }
    if (const auto v = config::setup_integer(s, "stop_deceleration")) enqueue(i, rq::set_stop_deceleration(saturate<std::uint32_t>(*v)), 0);
    if (const auto v = config::setup_integer(s, "backlash")) enqueue(i, rq::set_backlash(saturate<std::uint32_t>(*v)), 0);
    // Notifications this stack relies on (§5.3): inputs for INPUT_EDGE, PTP finished for DONE.
    // Alarms (stall, limits) have no enable bit and are always sent.
    for (const auto e : {uim342::InformationEnable::in1_change, uim342::InformationEnable::in2_change,
                         uim342::InformationEnable::in3_change, uim342::InformationEnable::position_reached}) {
      enqueue(i, rq::set(e, true), 0);
    }
    // The last setup request: its ACK makes the node ready (see completed()).
    enqueue(i, rq::get(uim342::MotionStatusIndex::status), 0);
    enqueue(i, rq::get(uim342::MotionStatusIndex::kinematics), 0);
  }

  // Set-up nodes are polled, except an armed one: it waits for its trigger with an empty queue so
  // the BG goes out without delay (and nothing changes on a drive that has not started).
  [[nodiscard]] bool polled(const Node& n) const {
    if (n.phase != Phase::ready && n.phase != Phase::setup_failed) return false;
    if (n.move == 0) return true;
    const auto it = commands.find(n.move);
    return it == commands.end() || it->second.stage != Stage::armed;
  }

  void poll_if_due(std::size_t i, TimePoint now) {
    Node& n = nodes[i];
    if (!polled(n) || !n.queue.empty() || now < n.next_poll) return;
    n.next_poll = now + poll_period;
    enqueue(i, rq::get(uim342::MotionStatusIndex::status), 0);
    enqueue(i, rq::get(uim342::MotionStatusIndex::kinematics), 0);
  }

  void go_offline(std::size_t i, const std::string& reason, TimePoint now) {
    Node& n = nodes[i];
    const bool was_online = n.status.online;
    const bool first_report = !n.offline_reported;
    n.offline_reported = true;
    n.phase = Phase::offline;
    n.status.online = false;
    n.status.moving = false;
    fail_commands_of(i, error_code(ReplyError::kAxisOffline), reason);
    n.queue.clear();
    n.backoff = n.backoff.count() == 0 ? config.offline_retry_first : std::min(n.backoff * 2, config.offline_retry_max);
    n.retry_at = now + n.backoff;
    if (first_report) {
      event(n, event_t::OFFLINE, was_online ? event_t::ERROR : event_t::WARNING, 0,
            fmt::format("{} offline: {}; retrying in {} ms", n.name(), reason, n.backoff.count()));
      publish(n, now);
    }
  }

  // ---- replies ----

  void completed(std::size_t i, const Request& r, const std::optional<uim342::Reply>& ack, TimePoint now) {
    Node& n = nodes[i];
    if (ack) apply_ack(i, r, *ack, now);
    if (r.instruction.function == FunctionCode::SY) {
      // The drive reboots without answering; identified and set up again after reboot_wait.
      n.power.forget();  // our own reboot: its counter restarts at 0 (not a lost power)
      fail_commands_of(i, error_code(ReplyError::kAxisOffline), fmt::format("{} is rebooting to apply its set-up (PP[8], MT[0])", n.name()));
      n.phase = Phase::rebooting;
      n.queue.clear();
      n.retry_at = now + config.reboot_wait;
      return;
    }
    if (r.command_id != 0 && n.homing.command == r.command_id) {
      if (!has_request_of(i, r.command_id)) homing_step_loaded(i, now);
      return;
    }
    if (r.command_id != 0) {
      auto it = commands.find(r.command_id);
      if (it != commands.end() && !has_request_of(i, r.command_id)) {
        it->second.waiting.erase(i);
        if (it->second.waiting.empty()) stage_done(it->second, now);
      }
      return;
    }
    if (n.phase == Phase::setting_up && n.queue.empty()) setup_finished(i, now);
  }

  // §5.9, §5.7: MT[0] and QE[4] as read at set-up against the configured micro-steps. Equal: the
  // drive runs at them (after a restart, or since its last one). Different the first time: driver
  // off (MO=0, so the values go to EEPROM and not only to RAM), MT[0], QE[4], restart (SY[1]);
  // set-up runs again after the reboot and reads them back. Different after that restart: the
  // drive does not keep them, and counts per unit would be wrong: CONFIG_MISMATCH, never ready.
  void check_micro_steps(std::size_t i, std::uint16_t read_cpr) {
    Node& n = nodes[i];
    const auto wanted = saturate<std::uint16_t>(config::setup_integer(n.cfg.setup, "micro_steps").value_or(0));
    const auto wanted_cpr = saturate<std::uint16_t>(std::int64_t{wanted} * uim342::kFullStepsPerRevolution);
    if (n.read_micro_steps == wanted && read_cpr == wanted_cpr) return;
    const auto found = fmt::format("MT[0] {} / QE[4] {} (configured micro_steps {}: MT[0] {} / QE[4] {})", n.read_micro_steps, read_cpr,
                                   wanted, wanted, wanted_cpr);
    if (n.restarted_for_micro_steps) {
      event(n, event_t::CONFIG_MISMATCH, event_t::ERROR, n.read_micro_steps,
            fmt::format("{} reads {} after storing them and restarting: counts per unit would be wrong; not ready", n.name(), found));
      n.setup_refused = true;
      return;
    }
    event(n, event_t::REBOOT, event_t::INFO, n.read_micro_steps,
          fmt::format("{}: {}; driver off, storing, restarting (SY[1])", n.name(), found));
    n.restarted_for_micro_steps = true;
    n.queue.erase(n.queue.begin() + (n.busy() ? 1 : 0), n.queue.end());
    enqueue(i, rq::driver_on(false), 0);
    enqueue(i, rq::set(uim342::MotorDriver::microstepping, wanted), 0);
    enqueue(i, rq::set(uim342::QuadratureEncoder::counts_per_revolution, wanted_cpr), 0);
    enqueue(i, rq::system(uim342::SystemOperation::reboot), 0);
  }

  // The last set-up request was answered (or refused).
  void setup_finished(std::size_t i, TimePoint now) {
    Node& n = nodes[i];
    n.phase = n.setup_refused ? Phase::setup_failed : Phase::ready;
    n.backoff = std::chrono::milliseconds{0};
    n.next_poll = now + poll_period;
    if (n.setup_refused) return;  // CONFIG_MISMATCH already reported
    n.restarted_for_micro_steps = false;  // a later mismatch (someone rewrote MT) may restart once more
    event(n, event_t::ONLINE, event_t::INFO, 0,
          fmt::format("{} set up{}", n.name(), n.cfg.group_id != 0 && !n.group_ok ? " (group start disabled: group id not confirmed)" : ""));
  }

  void apply_ack(std::size_t i, const Request& r, const uim342::Reply& ack, TimePoint now) {
    Node& n = nodes[i];
    const auto& body = ack.body;
    switch (r.instruction.function) {
      case FunctionCode::ML: {
        const auto& model = std::get<uim342::ModelInfo>(body);
        n.status.online = true;
        n.offline_reported = false;
        n.setup_refused = false;
        event(n, event_t::ONLINE, event_t::INFO, static_cast<std::int32_t>(model.model_bytes[0]),
              fmt::format("{} online: model {:02X} {:02X} {:02X}, firmware {}", n.name(), model.model_bytes[0],
                          model.model_bytes[1], model.model_bytes[2], model.firmware));
        n.ever_online = true;
        if (n.phase == Phase::identifying) set_up(i);
        break;
      }
      case FunctionCode::PP: {
        const auto& pp = std::get<uim342::IndexedByte>(body);
        if (pp.index != static_cast<std::uint8_t>(uim342::ProtocolParameter::group_id) || r.instruction.operation != uim342::Operation::get) break;
        n.group_ok = pp.value == n.cfg.group_id;
        if (n.group_ok) break;
        if (n.rebooted_for_group) {
          event(n, event_t::CONFIG_MISMATCH, event_t::ERROR, pp.value,
                fmt::format("{} keeps group id {} after a reboot (configured {}): moves start axis by axis", n.name(), pp.value, n.cfg.group_id));
          break;
        }
        // §5.1: PP values act after a reboot; everything in RAM is set up again afterwards.
        event(n, event_t::REBOOT, event_t::INFO, pp.value,
              fmt::format("{}: group id {} -> {} (PP[8]), rebooting (SY[1])", n.name(), pp.value, n.cfg.group_id));
        n.rebooted_for_group = true;
        n.queue.erase(n.queue.begin() + (n.busy() ? 1 : 0), n.queue.end());
        enqueue(i, rq::set(uim342::ProtocolParameter::group_id, n.cfg.group_id), 0);
        enqueue(i, rq::system(uim342::SystemOperation::reboot), 0);
        break;
      }
      case FunctionCode::MT:
        if (r.instruction.operation == uim342::Operation::get) n.read_micro_steps = std::get<uim342::IndexedWord>(body).value;
        break;
      case FunctionCode::QE:
        if (r.instruction.operation == uim342::Operation::get && n.phase == Phase::setting_up) {
          check_micro_steps(i, std::get<uim342::IndexedWord>(body).value);
        }
        break;
      case FunctionCode::MO: {
        n.status.enabled = std::get<uim342::Byte>(body).value != 0;
        if (!n.status.enabled) n.status.moving = false;
        publish(n, now);
        break;
      }
      case FunctionCode::MS:
        if (const auto* s = std::get_if<uim342::MotionStatus>(&body)) on_motion_status(i, *s, r, now);
        if (const auto* k = std::get_if<uim342::MotionKinematics>(&body)) {
          if (auto why = powered_up(n, *k, now)) {
            on_power_cycle(i, *why, now);
            break;
          }
          n.status.position_counts = k->absolute_position + n.offset;
          n.status.velocity_counts = k->speed;
          publish(n, now);
        }
        break;
      case FunctionCode::OG: {
        auto it = commands.find(r.command_id);
        if (it == commands.end()) break;
        // SET_POSITION's value, or the homing offset: the position the origin gets.
        n.power.counter_set(0, now);  // the counter is 0 now by our own doing
        n.offset = it->second.targets[i];
        n.status.position_counts = n.offset;
        if (it->second.cmd.kind == gateway_command_t::HOME) n.status.homed = true;
        publish(n, now);
        break;
      }
      case FunctionCode::IL: {
        if (n.homing.command == 0 || r.command_id != n.homing.command) break;
        const auto* actions = std::get_if<uim342::InputActions>(&body);
        if (!actions) break;
        if (r.instruction.operation == uim342::Operation::get) {
          n.homing.previous = *actions;
        } else {
          n.homing.armed = n.homing.step == Node::Homing::Step::searching_load;  // the restore's ACK disarms
        }
        break;
      }
      case FunctionCode::DI: {
        const auto& io = std::get<uim342::DigitalIo>(body);
        n.status.inputs = io.inputs & 0x07;
        n.status.outputs = io.outputs & 0x01;
        publish(n, now);
        break;
      }
      case FunctionCode::BG:
        if (n.move == r.command_id && r.command_id != 0) {
          n.bg_acked = true;
          n.seen_moving = false;
          n.status.in_position = false;
          n.status.moving = true;
        }
        break;
      default: break;
    }
    if (auto it = commands.find(r.command_id); it != commands.end()) {
      auto& c = it->second;
      if (c.cmd.kind == gateway_command_t::PARAM_READ || c.cmd.kind == gateway_command_t::PARAM_WRITE) {
        c.cmd.param.value = param_value(ack, c.cmd.param);
      }
    }
  }

  void on_motion_status(std::size_t i, const uim342::MotionStatus& s, const Request& r, TimePoint now) {
    Node& n = nodes[i];
    using uim342::IoStatusBit;
    using uim342::StatusFlag;
    n.status.online = true;
    n.was_enabled = n.status.enabled;
    n.status.enabled = s.has(IoStatusBit::driver_on);
    n.status.moving = !s.has(StatusFlag::stopped);
    n.status.in_position = s.has(StatusFlag::in_position);
    n.status.inputs = (s.has(IoStatusBit::in1) ? 1 : 0) | (s.has(IoStatusBit::in2) ? 2 : 0) | (s.has(IoStatusBit::in3) ? 4 : 0);
    n.status.outputs = s.has(IoStatusBit::op1) ? 1 : 0;
    const bool stalled = s.has(StatusFlag::stalled);
    const bool locked = s.has(StatusFlag::locked);
    if (stalled || locked || s.has(StatusFlag::error)) {
      n.status.fault = true;
      if (stalled) n.status.fault_text = "motor stall detected (TLIF)";
      if (locked) n.status.fault_text = "system locked down (LOCK): only a reboot or power cycle releases it";
      if (!stalled && !locked) n.status.fault_text = "system error detected (ERR)";
    } else {
      n.status.fault = false;
      n.status.fault_code = 0;
      n.status.fault_text.clear();
    }
    auto it = commands.find(r.command_id);
    if (it != commands.end() && it->second.cmd.kind == gateway_command_t::FAULT_RESET && locked) {
      fail(r.command_id, error_code(ReplyError::kDriveError), fmt::format("{} is locked down (LOCK); MS[0]=0 does not release it, a reboot (SY[1]) or power cycle does", n.name()));
    }
    if (n.homing.command != 0) {
      homing_observe(i, now);
      return;
    }
    // Completion of an active move, from a status read sent after its BG was acknowledged. A
    // driver turned off by nobody may be a power cycle: the position read next decides (powered_up()).
    const bool switched_off = n.was_enabled && !n.status.enabled;
    if (n.move != 0 && n.bg_acked && !(switched_off && r.command_id == 0)) {
      if (stalled) {
        fail(n.move, error_code(ReplyError::kAxisFault), fmt::format("{} stalled during the move (TLIF)", n.name()));
      } else if (n.status.moving) {
        n.seen_moving = true;
      } else if (n.status.in_position) {
        arrived(i, now);
      } else if (n.seen_moving) {
        fail(n.move, error_code(ReplyError::kAxisFault), fmt::format("{} stopped short of its target without a stop command", n.name()));
      }
    }
  }

  // The UIM342 sends nothing when it powers up (no such notification in §5.3; §5.2 IC and §5.9
  // MT[3] only say what it does at power-on), so a power cycle shows only in what it answers
  // afterwards (PowerUpWatch): its position counter starts at 0 (the manual keeps no position over
  // power loss; it names PP values as saved to flash, §5.1), at rest, with the driver off unless
  // IC auto-enable is set (§5.2). Not watched while it is identified or homed (the origin moves).
  [[nodiscard]] std::optional<std::string> powered_up(Node& n, const uim342::MotionKinematics& k, TimePoint now) {
    const bool watched = n.phase == Phase::ready || n.phase == Phase::setup_failed || n.phase == Phase::setting_up;
    if (!watched || n.homing.command != 0) {
      n.power.forget();
      return std::nullopt;
    }
    const bool switched_off = n.was_enabled && !n.status.enabled;
    auto why = n.power.sample(k.absolute_position, static_cast<double>(k.speed), now, switched_off);
    if (!why) return std::nullopt;
    return n.name() + " " + *why;
  }

  // A power cycle seen in its answers: what it was doing ended, its position is lost, and its
  // RAM settings are gone, so it is identified and set up again (as after a reboot).
  void on_power_cycle(std::size_t i, const std::string& why, TimePoint now) {
    Node& n = nodes[i];
    fail_commands_of(i, error_code(ReplyError::kAxisFault), why);
    n.offset = 0;
    n.status.position_counts = 0;
    n.status.velocity_counts = 0;
    n.status.moving = false;
    n.status.in_position = false;
    n.status.homed = false;
    publish(n, now);
    if (!n.cfg.axis.empty()) context.out->position_lost(n.cfg.axis, why);
    if (n.phase == Phase::setting_up) return;  // being set up already (it was offline)
    identify(i, now);  // commands arriving meanwhile queue behind its set-up
  }

  void arrived(std::size_t i, TimePoint) {
    Node& n = nodes[i];
    auto it = commands.find(n.move);
    if (it == commands.end()) return;
    Command& c = it->second;
    if (!c.arrived.insert(i).second) return;
    n.status.in_position = true;
    n.status.moving = false;
    n.status.target_counts = c.targets[i];
    event(n, event_t::MOTION_COMPLETE, event_t::INFO, 0, fmt::format("{} in position at {}", n.name(), n.status.position_counts));
    check_move_done(c);
  }

  void check_move_done(Command& c) {
    if (c.stage != Stage::moving || c.arrived.size() < c.nodes.size()) return;
    finish(c.cmd.command_id, gateway_reply_t::DONE);
  }

  void stage_done(Command& c, TimePoint now) {
    if (c.cmd.kind != gateway_command_t::ARM_MOVE) {
      if (c.unreached.empty()) {
        finish(c.cmd.command_id, gateway_reply_t::DONE, fmt::format("{}", fmt::join(c.notes, "; ")));
      } else {
        fail(c.cmd.command_id, error_code(ReplyError::kAxisOffline), c.unreached);
      }
      return;
    }
    switch (c.stage) {
      case Stage::loading:
        c.stage = Stage::armed;
        reply(c, gateway_reply_t::ARMED);
        if (c.cmd.trigger_id == 0) start_move(c, now);
        break;
      case Stage::starting:
        c.stage = Stage::moving;
        check_move_done(c);
        break;
      case Stage::armed:
      case Stage::moving: break;
    }
  }

  // ---- synchronized start (§5.11, §3.2) ----

  void start_move(Command& c, TimePoint now) {
    c.stage = Stage::starting;
    const std::uint8_t group = nodes[c.nodes.front()].cfg.group_id;
    // One BG to the group id starts every drive of the group, so it is used only when the group
    // is exactly this command's axes (a drive of the group outside the command would start too).
    bool one_frame = group != 0;
    for (const auto i : c.nodes) one_frame = one_frame && nodes[i].cfg.group_id == group && nodes[i].group_ok;
    for (std::size_t i = 0; i < nodes.size() && one_frame; ++i) {
      if (nodes[i].cfg.group_id == group && std::find(c.nodes.begin(), c.nodes.end(), i) == c.nodes.end()) one_frame = false;
    }
    const auto bg_frame = uim342::instruction_frame(one_frame ? group : nodes[c.nodes.front()].cfg.node_id, rq::begin());
    const auto frame_us = std::chrono::duration<double, std::micro>(can::frame_duration(*bg_frame, config.bitrate)).count();
    c.mechanism = one_frame ? "group-bg" : "sequential";
    c.skew_us = one_frame ? 0.0 : frame_us * static_cast<double>(c.nodes.size() - 1);
    c.start_frames_left = one_frame ? 1 : c.nodes.size();
    std::shared_ptr<GroupSend> shared;
    if (one_frame) shared = std::make_shared<GroupSend>(GroupSend{group, c.nodes});
    for (const auto i : c.nodes) enqueue(i, rq::begin(), c.cmd.command_id, /*front=*/true).group = shared;
    for (const auto i : c.nodes) pump(i, now);
  }

  // ---- commands ----

  std::optional<std::size_t> node_of_axis(const std::string& axis) const {
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      if (nodes[i].cfg.axis == axis) return i;
    }
    return std::nullopt;
  }

  void execute(const gateway_command_t& cmd, TimePoint now) {
    if (cmd.axes.empty()) {
      reply_to(cmd, gateway_reply_t::FAILED, command_name(cmd.kind) + " names no axis", error_code(ReplyError::kMalformedRequest));
      return;
    }
    Command c;
    c.cmd = cmd;
    for (const auto& a : cmd.axes) {
      const auto i = node_of_axis(a.axis);
      if (!i) {
        reply_to(cmd, gateway_reply_t::FAILED, fmt::format("axis '{}' is not driven by a uim342 drive on bus {}", a.axis, config.bus), error_code(ReplyError::kUnknownAxis));
        return;
      }
      c.nodes.push_back(*i);
      c.targets[*i] = a.target_counts;
    }
    const bool needs_drive = cmd.kind != gateway_command_t::DISARM;
    const bool stops = cmd.kind == gateway_command_t::STOP || cmd.kind == gateway_command_t::ESTOP;
    for (const auto i : c.nodes) {
      const Node& n = nodes[i];
      // A stop naming an offline drive still stops the others (see load()).
      if (needs_drive && n.phase == Phase::offline && !stops) {
        reply_to(cmd, gateway_reply_t::FAILED, fmt::format("{} is offline", n.name()), error_code(ReplyError::kAxisOffline));
        return;
      }
      const bool starts_motion = cmd.kind == gateway_command_t::ARM_MOVE || cmd.kind == gateway_command_t::JOG ||
                                 cmd.kind == gateway_command_t::HOME || cmd.kind == gateway_command_t::SET_POSITION;
      if (starts_motion && n.move != 0) {
        reply_to(cmd, gateway_reply_t::FAILED, fmt::format("{} is busy with move command {}", n.name(), n.move), error_code(ReplyError::kAxisBusy));
        return;
      }
    }
    if (commands.count(cmd.command_id) != 0) {
      reply_to(cmd, gateway_reply_t::FAILED, fmt::format("command id {} is already in progress", cmd.command_id), error_code(ReplyError::kMalformedRequest));
      return;
    }
    const auto id = cmd.command_id;
    auto& stored = commands.emplace(id, std::move(c)).first->second;
    if (const auto problem = load(stored)) {
      commands.erase(id);
      drop_requests(id);
      reply_to(cmd, gateway_reply_t::FAILED, problem->first, problem->second);
      return;
    }
    auto it = commands.find(id);
    if (it != commands.end() && it->second.waiting.empty()) stage_done(it->second, now);
    for (std::size_t i = 0; i < nodes.size(); ++i) pump(i, now);
  }

  using Problem = std::optional<std::pair<std::string, std::int32_t>>;

  // Queues the command's requests; a reason when the command cannot be carried out.
  Problem load(Command& c) {
    const auto id = c.cmd.command_id;
    const auto each = [&](auto&& per_node) -> Problem {
      for (std::size_t k = 0; k < c.nodes.size(); ++k) {
        if (auto p = per_node(c.nodes[k], c.cmd.axes[k])) return p;
      }
      return std::nullopt;
    };
    switch (c.cmd.kind) {
      case gateway_command_t::ENABLE:
      case gateway_command_t::DISABLE: {
        const bool on = c.cmd.kind == gateway_command_t::ENABLE;
        for (const auto i : c.nodes) {
          if (!on && nodes[i].move != 0) fail(nodes[i].move, error_code(ReplyError::kStopped), fmt::format("{} disabled by command {}", nodes[i].name(), id));
          enqueue(i, rq::driver_on(on), id);
        }
        return std::nullopt;
      }
      case gateway_command_t::ARM_MOVE:
        if (auto p = each([&](std::size_t i, const motionlcm::axis_command_t& a) { return load_move(c, i, a); })) return p;
        for (const auto i : c.nodes) {
          nodes[i].move = id;
          nodes[i].bg_acked = false;
          nodes[i].status.target_counts = c.targets.at(i);
        }
        return std::nullopt;
      case gateway_command_t::JOG:
        return each([&](std::size_t i, const motionlcm::axis_command_t& a) { return load_jog(c, i, a); });
      case gateway_command_t::STOP:
      case gateway_command_t::ESTOP: {
        const bool emergency = c.cmd.kind == gateway_command_t::ESTOP;
        for (const auto i : c.nodes) {
          Node& n = nodes[i];
          if (n.phase == Phase::offline) {
            c.unreached += fmt::format("{}{} is offline", c.unreached.empty() ? "" : "; ", n.name());
            continue;
          }
          const auto reason = fmt::format("{} stopped by {} command {}", n.name(), command_name(c.cmd.kind), id);
          if (emergency) {
            fail_commands_of(i, error_code(ReplyError::kStopped), reason, id);  // nothing queued goes out after an e-stop
          } else {
            // The running move, and every motion command whose frames are still queued (a jog's
            // JV/BG sent after the ST would start the motor again).
            std::set<std::int64_t> motion;
            if (n.move != 0) motion.insert(n.move);
            for (const auto& r : n.queue) {
              const auto cmd = commands.find(r.command_id);
              if (r.command_id == id || cmd == commands.end()) continue;
              const auto kind = cmd->second.cmd.kind;
              if (kind == gateway_command_t::JOG || kind == gateway_command_t::HOME || kind == gateway_command_t::ARM_MOVE) motion.insert(r.command_id);
            }
            for (const auto m : motion) fail(m, error_code(ReplyError::kStopped), reason);
          }
          enqueue(i, rq::stop(), id, /*front=*/true);
          // An e-stop leaves the power stage off, as on every family (CiA 402 quick stop ends
          // in "switch on disabled"): the driver is switched off (MO=0, manual §5.10) once stopped.
          if (emergency) enqueue(i, rq::driver_on(false), id);
        }
        return std::nullopt;
      }
      case gateway_command_t::HOME:
        return each([&](std::size_t i, const motionlcm::axis_command_t& a) { return load_home(c, i, a); });
      case gateway_command_t::SET_POSITION:
        for (const auto i : c.nodes) enqueue(i, rq::set_origin(), id);
        return std::nullopt;
      case gateway_command_t::FAULT_RESET:
        for (const auto i : c.nodes) enqueue(i, rq::clear_motion_status(), id);
        return std::nullopt;
      case gateway_command_t::SET_OUTPUTS:
        return each([&](std::size_t i, const motionlcm::axis_command_t& a) -> Problem {
          if ((a.output_mask & ~1) != 0) {
            return std::pair{fmt::format("{} has one digital output (OP1, bit 0); mask 0x{:X} names others", nodes[i].name(), a.output_mask),
                             error_code(ReplyError::kUnsupported)};
          }
          const auto outputs = static_cast<std::uint8_t>((nodes[i].status.outputs & ~a.output_mask) | (a.output_value & a.output_mask));
          enqueue(i, rq::set_outputs(outputs), id);
          return std::nullopt;
        });
      case gateway_command_t::PARAM_READ:
      case gateway_command_t::PARAM_WRITE: return load_param(c);
      case gateway_command_t::DISARM: {
        std::set<std::int64_t> armed;
        for (const auto i : c.nodes) {
          auto it = commands.find(nodes[i].move);
          if (it != commands.end() && it->second.stage == Stage::armed &&
              (c.cmd.trigger_id == 0 || it->second.cmd.trigger_id == c.cmd.trigger_id)) {
            armed.insert(it->first);
          }
        }
        for (const auto a : armed) fail(a, error_code(ReplyError::kStopped), fmt::format("move disarmed by command {}", id));
        return std::nullopt;
      }
      default:
        return std::pair{fmt::format("command kind {} is not supported by the uim342 stack", int{c.cmd.kind}), error_code(ReplyError::kUnsupported)};
    }
  }

  // AC/DC in the drive's IC[4] unit; nullopt when the command leaves the drive's value.
  Problem ramp(std::size_t i, double rate, double speed, bool acceleration, std::int64_t id) {
    if (rate <= 0) return std::nullopt;
    const Node& n = nodes[i];
    const auto wire = uim342::acceleration_to_wire(rate, n.unit, speed, n.cut_in_pps);
    if (!wire) {
      return std::pair{fmt::format("{}: {} {} counts/s^2 is outside the drive's range", n.name(), acceleration ? "acceleration" : "deceleration", rate),
                       error_code(ReplyError::kOutsideLimits)};
    }
    enqueue(i, acceleration ? rq::set_acceleration(*wire) : rq::set_deceleration(*wire), id);
    return std::nullopt;
  }

  Problem load_move(Command& c, std::size_t i, const motionlcm::axis_command_t& a) {
    const Node& n = nodes[i];
    const auto speed = uim342::speed_to_pps(std::abs(a.velocity));
    if (!speed || *speed <= 0) {
      return std::pair{fmt::format("{}: ARM_MOVE needs a positive speed within 32 bits (got {} counts/s)", n.name(), a.velocity), error_code(ReplyError::kOutsideLimits)};
    }
    const std::int64_t drive_target = a.target_counts - n.offset;
    if (drive_target < std::numeric_limits<std::int32_t>::min() || drive_target > std::numeric_limits<std::int32_t>::max()) {
      return std::pair{fmt::format("{}: target {} counts does not fit PA (32 bits)", n.name(), a.target_counts), error_code(ReplyError::kOutsideLimits)};
    }
    const auto id = c.cmd.command_id;
    // §5.19: in PTP mode PR/PA first, then SP (otherwise error #50).
    enqueue(i, rq::set_absolute_position(static_cast<std::int32_t>(drive_target)), id);
    enqueue(i, rq::set_ptp_speed(*speed), id);
    if (auto p = ramp(i, a.acceleration, *speed, true, id)) return p;
    return ramp(i, a.deceleration, *speed, false, id);
  }

  // ---- homing (§4.3, §5.13, §5.26; see the header) ----

  [[nodiscard]] static std::string edge_name(const Node::Homing& h) {
    return fmt::format("IN{} {} edge", static_cast<int>(h.port) + 1, h.rising ? "rising" : "falling");
  }

  // HOME: OG where the axis stands (method none / current-position), or a switch search.
  Problem load_home(Command& c, std::size_t i, const motionlcm::axis_command_t& a) {
    Node& n = nodes[i];
    const auto id = c.cmd.command_id;
    if (n.cfg.homing.method != config::HomingMethod::kSwitch) {
      enqueue(i, rq::set_origin(), id);
      c.notes.push_back(fmt::format("{}: origin set at the current position ({} counts); no switch search (homing method {})", n.name(),
                           a.target_counts, n.cfg.homing.method_name.empty() ? "none" : n.cfg.homing.method_name));
      return std::nullopt;
    }
    if (!n.status.enabled) {
      return std::pair{fmt::format("{} is disabled: a switch search needs the driver on (MO=1)", n.name()), error_code(ReplyError::kAxisDisabled)};
    }
    if (!uim342::speed_to_pps(a.velocity) || a.velocity == 0) {
      return std::pair{fmt::format("{}: homing speed {} counts/s is zero or does not fit 32 bits", n.name(), a.velocity), error_code(ReplyError::kOutsideLimits)};
    }
    Node::Homing h;
    h.command = id;
    h.step = Node::Homing::Step::reading;
    h.port = static_cast<uim342::InputPort>(std::clamp(n.cfg.homing.input, 1, 3) - 1);
    h.rising = n.cfg.homing.edge == config::HomingEdge::kRising;
    h.velocity = a.velocity;
    h.acceleration = a.acceleration;
    h.deceleration = a.deceleration;
    h.offset = a.target_counts;
    n.homing = h;
    n.move = id;
    // The input's present level decides the search (MS[0] d1, §3.7); IL[i] is kept to restore.
    enqueue(i, rq::get(uim342::MotionStatusIndex::status), id);
    enqueue(i, rq::get_input_logic(static_cast<std::uint8_t>(h.port)), id);
    return std::nullopt;
  }

  // The requests of a homing step were all answered.
  void homing_step_loaded(std::size_t i, TimePoint now) {
    Node& n = nodes[i];
    auto& h = n.homing;
    using Step = Node::Homing::Step;
    switch (h.step) {
      case Step::reading: {
        const bool level = (n.status.inputs >> static_cast<int>(h.port) & 1) != 0;
        if (level == h.rising) {
          // Already on the switch: leave it the other way; its edge out is the same boundary.
          h.velocity = -h.velocity;
          h.rising = !h.rising;
        }
        const double speed = std::abs(h.velocity);
        const double ramps = h.acceleration > 0 ? 2 * speed / h.acceleration : 0.0;
        h.bound = std::chrono::duration_cast<Duration>(std::chrono::duration<double>(static_cast<double>(n.cfg.travel_counts) / speed + ramps + 2.0));
        h.deadline = now + h.bound;
        h.step = Step::searching_load;
        const auto id = h.command;
        const auto edge_group = static_cast<uim342::ParameterGroup>(2 + 2 * static_cast<int>(h.port) + (h.rising ? 0 : 1));
        // §5.13: the edge's own group holds the DC of action 0x06; MF applies to the next set only.
        if (h.deceleration > 0) {
          enqueue(i, rq::select_group(edge_group), id);
          if (auto p = ramp(i, h.deceleration, speed, false, id)) return fail(id, p->second, p->first);
        }
        const uim342::EdgeAction origin{uim342::InputAction::origin_then_decelerate_stop, true};
        const uim342::EdgeAction nothing{uim342::InputAction::none, true};
        enqueue(i, rq::set_input_logic(h.port, h.rising ? nothing : origin, h.rising ? origin : nothing), id);
        motionlcm::axis_command_t jog{};
        jog.velocity = h.velocity;
        jog.acceleration = h.acceleration;
        jog.deceleration = h.deceleration;
        auto it = commands.find(id);
        if (it == commands.end()) return;
        if (auto p = load_jog(it->second, i, jog)) return fail(id, p->second, p->first);
        pump(i, now);
        return;
      }
      case Step::searching_load:
        h.step = Step::searching;
        h.seen_moving = false;
        return;
      case Step::returning_load:
        h.step = Step::returning;
        h.seen_moving = false;
        return;
      case Step::none:
      case Step::searching:
      case Step::returning: return;
    }
  }

  // A status of a homing axis (MS[0] poll, edge or position notification).
  void homing_observe(std::size_t i, TimePoint now) {
    Node& n = nodes[i];
    auto& h = n.homing;
    using Step = Node::Homing::Step;
    if (h.step != Step::searching && h.step != Step::returning) return;
    const auto id = h.command;
    if (n.status.fault) return fail(id, error_code(ReplyError::kAxisFault), fmt::format("{} faulted while homing: {}", n.name(), n.status.fault_text));
    if (n.status.moving) {
      h.seen_moving = true;
      return;
    }
    if (h.step == Step::searching) {
      const bool on_switch = ((n.status.inputs >> static_cast<int>(h.port) & 1) != 0) == h.rising;
      if (!(h.edge_seen || on_switch)) {
        if (h.seen_moving) {
          fail(id, error_code(ReplyError::kAxisFault), fmt::format("{} stopped before the home switch ({}) was reached", n.name(), edge_name(h)));
        }
        return;
      }
      // Stopped by the origin action: IL[i] as it was, then back to the switch edge (PA = 0).
      h.step = Step::returning_load;
      h.deadline = kNever;
      const auto pps = uim342::speed_to_pps(std::abs(h.velocity));
      const std::int32_t speed = pps ? *pps : 1;  // checked at load
      enqueue(i, rq::set_input_logic(h.port, h.previous ? h.previous->falling : uim342::EdgeAction{}, h.previous ? h.previous->rising : uim342::EdgeAction{}), id);
      enqueue(i, rq::set_absolute_position(0), id);  // §5.19: PA before SP
      enqueue(i, rq::set_ptp_speed(speed), id);
      enqueue(i, rq::begin(), id);
      pump(i, now);
      return;
    }
    if (!n.status.in_position) {
      if (h.seen_moving) fail(id, error_code(ReplyError::kAxisFault), fmt::format("{} stopped short of the home switch edge", n.name()));
      return;
    }
    const std::int64_t drive_position = n.status.position_counts - n.offset;
    n.offset = h.offset;
    n.status.position_counts = drive_position + n.offset;
    n.status.homed = true;
    n.status.target_counts = h.offset;
    publish(n, now);
    // This axis is homed; the command is DONE when every axis of it is.
    auto it = commands.find(id);
    if (it == commands.end()) return;
    Command& c = it->second;
    const auto done_text = fmt::format("{}: origin at the {}, axis at {} counts", n.name(), edge_name(h), n.status.position_counts);
    n.homing = {};
    n.move = 0;
    c.notes.push_back(done_text);
    c.waiting.erase(i);
    if (c.waiting.empty()) stage_done(c, now);
  }

  // The search bound passed without the switch: stop, restore IL (finish()), fail.
  void homing_not_found(std::size_t i, TimePoint) {
    Node& n = nodes[i];
    const auto& h = n.homing;
    const auto reason = fmt::format("{}: home switch ({}) not found within {:.1f} s ({} counts of travel at {} counts/s); axis stopped", n.name(),
                                    edge_name(h), std::chrono::duration<double>(h.bound).count(), n.cfg.travel_counts, std::abs(h.velocity));
    enqueue(i, rq::stop(), 0, /*front=*/true);
    fail(h.command, error_code(ReplyError::kTimeout), reason);
  }

  Problem load_jog(Command& c, std::size_t i, const motionlcm::axis_command_t& a) {
    const auto speed = uim342::speed_to_pps(a.velocity);
    if (!speed) return std::pair{fmt::format("{}: jog speed {} counts/s does not fit 32 bits", nodes[i].name(), a.velocity), error_code(ReplyError::kOutsideLimits)};
    const auto id = c.cmd.command_id;
    enqueue(i, rq::set_jog_velocity(*speed), id);
    const double magnitude = std::abs(static_cast<double>(*speed));
    if (auto p = ramp(i, a.acceleration, magnitude, true, id)) return p;
    if (auto p = ramp(i, a.deceleration, magnitude, false, id)) return p;
    enqueue(i, rq::begin(), id);
    return std::nullopt;
  }

  // PARAM_READ / PARAM_WRITE in the family's terms: index = function code, subindex = sub-index.
  Problem load_param(Command& c) {
    const auto& p = c.cmd.param;
    const bool write = c.cmd.kind == gateway_command_t::PARAM_WRITE;
    if (c.nodes.size() != 1) return std::pair{std::string("a parameter command names exactly one axis"), error_code(ReplyError::kMalformedRequest)};
    const Node& n = nodes[c.nodes.front()];
    if (p.space != motionlcm::param_t::UIM342_INSTRUCTION) {
      return std::pair{fmt::format("{} takes UIM342 parameters (space {}), not space {}", n.name(), int{motionlcm::param_t::UIM342_INSTRUCTION}, int{p.space}),
                       error_code(ReplyError::kUnsupported)};
    }
    const auto* forms = p.index >= 0 && p.index <= 0x7F ? uim342::find_forms(static_cast<std::uint8_t>(p.index)) : nullptr;
    if (!forms) return std::pair{fmt::format("{}: 0x{:02X} is not a UIM342 instruction", n.name(), p.index), error_code(ReplyError::kMalformedRequest)};
    const auto instruction = param_instruction(*forms, p, write);
    if (!instruction) return std::pair{fmt::format("{}: {} has no {} form with this sub-index", n.name(), forms->mnemonic, write ? "set" : "get"), error_code(ReplyError::kMalformedRequest)};
    if (write) {
      if (const auto ec = uim342::check_instruction(*instruction, n.unit)) {
        return std::pair{fmt::format("{}: {} refused before sending: {}", n.name(), uim342::to_string(*instruction), ec.message()), error_code(ReplyError::kOutsideLimits)};
      }
    }
    enqueue(c.nodes.front(), *instruction, c.cmd.command_id);
    return std::nullopt;
  }

  static std::optional<Instruction> param_instruction(const uim342::InstructionForms& forms, const motionlcm::param_t& p, bool write) {
    using L = uim342::Layout;
    const auto sub = static_cast<std::uint8_t>(std::max(p.subindex, 0));
    const bool has_sub = p.subindex >= 0;
    const auto v = p.value;
    Instruction out{forms.function, write ? uim342::Operation::set : uim342::Operation::get, true, uim342::Empty{}};
    switch (write ? forms.set : forms.get) {
      case L::empty: break;
      case L::index:
        if (!has_sub) return std::nullopt;
        out.body = uim342::Index{sub};
        break;
      case L::byte: out.body = uim342::Byte{saturate<std::uint8_t>(v)}; break;
      case L::indexed_byte:
        if (!has_sub) return std::nullopt;
        out.body = uim342::IndexedByte{sub, saturate<std::uint8_t>(v)};
        break;
      case L::input_logic:
        if (sub <= 2) {
          out.body = uim342::InputActions{sub, uim342::EdgeAction::from_byte(static_cast<std::uint8_t>(v & 0xFF)),
                                          uim342::EdgeAction::from_byte(static_cast<std::uint8_t>((v >> 8) & 0xFF))};
          break;
        }
        [[fallthrough]];
      case L::indexed_word:
        if (!has_sub) return std::nullopt;
        out.body = uim342::IndexedWord{sub, saturate<std::uint16_t>(v)};
        break;
      case L::u32: out.body = uim342::Unsigned{saturate<std::uint32_t>(v)}; break;
      case L::s32: out.body = uim342::Signed{saturate<std::int32_t>(v)}; break;
      case L::digital_output: out.body = uim342::DigitalOutput{saturate<std::uint8_t>(v), 1}; break;
      default: return std::nullopt;
    }
    if (out.function == FunctionCode::SY) out.ack_requested = false;
    return out;
  }

  // The value of a parameter reply: its data bytes after the echoed sub-index, little-endian,
  // `width` bytes (all when 0), sign-extended when `is_signed`.
  static std::int64_t param_value(const uim342::Reply& ack, const motionlcm::param_t& p) {
    const auto message = uim342::encode(ack);
    if (!message) return 0;
    auto data = message->payload();
    if (ack.sub_index() && !data.empty()) data = data.subspan(1);
    const std::size_t width = p.width > 0 ? std::min<std::size_t>(static_cast<std::size_t>(p.width), data.size()) : data.size();
    std::uint64_t raw = 0;
    for (std::size_t k = 0; k < width && k < 8; ++k) raw |= std::uint64_t{data[k]} << (8 * k);
    if (p.is_signed && width > 0 && width < 8 && (data[width - 1] & 0x80) != 0) raw |= ~std::uint64_t{0} << (8 * width);
    return static_cast<std::int64_t>(raw);
  }

  void fire(std::int64_t trigger_id, TimePoint now) {
    std::vector<std::int64_t> ids;
    for (auto& [id, c] : commands) {
      if (c.cmd.kind == gateway_command_t::ARM_MOVE && c.stage == Stage::armed && c.cmd.trigger_id == trigger_id && trigger_id != 0) ids.push_back(id);
    }
    for (const auto id : ids) {
      if (auto it = commands.find(id); it != commands.end()) start_move(it->second, now);
    }
  }

  // ---- incoming frames ----

  std::optional<std::size_t> node_of_id(std::uint8_t id) const {
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      if (nodes[i].cfg.node_id == id) return i;
    }
    return std::nullopt;
  }

  bool on_frame(const can::Frame& frame, TimePoint now) {
    if (!frame.extended) return false;
    const auto fields = uim342::decode_can_id(frame.id);
    const auto i = fields ? node_of_id(fields->producer) : std::nullopt;
    if (!i) {
      ++counters.foreign;
      return false;
    }
    const auto message = uim342::decode_can(frame);
    const auto drive_message = message ? uim342::decode_drive_message(message->message) : uim342::Result<uim342::DriveMessage>(message.error());
    if (!drive_message) {
      ++counters.malformed;
      return true;
    }
    if (const auto* notification = std::get_if<uim342::Notification>(&*drive_message)) {
      ++counters.notifications;
      on_notification(*i, *notification, now);
    } else {
      on_reply(*i, message->message, std::get<uim342::Reply>(*drive_message), now);
    }
    pump(*i, now);
    return true;
  }

  void on_reply(std::size_t i, const uim342::Message& message, const uim342::Reply& reply, TimePoint now) {
    Node& n = nodes[i];
    const auto kind = n.busy() ? uim342::classify_reply(n.queue.front().instruction, message) : uim342::ReplyKind::unrelated;
    if (kind == uim342::ReplyKind::ack) {
      const Request r = std::move(n.queue.front());
      n.queue.pop_front();
      completed(i, r, reply, now);
      return;
    }
    if (reply.function == FunctionCode::ER) {
      ++counters.error_reports;
      const auto& record = std::get<uim342::ErrorRecord>(reply.body);
      if (kind == uim342::ReplyKind::error_report) {
        const Request r = std::move(n.queue.front());
        n.queue.pop_front();
        refused(i, r, record, now);
      } else {
        event(n, event_t::ERROR_REPORT, event_t::WARNING, record.code,
              fmt::format("{} reported {} on CW 0x{:02X}", n.name(), record.error().message(), record.control_word));
      }
      return;
    }
    ++counters.unexpected;
  }

  // §2.3: the instruction was not executed.
  void refused(std::size_t i, const Request& r, const uim342::ErrorRecord& record, TimePoint now) {
    Node& n = nodes[i];
    const auto reason = fmt::format("{} refused {}: {}", n.name(), uim342::to_string(r.instruction), record.error().message());
    event(n, event_t::ERROR_REPORT, event_t::WARNING, record.code, reason);
    if (r.command_id != 0) {
      fail(r.command_id, error_code(ReplyError::kDriveError), reason);
      return;
    }
    if (n.phase == Phase::setting_up) {
      // A set-up value the drive does not take: the rest is applied, but ready() stays false.
      event(n, event_t::CONFIG_MISMATCH, event_t::ERROR, record.code, reason);
      n.setup_refused = true;
      if (n.queue.empty()) setup_finished(i, now);
    }
  }

  void on_notification(std::size_t i, const uim342::Notification& notification, TimePoint now) {
    Node& n = nodes[i];
    if (const auto* alarm = std::get_if<uim342::AlarmNotification>(&notification)) {
      const auto code = static_cast<std::int32_t>(alarm->alarm);
      const auto text = fmt::format("{}: {} (alarm 0x{:02X})", n.name(), uim342::describe(alarm->alarm), code);
      std::int16_t kind = event_t::ALARM;
      if (alarm->alarm == uim342::AlarmCode::stall) kind = event_t::STALL;
      if (alarm->alarm == uim342::AlarmCode::below_lower_limit || alarm->alarm == uim342::AlarmCode::above_upper_limit) kind = event_t::LIMIT;
      const bool warning_only = alarm->alarm == uim342::AlarmCode::encoder_battery_low;
      event(n, kind, warning_only ? event_t::WARNING : event_t::ERROR, code, text);
      if (!warning_only) {
        n.status.fault = true;
        n.status.fault_code = code;
        n.status.fault_text = uim342::describe(alarm->alarm);
        if (n.move != 0) fail(n.move, error_code(ReplyError::kAxisFault), text);
      }
      publish(n, now);
    } else if (const auto* edge = std::get_if<uim342::InputEdgeNotification>(&notification)) {
      const int bit = 1 << static_cast<int>(edge->port);
      n.status.inputs = edge->edge == uim342::Edge::rising ? (n.status.inputs | bit) : (n.status.inputs & ~bit);
      event(n, event_t::INPUT_EDGE, event_t::INFO, static_cast<std::int32_t>(edge->code()),
            fmt::format("{}: IN{} {} edge", n.name(), static_cast<int>(edge->port) + 1, edge->edge == uim342::Edge::rising ? "rising" : "falling"));
      if (n.homing.step == Node::Homing::Step::searching && edge->port == n.homing.port && (edge->edge == uim342::Edge::rising) == n.homing.rising) {
        n.homing.edge_seen = true;
      }
      publish(n, now);
    } else if (const auto* reached = std::get_if<uim342::PositionReachedNotification>(&notification)) {
      n.status.position_counts = reached->position + n.offset;
      n.status.in_position = true;
      n.status.moving = false;
      n.status.velocity_counts = 0;
      if (n.move != 0) {
        auto it = commands.find(n.move);
        if (it != commands.end() && it->second.stage >= Stage::starting) arrived(i, now);
      }
      publish(n, now);
      if (n.homing.command != 0) homing_observe(i, now);
    }
  }

  // ---- time ----

  TimePoint process(TimePoint now) {
    TimePoint next = kNever;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      Node& n = nodes[i];
      if ((n.phase == Phase::offline || n.phase == Phase::rebooting) && now >= n.retry_at) identify(i, now);
      if (n.busy() && now >= n.queue.front().deadline) timed_out(i, now);
      if (n.homing.command != 0 && now >= n.homing.deadline) homing_not_found(i, now);
      next = std::min(next, n.homing.deadline);
      poll_if_due(i, now);
      pump(i, now);
      if (n.busy()) next = std::min(next, n.queue.front().deadline);
      if (n.phase == Phase::offline || n.phase == Phase::rebooting) next = std::min(next, n.retry_at);
      if (polled(n) && n.queue.empty()) next = std::min(next, n.next_poll);
      // A frame the transport refused is tried again soon.
      if (!n.queue.empty() && !n.queue.front().sent) next = std::min(next, now + n.cfg.request_timeout);
    }
    return next;
  }

  void timed_out(std::size_t i, TimePoint now) {
    Node& n = nodes[i];
    Request& r = n.queue.front();
    const int tries = 1 + std::max(n.cfg.retries, 0);
    if (r.attempts < tries) {
      // A shared group BG is retried to this node alone: the others have started.
      if (transmit(n.cfg.node_id, r.instruction)) {
        r.group.reset();
        ++r.attempts;
        ++counters.retries;
        r.deadline = deadline_of(n, now);
        return;
      }
    }
    ++counters.timeouts;
    const auto reason = fmt::format("{} did not answer {} after {} tries", n.name(), uim342::mnemonic(r.instruction.function), r.attempts);
    event(n, event_t::TIMEOUT, event_t::WARNING, 0, reason);
    if (r.command_id != 0) fail(r.command_id, error_code(ReplyError::kTimeout), reason);
    go_offline(i, reason, now);
  }
};

// ---- public forwarding ------------------------------------------------------------------------------

Uim342Stack::Uim342Stack(Uim342StackConfig config, CanStackContext context, WallClock wall_clock)
    : impl_(std::make_unique<Impl>(std::move(config), std::move(context), std::move(wall_clock), counters_)) {}

Uim342Stack::Uim342Stack(const config::Config& config, std::string_view bus, CanStackContext context, WallClock wall_clock)
    : Uim342Stack(Uim342StackConfig::from(config, bus), std::move(context), std::move(wall_clock)) {}

Uim342Stack::~Uim342Stack() = default;

std::vector<std::string> Uim342Stack::axes() const {
  std::vector<std::string> out;
  for (const auto& n : impl_->nodes) {
    if (!n.cfg.axis.empty()) out.push_back(n.cfg.axis);
  }
  return out;
}

void Uim342Stack::start(TimePoint now) {
  impl_->started = true;
  if (!impl_->poll_warning.empty()) {
    DriveEvent e;
    e.kind = event_t::CONFIG_MISMATCH;
    e.severity = event_t::WARNING;
    e.text = impl_->poll_warning;
    impl_->context.out->axis_event("", e);
  }
  for (std::size_t i = 0; i < impl_->nodes.size(); ++i) impl_->identify(i, now);
}

bool Uim342Stack::on_frame(const can::Frame& frame, TimePoint now) { return impl_->on_frame(frame, now); }
TimePoint Uim342Stack::process(TimePoint now) { return impl_->process(now); }
void Uim342Stack::execute(const motionlcm::gateway_command_t& command, TimePoint now) { impl_->execute(command, now); }
void Uim342Stack::fire(std::int64_t trigger_id, TimePoint now) { impl_->fire(trigger_id, now); }

Duration Uim342Stack::poll_period() const { return impl_->poll_period; }

bool Uim342Stack::ready() const {
  return impl_->started && std::all_of(impl_->nodes.begin(), impl_->nodes.end(), [](const Impl::Node& n) { return n.phase == Impl::Phase::ready; });
}

void Uim342Stack::add_statistics(motionlcm::bus_stats_t& stats) const {
  stats.timeouts += counters_.timeouts;
  stats.retries += counters_.retries;
  stats.errors += counters_.malformed;
  for (const auto& n : impl_->nodes) {
    if (n.status.online) ++stats.drives_online;
  }
  stats.drives_total += static_cast<std::int32_t>(impl_->nodes.size());
}

std::optional<DriveStatus> Uim342Stack::status(std::string_view axis) const {
  for (const auto& n : impl_->nodes) {
    if (n.cfg.axis == axis) return n.status;
  }
  return std::nullopt;
}

}  // namespace motion::gateway
