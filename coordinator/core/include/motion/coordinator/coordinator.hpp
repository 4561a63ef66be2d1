// The coordinator: the single entry point for clients.
//
// Every request_t gets replies on REPLY that end in exactly one terminal status:
//   validate (REJECTED with a reason and error code)  -> ACCEPTED
//   moves:  plan -> ARM_MOVE to every gateway involved (each loads and verifies, replies ARMED)
//           -> SYNC_TRIGGER at a common wall-clock time -> STARTED -> PROGRESS ... -> DONE
//   others: one gateway command per bus -> DONE when every gateway is done
// Abort paths: stop / e-stop requests preempt (ABORTED, kStopped); an axis of the group faults,
// stalls or hits a limit, or a gateway's heartbeat is lost or restarts (the rest of the group is
// stopped, ABORTED with the cause); request timeout (FAILED, kTimeout); a gateway error (FAILED).
// Every stop sent is watched until the axis states confirm standstill (StopGuard: repeated, then
// an e-stop, then given up and reported); an aborted request's terminal reply waits for that and
// says which axes could not be confirmed stopped. An axis already moving when the coordinator
// first hears of it (a coordinator restarted mid-motion) is stopped, with an UNOWNED_MOTION event.
// The desired state of the active motion requests goes out on ACTIVE_MOVES every 500 ms, on every
// change, and before the requests hit by a gateway restart are aborted (active_moves_t).
//
// The lifecycle of one request (Request::phase):
//   moves:   kArming -> kTriggered -> done
//            kArming -> kReleasing (could not be armed everywhere: DISARM, then the terminal reply)
//   others:  kWaitingGateways -> kConfirming (the gateways are done, the axis states must show it)
//   any motion -> kStopping (aborted: the terminal reply waits for the StopGuard)
//
// Passive: no sockets, no timers, no clock reads. Messages come in through the on_*() inputs,
// each with `now` (steady time); process(now) runs what is due (request, arming, release and
// confirmation deadlines, PROGRESS replies, the gateway watchdog, the StopGuard, ACTIVE_MOVES
// republishing) and returns the next deadline (kNever: nothing scheduled). Everything sent goes out
// through CoordinatorOutput; wall-clock stamps (utime fields, SYNC fire times) come from the
// WallClock the core is built with. The caller calls process() after every input and again at
// the deadline it returned: CoordinatorService (coordinator_service.hpp) does so over LCM.
//
// Thread contract: single-threaded (the process's loop thread); no call blocks. The outputs are
// called from inside the inputs and process() and must not call back into the core.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include <motionlcm/active_moves_t.hpp>
#include <motionlcm/arm_timing_t.hpp>
#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/drive_model_request_t.hpp>
#include <motionlcm/drive_model_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/gateway_command2_t.hpp>
#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/line_timing_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>
#include <motionlcm/trigger_heard_t.hpp>

#include "motion/config/config.hpp"
#include "motion/coordinator/start_schedule.hpp"
#include "motion/coordinator/stop_guard.hpp"
#include "motion/coordinator/trigger_lead.hpp"
#include "motion/core/clock.hpp"
#include "motion/lcm/reply_error.hpp"
#include "motion/planner/quantizer.hpp"

