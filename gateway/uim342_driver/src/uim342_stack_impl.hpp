// Private to the UIM342 stack's sources (uim342_stack.cpp: construction, bookkeeping, sending,
// polling, frames in, time; uim342_stack_setup.cpp: identification, set-up, reboots, ACKs and
// status; uim342_stack_commands.cpp: commands, synchronized start, parameters;
// uim342_stack_homing.cpp: HOME with a switch search): the Impl and the helpers they share. Not
// installed, not included elsewhere. Thread contract as Uim342Stack's: single-threaded, nothing blocks.
#pragma once
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
#include "motion/gateway/command_ledger.hpp"
#include "motion/gateway/power_up_watch.hpp"

namespace motion::gateway {
namespace uim342_stack_detail {

using motionlcm::event_t;
using motionlcm::gateway_command_t;
using motionlcm::gateway_reply_t;
using uim342::FunctionCode;
using uim342::Instruction;
namespace rq = uim342::request;

// A gateway command kind as text ("ARM_MOVE"), for reasons.
std::string command_name(std::int8_t kind);

template <typename T>
T saturate(long long v) {
  return static_cast<T>(std::clamp<long long>(v, std::numeric_limits<T>::min(), std::numeric_limits<T>::max()));
}

}  // namespace uim342_stack_detail

using namespace uim342_stack_detail;  // the helpers above, unqualified in the stack's sources

struct Uim342Stack::Impl {
  // kStoppingForSetup: found running at set-up (a move no process of this gateway started), stopped
  // (ST); identified and set up again at retry_at, once at rest.
  enum class Phase { kIdle, kIdentifying, kSettingUp, kReady, kSetupFailed, kOffline, kRebooting, kStoppingForSetup };

  // One shared BG frame for every member of a group start, sent once when all of them are free.
  // `members` are the command's parts; `bystanders` the drives of the group outside it, each
  // holding PR=0 (hold_bystanders()), for which the same BG is a move of zero counts.
  struct GroupSend {
    std::uint8_t group_id = 0;
    std::int64_t command_id = 0;
    std::vector<std::size_t> members;
    std::vector<std::size_t> bystanders;
  };

  struct Request {
    Instruction instruction;
    std::int64_t command_id = 0;  // 0: the stack's own (identify, setup, poll)
    // The stack's own background work (identification, set-up, status polls): through the poll
    // slot, behind every command request.
    bool background = false;
    std::uint64_t poll_seq = 0;  // a background request's place in the order they were handed over
    TimePoint answer_due{};      // holds polls back until then at most (poll_may_go)
    std::shared_ptr<GroupSend> group;
    std::int64_t hold_for = 0;  // a PR=0 holding a bystander of this ARM_MOVE's group start
    int attempts = 0;
    bool sent = false;
    TimePoint deadline{};
  };

  struct Node {
    Uim342NodeConfig cfg;
    Phase phase = Phase::kIdle;
    std::deque<Request> queue;
    DriveStatus status;
    TimePoint next_poll{};
    bool poll_waiting = false;  // in poll_queue
    TimePoint retry_at{};
    std::chrono::milliseconds backoff{0};
    bool ever_online = false;
    bool offline_reported = false;
    bool setup_refused = false;  // the drive refused a set-up value (CONFIG_MISMATCH)
    bool group_ok = false;       // PP[8] reads back the configured group id
    bool rebooted_for_group = false;
    bool restarted_for_micro_steps = false;  // MT[0]/QE[4] were stored and the drive restarted
    std::uint16_t read_micro_steps = 0;      // MT[0] as read at set-up
    uim342::AccelerationUnit unit = uim342::AccelerationUnit::kPulsesPerS2;
    double cut_in_pps = 0;
    std::int64_t offset = 0;  // reported position = drive counter + offset (SET_POSITION)
    // Power-cycle detection (see on_kinematics()): the drive counter's samples, and whether the
    // driver was on before the latest MS[0].
    PowerUpWatch power;
    bool was_enabled = false;
    // Power-on marker (see check_marker()): MT[3] as last read, and the value this stack wrote to
    // the drive's RAM (nullopt: none there now).
    std::optional<std::uint16_t> delay_read;
    std::optional<std::uint16_t> marker;
    TimePoint marker_checked{};
    std::int64_t move = 0;  // active ARM_MOVE command
    // The ARM_MOVE whose group BG this drive, at rest outside the move, joins holding PR=0
    // (hold_bystanders()); 0: none. Not polled meanwhile, like an armed drive.
    std::int64_t held_for = 0;
    bool bg_acked = false;     // of the active move
    bool seen_moving = false;  // since the active move's BG
    // A BG was acknowledged after the last status read: it may run whatever that read said.
    bool started_since_status = false;
    // A HOME with a switch search (§5.26), one step after the other; see load_home().
    struct Homing {
      enum class Step { kNone, kReading, kSearchingLoad, kSearching, kReturningLoad, kReturning };
      std::int64_t command = 0;
      Step step = Step::kNone;
      uim342::InputPort port = uim342::InputPort::kIn1;
      bool rising = false;      // the armed edge
      double velocity = 0;      // of the search, counts/s; the sign is the direction
      double acceleration = 0;  // counts/s^2 of the command (0: the drive's)
      double deceleration = 0;
      std::int64_t offset = 0;                       // the position of the switch edge (HOME target_counts)
      std::optional<uim342::InputActions> previous;  // IL[port] before arming, restored after
      bool armed = false;                            // IL[port] holds the origin action
      bool seen_moving = false;                      // in the present step
      bool edge_seen = false;                        // the armed edge was notified
      TimePoint deadline = kNever;                   // of the search
      Duration bound{};
    } homing;
    [[nodiscard]] std::string name() const { return fmt::format("{} (node {})", cfg.drive, cfg.node_id); }
    [[nodiscard]] const std::string& axis_or_drive() const { return cfg.axis.empty() ? cfg.drive : cfg.axis; }
    [[nodiscard]] bool busy() const { return !queue.empty() && queue.front().sent; }
  };

