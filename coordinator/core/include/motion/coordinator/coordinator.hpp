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
// Thread contract: loop thread only. Never blocks.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <variant>
#include <vector>

#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/gateway_reply_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>

#include "motion/config/config.hpp"
#include "motion/coordinator/stop_guard.hpp"
#include "motion/lcm/reply_error.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/lcm/node.hpp"

namespace motion::coordinator {

// Planner seam, in drive counts. One entry per axis of a move.
struct PlanInput {
  std::string axis;
  config::Family family;
  std::int64_t start_counts = 0;
  std::int64_t target_counts = 0;
  double max_velocity = 0;      // counts/s
  double max_acceleration = 0;  // counts/s^2
};
struct AxisPlan {
  std::string axis;
  std::int64_t target_counts = 0;
  double velocity = 0;          // counts/s, as the drive will realize it
  double acceleration = 0;      // counts/s^2
  double deceleration = 0;      // counts/s^2
  double duration_s = 0;        // realized duration of this axis's profile
};
struct MovePlan {
  std::vector<AxisPlan> axes;
  double duration_s = 0;          // the longest realized duration
  double predicted_skew_us = 0;   // arrival spread after quantization
};
using MovePlanner = std::function<std::variant<MovePlan, std::string>(const std::vector<PlanInput>& inputs, double velocity_scale,
                                                                       double acceleration_scale)>;

class Coordinator {
 public:
  Coordinator(EventLoop& loop, lcm::Node& node, const config::Config& config, MovePlanner planner);
  ~Coordinator();
  Coordinator(const Coordinator&) = delete;
  Coordinator& operator=(const Coordinator&) = delete;

  [[nodiscard]] std::size_t active_requests() const { return requests_.size(); }
  // Buses whose gateway has not been heard within gateway_timeout_ms (requests for their axes
  // are rejected as offline): the coordinator's health lists them.
  [[nodiscard]] std::vector<std::string> buses_without_gateway() const;

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
  };
  struct GatewayLive {
    TimePoint last_heartbeat{};
    std::int32_t pid = 0;
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
  struct Request {
    std::uint64_t serial = 0;
    motionlcm::request_t msg{};
    Phase phase = Phase::kWaitingGateways;
    std::vector<std::string> axes;                 // in request order
    std::map<std::string, std::int64_t> targets;   // counts, moves only
    std::map<std::string, double> target_units;    // the same in user units, before rounding
    std::map<std::string, std::int64_t> starts;    // counts at planning
    std::set<std::string> still;                   // moves: axes already at their target (no command)
    std::map<std::int64_t, std::string> pending;   // command id -> bus, awaiting the next reply
    std::set<std::string> buses;
    // Moves: one ARM_MOVE per start mechanism (see start_move), all on one trigger id.
    std::map<std::string, std::int64_t> axis_command;   // axis -> its ARM_MOVE command id
    std::size_t move_commands = 0;
    std::map<std::int64_t, std::int64_t> started_utime;  // command -> when its start frame went on the wire
    std::map<std::int64_t, double> start_spread_us;      // command -> its gateway's spread of its start frames
    bool started_sent = false;
    std::int64_t trigger_id = 0;
    std::int64_t fire_utime = 0;
    MovePlan plan;
    motionlcm::param_t param_result{};
    Outcome outcome;                               // kReleasing, kStopping: the terminal reply to send
    std::set<std::string> stopping;                // kStopping: the axes whose stop must be confirmed
    std::string unreached;                         // stops: axes whose gateway was offline
    std::string gateway_failure;                   // stops: what a gateway said when its stop failed
    TimePoint gateways_done{};                     // kConfirming: when the last gateway said DONE
    EventLoop::TimerId timeout_timer = 0;
    EventLoop::TimerId progress_timer = 0;
    EventLoop::TimerId arm_timer = 0;
  };

  void on_request(const motionlcm::request_t& msg);
  // A request that does not decode: REJECTED (code 1) when its client and request ids are readable.
  void on_malformed_request(const void* data, int size, const std::string& why);
  void on_axis_state(const motionlcm::axis_state_t& state);
  void on_gateway_reply(const motionlcm::gateway_reply_t& reply);
  void on_event(const motionlcm::event_t& event);
  void on_health(const motionlcm::health_t& health);
  void check_gateways();
  // The desired state of every active motion request on ACTIVE_MOVES (active_moves_t).
  void publish_active_moves();

  // Validation: an error (code, reason) or nothing.
  std::optional<std::pair<ReplyError, std::string>> validate(const motionlcm::request_t& msg, std::vector<std::string>& axes);
  std::optional<std::pair<ReplyError, std::string>> check_axis_ready(const std::string& axis, bool need_enabled);
  // Where a move of `kind` by `value` (user units) ends on `a`: absolute, or relative to the last
  // commanded target while the axis stands there (else to its position).
  [[nodiscard]] double move_target_units(const AxisLive& a, std::int8_t kind, double value) const;
  // Targets in counts and the plan of the axes that have to move; an error leaves nothing sent.
  std::optional<std::pair<ReplyError, std::string>> plan_move(Request& r);

  void start_move(Request& r);
  // The axes of a move on `bus`, split by start mechanism: every UIM342 group moving whole (one BG
  // to its group id), each other UIM342 axis, and per remaining family all its axes (UC57: one
  // SYNC; ADAM: one broadcast; UIM242: global instructions).
  [[nodiscard]] std::vector<std::vector<motionlcm::axis_command_t>> start_groups(const std::string& bus,
                                                                                std::vector<motionlcm::axis_command_t> axes) const;
  void start_simple(Request& r);
  void preempt(const motionlcm::request_t& stop);
  void fire(Request& r);
  void check_move_done(Request& r);
  void abort_group(Request& r, std::int8_t status, ReplyError error, const std::string& reason);
  // A move not yet triggered: DISARM what any gateway may hold, then the terminal reply (at the
  // latest after kReleaseTimeout).
  void release_armed(Request& r, Outcome outcome);
  void end_with(Request& r, const Outcome& outcome);
  // kConfirming: the axis states show what the request did (enabled, disabled, no fault, at rest).
  [[nodiscard]] std::optional<std::string> unconfirmed(const Request& r) const;
  void check_confirmed(Request& r, bool final_check);

  std::int64_t send_command(Request& r, const std::string& bus, std::int8_t kind, std::vector<motionlcm::axis_command_t> axes);
  void send_stop(const std::vector<std::string>& axes, bool emergency, std::int64_t request_id);
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
  [[nodiscard]] bool gateway_alive(const std::string& bus) const;
  [[nodiscard]] double tolerance_counts(const AxisLive& a) const;
  Request* find_by_command(std::int64_t command_id);

  EventLoop& loop_;
  lcm::Node& node_;
  const config::Config& config_;
  MovePlanner planner_;
  std::map<std::string, AxisLive> axes_;
  std::map<std::string, GatewayLive> gateways_;  // by bus
  std::map<std::uint64_t, std::unique_ptr<Request>> requests_;
  StopGuard stops_;
  std::set<std::pair<std::string, std::int64_t>> active_ids_;  // (client_id, request_id)
  std::uint64_t next_serial_ = 1;
  std::int64_t next_command_id_ = 1;
  std::int64_t next_trigger_id_ = 1;
  EventLoop::TimerId watchdog_ = 0;
  EventLoop::TimerId active_moves_timer_ = 0;
  bool active_moves_published_ = false;  // the last ACTIVE_MOVES listed something
};

}  // namespace motion::coordinator