namespace motion::coordinator {

// Planner seam, in drive counts. One entry per axis of a move.
struct PlanInput {
  std::string axis;
  config::Family family;
  std::int64_t start_counts = 0;
  std::int64_t target_counts = 0;
  double max_velocity = 0;      // counts/s
  double max_acceleration = 0;  // counts/s^2
  // What the axis's drive can execute, from its gateway's DRIVE_MODEL (never null when the core
  // calls the planner: an axis without a model is refused before planning).
  std::shared_ptr<const planner::DriveQuantizer> quantizer = nullptr;
  std::int64_t model_utime = 0;  // utime of the drive model the quantizer was made from
};
struct AxisPlan {
  std::string axis;
  std::int64_t target_counts = 0;
  double velocity = 0;      // counts/s, as the drive will realize it
  double acceleration = 0;  // counts/s^2
  double deceleration = 0;  // counts/s^2
  double duration_s = 0;    // realized duration of this axis's profile
  // The same motion as integers of the drive model's grids (what gateway_command2_t carries), and
  // the utime of that model.
  planner::NativeMotion native;
  std::int64_t model_utime = 0;
};
struct MovePlan {
  std::vector<AxisPlan> axes;
  double duration_s = 0;         // the longest realized duration
  double predicted_skew_us = 0;  // arrival spread after quantization
};
using MovePlanner = std::function<std::variant<MovePlan, std::string>(
    const std::vector<PlanInput>& inputs, double velocity_scale, double acceleration_scale)>;

// Where the coordinator's messages go (one function per channel it publishes on).
class CoordinatorOutput {
 public:
  virtual ~CoordinatorOutput() = default;
  virtual void reply(const motionlcm::reply_t& reply) = 0;  // REPLY
  // GW_COMMAND2_<bus>: `command`, its motion values as integers of the axes' drive-model grids;
  // `counts` is the same command with them in counts/s as the core computed them (logs, tests).
  virtual void gateway_command(const std::string& bus, const motionlcm::gateway_command2_t& command,
                               const motionlcm::gateway_command_t& counts) = 0;
  virtual void sync_trigger(const motionlcm::sync_trigger_t& trigger) = 0;  // SYNC_TRIGGER
  // SYNC_TRIGGER2: the scheduled start (per-bus hand-over times), sent before SYNC_TRIGGER of the
  // same trigger id. Default: dropped.
  virtual void sync_trigger2(const motionlcm::sync_trigger2_t& /*trigger*/) {}
  virtual void active_moves(const motionlcm::active_moves_t& moves) = 0;  // ACTIVE_MOVES
  virtual void event(const motionlcm::event_t& event) = 0;                // EVENT
  // DRIVE_MODEL_REQUEST: asks the gateways for the drive models the core lacks. Default: dropped.
  virtual void drive_model_request(const motionlcm::drive_model_request_t& /*request*/) {}
};

// Microseconds since the Unix epoch, as wall_time_us() (motion/core/clock.hpp) reads them.
using WallClock = std::function<std::int64_t()>;

class Coordinator {
 public:
  // `config` and `output` must outlive the core (the configuration is read, not copied).
  Coordinator(const config::Config& config, MovePlanner planner, CoordinatorOutput& output,
              WallClock wall_clock = wall_time_us);
  Coordinator(const Coordinator&) = delete;
  Coordinator& operator=(const Coordinator&) = delete;