  // What the stack keeps per command beside its parts' lifecycle (the CommandLedger's): the
  // nodes with requests of the current step not yet answered, targets, a stop's unreachable nodes.
  struct CommandData {
    std::set<std::size_t> waiting;  // nodes with requests of the current stage not yet answered
    std::map<std::size_t, std::int64_t> targets;
    std::string unreached;           // a stop's offline nodes: the others are still stopped, then it fails
    std::vector<std::string> notes;  // the DONE reply's reason (what a HOME did, per axis)
    // An ARM_MOVE of part of a UIM342 group: the group's other drives whose PR=0 is not yet
    // acknowledged, and those holding it. One released meanwhile is in neither: the start is
    // then one BG per drive.
    std::set<std::size_t> holding;
    std::set<std::size_t> held;
  };
  using Ledger = CommandLedger<CommandData>;
  using Command = Ledger::Entry;  // parts per node: Loading -> Armed -> Started -> Done | Failed | Stopped

  Impl(Uim342StackConfig c, CanStackContext ctx, WallClock wc, Counters& shared_counters);

  // Wire time of one request and its ACK to `node`, for the longest of the poll's exchanges (the
  // MS[1] ACK carries 8 bytes); an upper bound for the ACK of any other instruction too.
  static Duration poll_exchange_time(std::uint8_t node, std::uint32_t bitrate);