  // ---- inputs (REQUEST, AXIS_STATE, GW_REPLY, EVENT, HEALTH)
  // A request sent again unchanged (the same client id, request id and content; its send time
  // aside) by a client that heard no reply to it, LCM having lost the request or the reply: its
  // latest reply goes out again, word for word, and nothing else happens. That is the request's
  // ACCEPTED/STARTED/PROGRESS while it runs, its terminal reply once it ended (the last
  // kRememberedReplies terminal replies are kept). The same ids with other content while the first
  // runs: REJECTED 9 as before.
  static constexpr std::size_t kRememberedReplies = 1024;
  void on_request(const motionlcm::request_t& msg, TimePoint now);
  // A request that does not decode (its bytes, and why): REJECTED (code 1) when its client and
  // request ids are readable, else nothing (nobody to answer).
  void on_malformed_request(std::span<const std::uint8_t> bytes, const std::string& why, TimePoint now);
  // Any other malformed message the caller received (rate-limited there): a PROTOCOL_ERROR event.
  void on_malformed_message(const std::string& what, TimePoint now);
  // A request the security gate refused (CoordinatorService: unsigned while security is
  // enforced, or a signed one that did not verify): a SECURITY event with `reason`, and nothing
  // else happens. `answer_to`: the refused request when its ids are authentic (signed, fresh,
  // its signer's own client id): it also gets a REJECTED reply (kUnauthorized). Without it no
  // reply goes out, since ids that cannot be trusted may be somebody else's.
  void on_refused_request(const std::optional<motionlcm::request_t>& answer_to, const std::string& reason,
                          TimePoint now);
  // A gateway message the security gate refused (CoordinatorService, mode enforce): a SECURITY
  // event with `reason`; nothing else happens.
  void on_refused_message(const std::string& reason, TimePoint now);
  void on_axis_state(const motionlcm::axis_state_t& state, TimePoint now);
  void on_gateway_reply(const motionlcm::gateway_reply_t& reply, TimePoint now);
  void on_event(const motionlcm::event_t& event, TimePoint now);
  void on_health(const motionlcm::health_t& health, TimePoint now);
  // ORPHANED_MOVES: rows a gateway last had from a coordinator that stopped heartbeating. Each of
  // their requests that is not this coordinator's own ends once, ABORTED (code 20), so that its
  // client gets its terminal reply; what still moves is stopped as unowned motion.
  void on_orphaned_moves(const motionlcm::active_moves_t& moves, TimePoint now);
  // DRIVE_MODEL: what an axis's drive can execute, as its gateway knows it. Moves of an axis are
  // planned and quantized from its latest model only; an axis without one is refused (code 21,
  // kNoDriveModel). A model naming an unknown axis, another bus or another family than the
  // configuration's is ignored with a PROTOCOL_ERROR event. While an axis whose gateway is alive
  // has no model, a DRIVE_MODEL_REQUEST goes out once a second.
  void on_drive_model(const motionlcm::drive_model_t& model, TimePoint now);
  // ARM_TIMING: how long arming an axis's move takes on its bus, added to the arming deadline
  // (arming_line_time). One for an axis that is not configured or not on that bus is ignored; an
  // axis without one adds nothing (arm_timeout_ms alone).
  void on_arm_timing(const motionlcm::arm_timing_t& timing, TimePoint now);
  // LINE_TIMING: what a start frame may wait behind on a bus (a serial line's exchange under way
  // when its gateway hears the trigger). A start of several buses is scheduled so that each bus
  // hears its trigger at least that long before its send time (start_schedule.hpp). One of a bus
  // that is not configured is ignored; one that is not a time from 0 to 1 s is ignored with a
  // PROTOCOL_ERROR event; a bus without one waits 0.
  void on_line_timing(const motionlcm::line_timing_t& timing, TimePoint now);
  // TRIGGER_HEARD: when the gateway of a bus heard a trigger of this coordinator: a sample of the
  // adaptive trigger lead (trigger_lead.hpp). One of a bus that is not configured, or of a trigger
  // this coordinator did not send lately, is ignored.
  void on_trigger_heard(const motionlcm::trigger_heard_t& heard, TimePoint now);
  // The lead a trigger of `buses` would get now (several buses; one bus starts at once), microseconds.
  [[nodiscard]] std::int64_t trigger_lead_us(const std::set<std::string>& buses) const {
    return trigger_lead_.lead_us(buses);
  }

  // Runs everything due at `now`; returns the next deadline, kNever when nothing is scheduled.
  [[nodiscard]] TimePoint process(TimePoint now);

  [[nodiscard]] std::size_t active_requests() const { return requests_.size(); }
  // Buses whose gateway has not been heard within gateway_timeout_ms before `now` (requests for
  // their axes are rejected as offline): the coordinator's health lists them.
  [[nodiscard]] std::vector<std::string> buses_without_gateway(TimePoint now) const;
  // Axes of which no AXIS_STATE has arrived since this coordinator started (requests for them are
  // refused as offline): until it is empty the coordinator's health is DEGRADED.
  [[nodiscard]] std::vector<std::string> axes_never_heard() const;
  // Whether `health` is a heartbeat of the process this core last took as the gateway of its bus
  // (same host and pid) and that one was heard within gateway_timeout_ms before `now`: under
  // enforce the plain copy of a live gateway's signed heartbeat, not looked at in silence
  // (CoordinatorService); any other plain heartbeat claiming a gateway is a refusal to report.
  [[nodiscard]] bool is_live_gateways_heartbeat(const motionlcm::health_t& health, TimePoint now) const;
  // The bus of a configured axis, and of a gateway command awaiting its reply (nullopt: none).
  [[nodiscard]] std::optional<std::string> bus_of_axis(const std::string& axis) const;
  [[nodiscard]] std::optional<std::string> bus_of_command(std::int64_t command_id) const;
  // The latest drive model of `axis` (nullptr: none yet).
  [[nodiscard]] const motionlcm::drive_model_t* drive_model(const std::string& axis) const;

 private:
  struct AxisLive {
    const config::Axis* axis = nullptr;
    const config::Drive* drive = nullptr;
    std::optional<motionlcm::axis_state_t> state;
    TimePoint received{};
    std::uint64_t busy_with = 0;  // serial of the request moving it, 0 = free
    // The target of the last move that ended DONE on this axis, in user units and in counts:
    // relative moves count from it while the axis stands there, so that N relative steps round
    // once and never drift. Cleared by anything else that moves or re-references the axis.
    std::optional<double> commanded_units;
    std::int64_t commanded_counts = 0;
    // From DRIVE_MODEL: the message, and the quantizer made of it (or why none could be made).
    std::optional<motionlcm::drive_model_t> model;
    std::shared_ptr<const planner::DriveQuantizer> quantizer;
    std::string model_error;
    motionlcm::arm_timing_t arming{};  // from ARM_TIMING; zero until one arrives
  };
  struct GatewayLive {
    TimePoint last_heartbeat{};  // TimePoint{}: announced STOPPING (offline until it heartbeats)
    std::int32_t pid = 0;
    std::string host;         // of its last heartbeat
    TimePoint last_health{};  // its last heartbeat (axis states do not count here)
    double uptime_s = 0;
    bool seen = false;
  };
  // kReleasing: a move that could not be armed everywhere waits for its DISARMs before its
  // terminal reply; kConfirming: the gateways are done and the axis states must show it;
  // kStopping: aborted, its terminal reply waits until the StopGuard resolved its axes.
  enum class Phase { kWaitingGateways, kArming, kTriggered, kReleasing, kConfirming, kStopping, kDone };
  struct Outcome {
    std::int8_t status = 0;
    ReplyError error = ReplyError::kNone;
    std::string reason;
  };
  // A gateway command of a request awaiting its next reply.
  struct PendingCommand {
    std::string bus;
    bool armed = false;  // ARM_MOVE: its gateway replied ARMED
    // Sent again, word for word, while no reply to it is heard (resend_unanswered()).
    motionlcm::gateway_command_t command{};
    motionlcm::gateway_command2_t command2{};  // what goes out (command with grid integers)
    bool heard = false;
    TimePoint resend_at = kNever;
  };
  // A gateway command without any reply after this long is sent again (LCM may have lost it or
  // its reply); a gateway answers a command it already has with its latest reply to it and runs
  // nothing twice (README "Safety and faults").
  static constexpr Duration kCommandResend = std::chrono::milliseconds(300);
  // Sends again what is due; the earliest of the next re-sends.
  TimePoint resend_unanswered();
  struct Request {
    std::uint64_t serial = 0;
    motionlcm::request_t msg{};
    Phase phase = Phase::kWaitingGateways;
    std::vector<std::string> axes;                   // in request order
    std::map<std::string, std::int64_t> targets;     // counts, moves only
    std::map<std::string, double> target_units;      // the same in user units, before rounding
    std::map<std::string, std::int64_t> starts;      // counts at planning
    std::set<std::string> still;                     // moves: axes already at their target (no command)
    std::map<std::int64_t, PendingCommand> pending;  // by command id
    // Moves, jogs, homing: per axis its motion as grid integers and its model's utime
    // (gateway_command2_t; velocity, acceleration, deceleration and model_utime are used).
    std::map<std::string, motionlcm::axis_command2_t> grid;
    std::set<std::string> buses;
    // Moves: one ARM_MOVE per start mechanism (see start_move), all on one trigger id.
    std::map<std::string, std::int64_t> axis_command;  // axis -> its ARM_MOVE command id
    std::size_t move_commands = 0;
    std::map<std::int64_t, std::int64_t> started_utime;  // command -> when its start frame went on the wire
    std::map<std::int64_t, double> start_spread_us;      // command -> its gateway's spread of its start frames
    bool started_sent = false;
    std::int64_t trigger_id = 0;
    std::int64_t fire_utime = 0;
    std::vector<StartFrame> start_frames;  // moves: one per ARM_MOVE, with its wire time from the drive model
    MovePlan plan;
    motionlcm::param_t param_result{};
    Outcome outcome;                   // kReleasing, kStopping: the terminal reply to send
    std::set<std::string> stopping;    // kStopping: the axes whose stop must be confirmed
    std::string unreached;             // stops: axes whose gateway was offline
    std::string gateway_failure;       // stops: what a gateway said when its stop failed
    TimePoint gateways_done{};         // kConfirming: when the last gateway said DONE
    int timeout_ms = 0;                // the request's timeout in effect
    TimePoint timeout_at = kNever;     // FAILED (kTimeout) then, once
    TimePoint next_progress = kNever;  // kTriggered: the next PROGRESS reply
    // kArming: the arm timeout; kReleasing: the end of the wait for DISARM replies; kConfirming:
    // the last look at the axis states. Once, and only in the phase that set it.
    TimePoint phase_deadline = kNever;
    std::optional<motionlcm::reply_t> last_reply;  // the latest reply sent (answer_again)
  };