  // §5.24 polling that fills an idle bus. Each drive is polled (MS[0], MS[1]) at most every
  // configured poll period. Poll frames (and the other background requests: identification and
  // set-up) go to the transport one at a time, through the poll slot: the next only once the one
  // before has been on the wire (its own echo, or the drive's answer; without echoes, after the
  // wire time of the requests in flight). A command's requests are handed over at once and go
  // ahead of a node's unsent polls (enqueue()), so a command frame waits in the transmit queue
  // behind at most the one poll frame there, and every other
  // sender (drive notifications, other stacks) wins the wire by arbitration at the next frame
  // boundary. Polls thus take whatever the bus leaves idle, up to all of it. When N drives at
  // the configured rate need more than the bus carries, the waiting nodes take the slot in turn
  // (poll_queue, first come first served), and the configuration is told so at start().
  // A poll goes only while every poll awaiting its answer is among the kPollsInFlight - 1 handed
  // over last: the next polls are on their way while drives answer (the wire stays busy even when
  // the gateway reacts a frame late), yet our polls (the host's identifier wins arbitration over
  // most drives' answers, §2.5) never hold an answer back for long. Otherwise a drive whose
  // identifier ranks low would see every newer answer overtake its own until its request timed
  // out; and a command to a polled node waits for at most that node's one exchange (§2.1: one
  // outstanding request per node). A poll still unanswered at its answer_due (the wire time of
  // the requests ahead of it and a few exchanges more) holds nothing back: a silent drive does not
  // stop the others' polls until its timeout.
  // No poll is handed over while a command's request awaits its answer, for at most this long
  // after each try of it: its answer, lower in priority than most of the polls' frames on a full
  // bus, would wait for as long as they fill it; a drive that does not answer holds the polls back
  // no longer than this per try.
  static constexpr Duration kCommandAnswerWindow = std::chrono::milliseconds(10);
  static constexpr std::uint64_t kPollsInFlight = 3;
  static constexpr int kAnswerSlackExchanges = 4;
  struct PollSlot {
    std::size_t node = 0;
    can::Frame frame;
    TimePoint release_by{};  // taken as gone by then without an echo or answer
  };
  void estimate_poll_period();
  // Node `i`'s next request is a poll and the slot is taken: it waits its turn.
  void wait_for_poll_slot(std::size_t i);
  // The slot is free, no poll (background request) awaits its answer but the latest ones, and the
  // poll's answer would be through before a reserved start (reserved_at).
  [[nodiscard]] bool poll_may_go(TimePoint now) const;
  // A command's request that waits for a reserved start, as a poll would (its answer could still
  // be on the wire at reserved_at). Starts (BG) and stops are never held.
  [[nodiscard]] bool held_for_start(const Request& r, TimePoint now) const;
  // A frame handed over now could still be answered on the wire at reserved_at (before fire()).
  [[nodiscard]] bool start_reserved(TimePoint now) const;
  // How long after its hand-over a poll's answer may still be on the wire: the requests in flight
  // ahead of it, and kAnswerSlackExchanges exchanges (answer_due).
  [[nodiscard]] Duration poll_horizon() const { return queued_wire_time() + kAnswerSlackExchanges * exchange_time; }
  // A start frame goes out at reserved_at (prepare_fire): no poll whose answer could still be on the
  // wire then is handed over, until fire() or kReservationGrace after it, nor a command's request
  // (held_for_start).
  TimePoint reserved_at = kNever;
  static constexpr Duration kReservationGrace = std::chrono::milliseconds(10);
  // Hands waiting polls to the transport while poll_may_go().
  void grant_polls(TimePoint now);
  // The poll in the slot has been on the wire (or is taken as gone): the next waiting poll goes.
  void release_poll_slot(TimePoint now);
  // A poll of node `i` was answered (or refused).
  void poll_answered(std::size_t i, TimePoint now);
  // One of our frames was on the wire (CanStack::on_transmitted).
  void on_transmitted(const can::Frame& frame, TimePoint now);

  // How long a request just handed to the transport may wait for the wire: every other request
  // in flight on this bus, and its ACK, may go first. Counted into its deadline so a long
  // transmit queue is not taken for a silent drive.
  [[nodiscard]] Duration queued_wire_time() const;
  [[nodiscard]] TimePoint deadline_of(const Node& n, TimePoint now) const {
    return now + n.cfg.request_timeout + queued_wire_time();
  }

  Uim342StackConfig config;
  CanStackContext context;
  WallClock wall;
  Counters& counters;
  std::vector<Node> nodes;
  Duration exchange_time{};            // wire time of the longest request + ACK (poll_exchange_time)
  Duration poll_period{};              // config.poll_period, or the estimated bus-limited period when longer
  std::string poll_warning;            // why poll_period is longer (reported at start)
  std::optional<PollSlot> poll_slot;   // the poll frame handed to the transport, not yet seen on the wire
  std::deque<std::size_t> poll_queue;  // nodes whose next request is a poll waiting for the slot
  bool echoes_seen = false;            // the transport echoes our frames (on_transmitted)
  std::uint64_t polls_handed = 0;      // background requests handed to the transport so far
  Ledger commands{[this](gateway_reply_t r) { context.out->command_reply(std::move(r)); }};
  bool started = false;

  // ---- output helpers ----

  void publish(Node& n, TimePoint now);
  void event(const Node& n, std::int16_t kind, std::int8_t severity, std::int32_t code, std::string text);

  // ---- command bookkeeping ----

  // Ends command `id` (the ledger's one terminal reply) and clears what its nodes held for it.
  void finish(std::int64_t id, Lifecycle terminal, std::int32_t code = 0, std::string reason = {});
  void done(std::int64_t id, std::string reason = {}) { finish(id, Lifecycle::kDone, 0, std::move(reason)); }
  void fail(std::int64_t id, std::int32_t code, std::string reason) {
    finish(id, code == error_code(ReplyError::kStopped) ? Lifecycle::kStopped : Lifecycle::kFailed, code,
           std::move(reason));
  }

  // Every command with work on node `i` (queued requests or an active move) fails.
  void fail_commands_of(std::size_t i, std::int32_t code, const std::string& reason, std::int64_t except = 0);

  Request& enqueue(std::size_t i, Instruction instruction, std::int64_t command_id, bool front = false);

  void drop_requests(std::int64_t command_id);

  [[nodiscard]] bool has_request_of(std::size_t i, std::int64_t command_id) const;

  // ---- sending ----

  // Hands the instruction's frame to the transport; `sent` gets the frame when not null.
  bool transmit(std::uint8_t target, const Instruction& instruction, can::Frame* sent = nullptr);

  void pump(std::size_t i, TimePoint now);

  // A start frame (BG to `target`) of a move was handed to the transport: the `parts` (nodes) are
  // Started (the ledger replies STARTED with the last); the driver dates the STARTED reply by the
  // frame's echo when it can (CanStackContext::start_frame).
  void on_sent(std::int64_t command_id, std::uint8_t target, const std::vector<std::size_t>& parts, TimePoint now);

  // ---- start-up: identify, set up, poll ----

  void identify(std::size_t i, TimePoint now);

  void set_up(std::size_t i);

  // Set-up nodes are polled, except an armed one: it waits for its trigger with an empty queue so
  // the BG goes out without delay (and nothing changes on a drive that has not started).
  [[nodiscard]] bool polled(const Node& n) const;

  void poll_if_due(std::size_t i, TimePoint now);

  void go_offline(std::size_t i, const std::string& reason, TimePoint now);

  // ---- replies ----

  void completed(std::size_t i, const Request& r, const std::optional<uim342::Reply>& ack, TimePoint now);

  // §5.9, §5.7: MT[0] and QE[4] as read at set-up against the configured micro-steps. Equal: the
  // drive runs at them (after a restart, or since its last one). Different the first time: driver
  // off (MO=0, so the values go to EEPROM and not only to RAM), MT[0], QE[4], restart (SY[1]);
  // set-up runs again after the reboot and reads them back. Different after that restart: the
  // drive does not keep them, and counts per unit would be wrong: CONFIG_MISMATCH, never ready.
  void check_micro_steps(std::size_t i, std::uint16_t read_cpr);

  // The last set-up request was answered (or refused).
  void setup_finished(std::size_t i, TimePoint now);

  void apply_ack(std::size_t i, const Request& r, const uim342::Reply& ack, TimePoint now);

  void on_motion_status(std::size_t i, const uim342::MotionStatus& s, const Request& r, TimePoint now);

  // The UIM342 sends nothing when it powers up (no such notification in §2.4 or §5.3; §5.2 IC and
  // §5.9 MT[3] only say what it does at power-on), so a power cycle shows in what it answers
  // afterwards: the power-on marker (check_marker()) once its driver was on, and always
  // PowerUpWatch: its position counter starts at 0 (the manual keeps no position over
  // power loss; it names PP values as saved to flash, §5.1), at rest, with the driver off unless
  // IC auto-enable is set (§5.2). Not watched while it is identified or homed (the origin moves).
  [[nodiscard]] std::optional<std::string> powered_up(Node& n, const uim342::MotionKinematics& k, TimePoint now);

  // The power-on marker (manual §5.9 note): MT[3], the delay of the automatic enable after
  // power-on, written while the driver is on stays in RAM only and is lost at power-off, and it
  // acts at power-on only (read from EEPROM then), so a RAM value of ours changes nothing. Set-up
  // reads MT[3]; once the driver is on and the drive rests with nothing commanded (MT writes are
  // refused while the motor runs), the stack writes a different value to RAM (arm_marker());
  // a read that no longer finds it shows a power-up (marker_read()). Read at every set-up (after
  // the drive was offline), and while the counter reads 0 at rest (what a power-up leaves):
  // at once when that sample is new or the driver went off by nobody, else at most once a second.
  void arm_marker(std::size_t i);
  void check_marker(std::size_t i, const uim342::MotionKinematics& k, bool switched_off, TimePoint now);
  // MT[3] was read: true when it shows a power-up (then reported through on_power_cycle()).
  bool marker_read(std::size_t i, std::uint16_t value, TimePoint now);
  [[nodiscard]] static bool is_marker(const Request& r);  // a MT[3] request of the marker's
  [[nodiscard]] bool marker_queued(const Node& n) const;