  // Every input and process() start here: `now` becomes the core's time.
  void begin(TimePoint now);
  [[nodiscard]] TimePoint next_deadline() const;
  void on_phase_deadline(Request& r);
  void check_gateways();
  // ACTIVE_MOVES is republished while a motion request is active, and once more after the last.
  [[nodiscard]] bool active_moves_wanted() const;
  // The desired state of every active motion request on ACTIVE_MOVES (active_moves_t).
  void publish_active_moves();

  // Validation: an error (code, reason) or nothing.
  std::optional<std::pair<ReplyError, std::string>> validate(const motionlcm::request_t& msg,
                                                             std::vector<std::string>& axes);
  std::optional<std::pair<ReplyError, std::string>> check_axis_ready(const std::string& axis, bool need_enabled);
  // Where a move of `kind` by `value` (user units) ends on `a`: absolute, or relative to the last
  // commanded target while the axis stands there (else to its position).
  [[nodiscard]] double move_target_units(const AxisLive& a, std::int8_t kind, double value) const;
  // Targets in counts and the plan of the axes that have to move; an error leaves nothing sent.
  std::optional<std::pair<ReplyError, std::string>> plan_move(Request& r);

  void start_move(Request& r);
  // The axes of a move on `bus`, split by start mechanism, from the drive models: a group BG when
  // the move holds the whole group, or at least two and at least half of it while the group's
  // other axes are free and at rest (their axis states), one SYNC, one ADAM broadcast, one UIM242
  // global start (each shared by the axes that offer it at the same address), else each axis on
  // its own.
  // `kinds` (optional) gets each group's mechanism (drive_model_t::START_*).
  [[nodiscard]] std::vector<std::vector<motionlcm::axis_command_t>> start_groups(
      const std::string& bus, std::vector<motionlcm::axis_command_t> axes,
      std::vector<std::int8_t>* kinds = nullptr) const;
  // The wire time of the start frame of a group of `kind` (its drive models'; 0 when none says).
  [[nodiscard]] double start_frame_wire_us(const std::vector<motionlcm::axis_command_t>& group, std::int8_t kind) const;
  [[nodiscard]] double start_lead_in_us(const std::vector<motionlcm::axis_command_t>& group) const;
  // The line time the gateways need to arm `per_bus` (axis commands per bus), from the drive
  // ARM_TIMINGs (arm_line_us per axis armed, arm_bystander_us per other drive of its bus): the slowest
  // bus's. Added to arm_timeout_ms for the arming deadline.
  [[nodiscard]] Duration arming_line_time(
      const std::map<std::string, std::vector<motionlcm::axis_command_t>>& per_bus) const;
  void start_simple(Request& r);
  void preempt(const motionlcm::request_t& stop);
  void fire(Request& r);
  // DONE once every start mechanism reported STARTED and every moving axis rests at its target.
  void check_move_done(Request& r);
  // The axes of a triggered move that have not arrived yet: moving (or not heard since the
  // trigger) in `*moving`, at rest elsewhere in the returned text ("" when every axis arrived).
  [[nodiscard]] std::string short_of_target(const Request& r, std::vector<std::string>* moving) const;
  // A triggered move past its predicted end (fire(): the start, the planned duration and two
  // gateway timeouts): a trigger or a STARTED reply lost on the way, or an axis that came to rest
  // short of its target, ends it here instead of at the request's timeout.
  void move_overdue(Request& r);
  void abort_group(Request& r, std::int8_t status, ReplyError error, const std::string& reason);
  // A move not yet triggered: DISARM what any gateway may hold, then the terminal reply (at the
  // latest after kReleaseTimeout).
  void release_armed(Request& r, Outcome outcome);
  void end_with(Request& r, const Outcome& outcome);
  // kConfirming: the axis states show what the request did (enabled, disabled, no fault, at rest).
  [[nodiscard]] std::optional<std::string> unconfirmed(const Request& r) const;
  void check_confirmed(Request& r, bool final_check);