  // A power cycle seen in its answers: what it was doing ended, its position is lost, and its
  // RAM settings are gone, so it is identified and set up again (as after a reboot).
  void on_power_cycle(std::size_t i, const std::string& why, TimePoint now);

  void arrived(std::size_t i, TimePoint);

  void stage_done(Command& c, TimePoint now);

  // ---- synchronized start (§5.11, §3.2) ----

  void start_move(Command& c, TimePoint now);

  // The drives of the command's group outside the command (none: the command is the group);
  // nullopt when its drives are not all in one group whose id each confirmed.
  [[nodiscard]] std::optional<std::vector<std::size_t>> group_outside(const Command& c) const;

  // A move of part of a group (at least two drives, and at least half of the group) starts with
  // one BG to the group id when every other drive of the group rests with nothing to do: each is
  // given PR=0 (§5.20: a relative move, counted from where the drive stands at BG) before the move
  // is ARMED, and is held (not polled, Node::held_for) until the start. Otherwise nothing is held
  // and the move starts with one BG per drive.
  void hold_bystanders(Command& c);
  [[nodiscard]] bool may_hold(std::size_t i) const;
  // The move's requests and its bystanders' PR=0 are all answered: every part Armed (the ledger
  // replies ARMED with the last), and stage_done().
  void armed_if_loaded(Command& c, TimePoint now);
  // A bystander's PR=0 was acknowledged.
  void hold_loaded(std::size_t i, std::int64_t command_id, TimePoint now);
  // Node `i` is no longer held (a command of its own, refused or unanswered PR=0, offline, power
  // cycle): its move starts drive by drive. `now` nullopt: no ARMED/start follows from it here.
  void release_hold(std::size_t i, std::optional<TimePoint> now);

  // ---- commands ----

  std::optional<std::size_t> node_of_axis(const std::string& axis) const;

  void execute(const gateway_command_t& cmd, TimePoint now);

  using Problem = std::optional<std::pair<std::string, std::int32_t>>;

  // Queues the command's requests; a reason when the command cannot be carried out.
  Problem load(Command& c);

  // AC/DC in the drive's IC[4] unit; nullopt when the command leaves the drive's value.
  Problem ramp(std::size_t i, double rate, double speed, bool acceleration, std::int64_t id);

  Problem load_move(Command& c, std::size_t i, const motionlcm::axis_command_t& a);

  // ---- homing (§4.3, §5.13, §5.26; see the header) ----

  [[nodiscard]] static std::string edge_name(const Node::Homing& h);

  // HOME: OG where the axis stands (method none / current-position), or a switch search.
  Problem load_home(Command& c, std::size_t i, const motionlcm::axis_command_t& a);

  // The requests of a homing step were all answered.
  void homing_step_loaded(std::size_t i, TimePoint now);

  // A status of a homing axis (MS[0] poll, edge or position notification).
  void homing_observe(std::size_t i, TimePoint now);

  // The search bound passed without the switch: stop, restore IL (finish()), fail.
  void homing_not_found(std::size_t i, TimePoint);

  Problem load_jog(Command& c, std::size_t i, const motionlcm::axis_command_t& a);

  // PARAM_READ / PARAM_WRITE in the family's terms: index = function code, subindex = sub-index.
  Problem load_param(Command& c);

  static std::optional<Instruction> param_instruction(const uim342::InstructionForms& forms,
                                                      const motionlcm::param_t& p, bool write);

  // The value of a parameter reply: its data bytes after the echoed sub-index, little-endian,
  // `width` bytes (all when 0), sign-extended when `is_signed`.
  static std::int64_t param_value(const uim342::Reply& ack, const motionlcm::param_t& p);

  void fire(std::int64_t trigger_id, TimePoint now);

  // ---- incoming frames ----

  std::optional<std::size_t> node_of_id(std::uint8_t id) const;

  bool on_frame(const can::Frame& frame, TimePoint now);

  void on_reply(std::size_t i, const uim342::Message& message, const uim342::Reply& reply, TimePoint now);

  // §2.3: the instruction was not executed.
  void refused(std::size_t i, const Request& r, const uim342::ErrorRecord& record, TimePoint now);

  void on_notification(std::size_t i, const uim342::Notification& notification, TimePoint now);

  // ---- time ----

  TimePoint process(TimePoint now);

  void timed_out(std::size_t i, TimePoint now);
};

}  // namespace motion::gateway