  std::int64_t send_command(Request& r, const std::string& bus, std::int8_t kind,
                            std::vector<motionlcm::axis_command_t> axes);
  void send_stop(const std::vector<std::string>& axes, bool emergency, std::int64_t request_id);
  // `command` as it goes out (coordinator_grid.cpp): a gateway_command2_t with the grid integers
  // of `grid` (r.grid; none for commands without motion values), and sent.
  [[nodiscard]] static motionlcm::gateway_command2_t to_grid(
      const motionlcm::gateway_command_t& command, const std::map<std::string, motionlcm::axis_command2_t>* grid);
  // A jog's or homing run's motion on the axis's model grids (velocity signed, ramps by magnitude):
  // the nearest values within the model's ranges that are not faster or steeper (0: the drive's own).
  [[nodiscard]] static motionlcm::axis_command2_t grid_of(const motionlcm::drive_model_t& model,
                                                          const motionlcm::axis_command_t& counts);
  // Aborted requests wait in kStopping for their axes' stops (see StopGuard).
  void enter_stopping(Request& r, std::set<std::string> axes, Outcome outcome);
  // Runs the StopGuard: sends what it escalates, reports it, and ends the requests it resolved.
  void check_stops();
  // How long `a` may take to report standstill after one stop.
  [[nodiscard]] Duration stop_allowance(const AxisLive& a) const;
  void publish_event(const std::string& axis, std::int8_t severity, std::int16_t kind, const std::string& text);
  void reply(Request& r, std::int8_t status, ReplyError error = ReplyError::kNone, const std::string& reason = {});
  void reply_unknown(const motionlcm::request_t& msg, std::int8_t status, ReplyError error, const std::string& reason);
  void finish(std::uint64_t serial);
  // on_request(): answers a request sent again (see there); false when `msg` is not one.
  bool answer_again(const motionlcm::request_t& msg);
  // A terminal reply kept for answer_again(), with the request it answered.
  void remember(const motionlcm::request_t& msg, const motionlcm::reply_t& terminal);
  [[nodiscard]] bool gateway_alive(const std::string& bus) const { return gateway_alive_at(bus, now_); }
  [[nodiscard]] bool gateway_alive_at(const std::string& bus, TimePoint now) const;
  // When the gateway of `bus` counts as lost unless it is heard again (kNever: not alive now).
  [[nodiscard]] TimePoint gateway_expiry(const std::string& bus) const;
  [[nodiscard]] double tolerance_counts(const AxisLive& a) const;
  Request* find_by_command(std::int64_t command_id);

  const config::Config& config_;
  MovePlanner planner_;
  CoordinatorOutput& out_;
  WallClock wall_clock_;
  TimePoint now_{};  // of the input or process() call running
  std::map<std::string, AxisLive> axes_;
  std::map<std::string, GatewayLive> gateways_;  // by bus
  std::map<std::uint64_t, std::unique_ptr<Request>> requests_;
  StopGuard stops_;
  std::map<std::string, double> start_wait_us_;  // bus -> LINE_TIMING start_wait_us
  TriggerLead trigger_lead_;                     // how far ahead a trigger of several buses schedules the start
  std::set<std::pair<std::string, std::int64_t>> active_ids_;     // (client_id, request_id)
  std::set<std::pair<std::string, std::int64_t>> orphans_ended_;  // requests of a predecessor answered
  struct Answered {
    motionlcm::request_t msg;
    motionlcm::reply_t reply;
  };
  std::map<std::pair<std::string, std::int64_t>, Answered> remembered_;  // the latest terminal replies
  std::deque<std::pair<std::string, std::int64_t>> remembered_order_;    // oldest first
  TimePoint next_resend_ = kNever;                                       // resend_unanswered()
  std::uint64_t next_serial_ = 1;
  std::int64_t next_command_id_ = 1;
  std::int64_t next_trigger_id_ = 1;
  TimePoint next_active_moves_ = kNever;  // the ACTIVE_MOVES period, from the first `now` seen
  TimePoint next_model_request_{};        // DRIVE_MODEL_REQUEST while models are missing
  // Axes of a live gateway that have no drive model yet (their buses, for the request).
  [[nodiscard]] std::set<std::string> buses_missing_models() const;
  bool active_moves_published_ = false;  // the last ACTIVE_MOVES listed something
};

}  // namespace motion::coordinator
