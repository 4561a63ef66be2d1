// The gateway-side protocol stack for ADAMPOWER UC57 drives (CANopen CiA 301 + CiA 402) on a CAN
// bus it may share with UIM342 drives (29-bit frames, ignored here).
//
// A passive core in the style of lely-core / CANopenNode: frames and `now` in, frames out through
// CanStackContext::send, replies/status/events through the GatewayOutput; process(now) returns
// the next deadline. It owns no socket, timer or thread. The one clock it may read is the wall
// clock for the STARTED reply's trigger_utime (Options::wall_clock_us, injectable).
//
// Thread contract: single-threaded; every method runs on the gateway's poll-loop thread.
//
// What it implements (manual = UC57 user manual):
//  - Start-up per node (CiA 301 §7.2.8, manual §4.1.2): probe by SDO read of 1000h (low word 0192h =
//    CiA 402) and 1018h:01 (vendor 322h), NMT pre-operational, setup keys -> 2006h/2005h written and
//    read back (manual §5.1), 1017h producer heartbeat (no node guarding: 100Ch/100Dh are absent),
//    RPDO1 remapped to controlword + target position, synchronous (CiA 301 remap procedure) or, when
//    the drive refuses it (the manual prints 1400h:01/1600h:00 RO), the manual's default RPDO1 made
//    synchronous (a drive aborting type 1 gets 255, the manual's FFh, once: no retry loop);
//    TPDO1/TPDO2 default mappings with transmission type 1 (tpdo_mode sync) or 255 (event); NMT
//    start; the RPDO1 acceptance test (applies at the SYNC or on reception? uc57_stack_rpdo.cpp,
//    moves nothing); a SYNC producer at the bus poll rate, slowed so that SYNC, synchronous TPDOs
//    and heartbeats keep to kPollBusShare of the bus (sync_period()). See process_data.hpp.
//    tpdo_mode staggered (uc57_stack_stagger.cpp): TPDO1 and TPDO2 of each such node get
//    transmission type G (every G-th SYNC, CiA 301 §7.5.2.35) and a slot of their own in the
//    cycle of G SYNCs, so each SYNC is answered by one TPDO; the SYNC then runs G times faster,
//    paced by the wire (the next one only once the last one and its answer are through), and
//    polls fill up to kStaggeredBusShare of the bus while a command waits behind at most one
//    TPDO.
//    A node that does not answer, or boots again, is re-probed with exponential back-off.
//  - SDO (CiA 301 §7.2.4): one transfer per node at a time (canopen::SdoClient), the bus/drive
//    request timeout and retries; aborts reported with the abort code's CiA text and the object.
//  - CiA 402 device control (manual §4.2.1/§4.2.2, cia402::PowerController): ENABLE 0x06 -> 0x07 ->
//    0x0F (transitions 2, 3, 4), DISABLE (shutdown, transition 8), FAULT_RESET (0x00 -> 0x80,
//    transition 15), ESTOP (quick stop 0x02, transition 11), STOP (halt, bit 8). A STOP/ESTOP
//    naming an offline node still stops every reachable one, then FAILS naming the offline one.
//  - Once a node is operational its controlword only travels in RPDO1, queued one image per SYNC
//    cycle (an SDO write of 6040h would be overwritten at the next SYNC, CiA 301 §7.2.2).
//  - Synchronized start (CiA 301 §7.2.2/§7.2.5 synchronous RPDOs, manual §4.2.4 PP set-point
//    handshake): ARM_MOVE writes 6060h = 1, 6081h/6083h/6084h by SDO (and 607Ah by SDO in the
//    fallback layout), leaves bit 4 at 0 -> ARMED; fire() sends every armed node's RPDO1 with bit 4
//    = 1 then ONE SYNC -> STARTED ("sync", skew 0); bit 12 acknowledged -> bit 4 cleared; DONE when
//    bit 10 (target reached) or bit 15 on every axis. A node whose RPDO1 applies on reception (or
//    is asynchronous) is never preloaded; its RPDO1 starts it: STARTED "rpdo" with the wire time
//    between the command's first and last start frame as skew; its drive model offers
//    START_SINGLE instead of START_CANOPEN_SYNC (DriveFacts::one_frame_start).
//  - JOG: profile velocity (6060h = 3, 60FFh; manual §4.2.5, §7 MC_JOG); HOME: homing mode
//    (6060h = 6, 6098h/6099h/609Ah/607Ch, manual §4.2.6; result per conflict C-08);
//    SET_OUTPUTS: 2030h:0D/0E output functions 5 (high) / 6 (low); SET_POSITION: 2012h (zero only);
//    PARAM_READ/PARAM_WRITE: param_t as CANopen index/sub-index; DISARM.
//  - EMCY (CiA 301 §7.2.7) -> events and FAILED for the node's running command; heartbeat loss ->
//    offline, event, FAILED; TPDOs -> DriveStatus (synchronous TPDO1 + TPDO2 of one SYNC count as
//    one sample: statusword and position are taken, and published, together).
// Every command ends in exactly one terminal reply (DONE or FAILED).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "motion/canopen/master.hpp"
#include "motion/cia402/power_controller.hpp"
#include "motion/config/config.hpp"
#include "motion/gateway/can_bus_driver.hpp"
#include "motion/gateway/command_ledger.hpp"
#include "motion/uc57_driver/node_settings.hpp"
#include "motion/uc57_driver/process_data.hpp"

namespace motion::uc57_driver {

class Uc57Stack final : public gateway::CanStack {
 public:
  struct Options {
    Duration retry_initial = std::chrono::milliseconds(500);          // first re-probe of a silent node
    Duration retry_max = std::chrono::seconds(10);                    // back-off ceiling
    Duration state_switch_timeout = std::chrono::milliseconds(1000);  // per CiA 402 transition
    Duration set_point_timeout = std::chrono::milliseconds(500);      // bit 12 handshake waits
    Duration stop_timeout = std::chrono::seconds(5);                  // halt / quick stop to standstill
    std::uint16_t default_heartbeat_ms = 100;  // 1017h when the drive's setup has no heartbeat_ms
    unsigned heartbeat_loss_factor = 3;        // consumer time = factor x producer time
    // trigger_utime of STARTED: wall-clock microseconds of `now` (default: system_wall_clock).
    gateway::WallClock wall_clock_us;
  };

  struct Counters {
    std::int64_t sdo_timeouts = 0;     // transfers that failed after every retry
    std::int64_t sdo_retries = 0;      // attempts repeated after a timeout
    std::int64_t sdo_aborts = 0;       // transfers the drive aborted
    std::int64_t emcy = 0;             // EMCY frames received (error resets included)
    std::int64_t protocol_errors = 0;  // malformed PDOs, refused sends
  };

  // Drives of family uc57 on `bus` (config.drives), with their axes (config.axes).
  Uc57Stack(const config::Config& config, const config::Bus& bus, gateway::CanStackContext context);
  Uc57Stack(const config::Config& config, const config::Bus& bus, gateway::CanStackContext context, Options options);
  ~Uc57Stack() override;
  Uc57Stack(const Uc57Stack&) = delete;
  Uc57Stack& operator=(const Uc57Stack&) = delete;

  [[nodiscard]] std::string family() const override { return "uc57"; }
  [[nodiscard]] std::vector<std::string> axes() const override;
  void start(TimePoint now) override;
  bool on_frame(const can::Frame& frame, TimePoint now) override;
  // A SYNC of the kernel's cyclic job (kernel_sync) was on the wire: counted (canopen::SyncProducer).
  void on_cyclic_sent(const can::Frame& frame, TimePoint now) override;
  TimePoint process(TimePoint now) override;
  void execute(const motionlcm::gateway_command_t& command, TimePoint now) override;
  void fire(std::int64_t trigger_id, TimePoint now) override;
  // No periodic SYNC within kQuietBeforeStart of a scheduled start at `at` (nor up to it): the
  // nodes' synchronous TPDOs answering it would still be on the wire and delay the start frames.
  // The SYNC that would fall there is moved, the period restarting from `at` (the start SYNC
  // restarts it again); those before it go out. The start may be heard more than a period ahead
  // (a line's start wait), so every SYNC is judged as it comes due, until fire() or
  // kStartGrace after `at`. Nor does any other frame of the master (SDO requests, NMT) go out
  // within kQuietBeforeStart before the start: the answer of an SDO request could still be on
  // the wire at the start. They wait, in their order, and go out right behind the start frames
  // (or when the start has not come kStartGrace after `at`). RPDOs are not held: a stop's image
  // goes out with the next SYNC, and the start's SYNC applies it.
  void prepare_fire(TimePoint at, TimePoint now) override;
  static constexpr Duration kStartGrace = std::chrono::milliseconds(10);
  static constexpr Duration kQuietBeforeStart = std::chrono::milliseconds(3);
  [[nodiscard]] Duration start_wait() const override { return kQuietBeforeStart; }
  [[nodiscard]] bool ready() const override;
  void add_statistics(motionlcm::bus_stats_t& stats) const override;
  [[nodiscard]] gateway::LedgerCounters ledger_counters() const override { return jobs_.counters(); }

  void on_transmitted(const can::Frame& frame, TimePoint now) override;

  [[nodiscard]] const Counters& counters() const { return counters_; }
  // The SYNC period in force: 1 / poll_hz, or longer when the nodes' synchronous TPDOs at that
  // rate would take more than kPollBusShare of the bus (fit_sync_period; said once at start()).
  // Type 1: longer still while nodes are being configured on such a bus (kConfiguringPollBusShare).
  [[nodiscard]] Duration sync_period() const { return sync_period_; }
  // SYNCs put on the wire so far (by the loop, or seen from the kernel's cyclic job), and
  // whether that job sends the periodic ones now (a socketcan: bus with kernel_sync on: the
  // context's start_cyclic; handed back to the loop while a start image waits in a drive).
  [[nodiscard]] std::uint64_t syncs_sent() const { return master_.sync()->sent(); }
  [[nodiscard]] bool kernel_sync_running() const { return master_.sync()->cyclic(); }
  static constexpr double kPollBusShare = 0.75;
  // Type 1, while nodes are being configured: what SYNC + answers + heartbeats may take, so that
  // the set-up's SDO exchanges and the heartbeats (700h + node, the lowest priority) keep half
  // the bus (ease_polls_while_configuring).
  static constexpr double kConfiguringPollBusShare = 0.5;
  // Staggered TPDOs (tpdo_mode staggered): what SYNC + its one answer + heartbeats may take.
  static constexpr double kStaggeredBusShare = 0.95;
  // G, the SYNCs of one staggered poll cycle (2 per staggered node, 1 above 120 nodes); 0 when
  // no node on the bus has tpdo_mode staggered.
  [[nodiscard]] unsigned stagger_cycle() const { return stagger_g_; }
  // The slots (SYNC index mod G) the TPDO1 and TPDO2 of `drive` answer in, as planned at its
  // start and then as observed; nullopt for a slot not known yet or a node not staggered.
  [[nodiscard]] std::array<std::optional<unsigned>, 2> tpdo_slots(std::string_view drive) const;
  // True when `drive` was set up staggered but refused transmission type G (type 1 instead).
  [[nodiscard]] bool stagger_refused(std::string_view drive) const;
  // What set-up found about RPDO1 of `drive` ("honoured (detected)", "on_reception (detected)",
  // "refused", "on_reception (configured)", ...); empty before the node is operational.
  [[nodiscard]] std::string rpdo_sync_finding(std::string_view drive) const;
  // The RPDO1 layout a configured node ended up with (nullopt: unknown drive or not configured).
  [[nodiscard]] std::optional<RpdoLayout> rpdo_layout(std::string_view drive) const;

 private:
  struct Node;
  // A command's parts (one per node) live in the gateway's CommandLedger; beside them a stop keeps
  // its unreachable (offline) nodes: the others are still stopped, then the reply fails.
  struct JobData {
    std::int32_t unreached_code = 0;
    std::string unreached;
    bool started = false;  // an ARM_MOVE's SYNC went out
  };
  using Job = gateway::CommandLedger<JobData>::Entry;
  enum class TaskKind : std::uint8_t;
  using Continue = std::function<void(std::optional<std::string> failure)>;
  struct ConfigOp;

  // --- start-up ---
  // Configures node n now, or once fewer than configuration_window_ nodes are being configured.
  void begin_probe(std::size_t n, TimePoint now);
  void probe_now(std::size_t n);
  [[nodiscard]] std::size_t configuring() const;  // nodes in Phase::kConfiguring
  void set_configuration_window();
  std::vector<ConfigOp> configuration_ops(std::size_t n);
  void run_config(std::size_t n, unsigned session, const std::shared_ptr<std::vector<ConfigOp>>& ops, std::size_t step);
  void configuration_failed(std::size_t n, const std::string& reason, bool retry);
  void enter_starting(std::size_t n);
  void enter_operational(std::size_t n);
  void go_offline(std::size_t n, std::int16_t event_kind, const std::string& reason, TimePoint now);
  void on_node_event(const canopen::NodeEvent& event);
  void on_emcy(const canopen::EmcyEvent& event);

  // --- RPDO1 acceptance test (uc57_stack_rpdo.cpp) ---
  ConfigOp rpdo_acceptance_op(std::size_t n);
  void rpdo_test_attempt(std::size_t n, unsigned session, unsigned attempt, const Continue& next);
  void rpdo_found(std::size_t n, bool at_sync, const std::string& finding);
  // Runs `run` once the SYNC producer has sent more than `count` SYNCs (checked after each SYNC).
  void after_sync(std::uint64_t count, std::function<void()> run);
  void run_sync_waiters();
  struct StartFacts {
    std::string mechanism;  // "sync": one SYNC; "rpdo": each node's RPDO1, back to back
    double skew_us = 0;
    can::Frame frame;  // the command's first start frame
  };
  [[nodiscard]] StartFacts start_facts(const Job& job) const;
  // The bus budget of the synchronous TPDOs (fit_sync_period) and its warning.
  void fit_sync_period();
  // The SYNC period that keeps SYNC + its answers + heartbeats within `budget` of the bus (the
  // asked period when that is longer); fit_sync_period() sets what it reads.
  [[nodiscard]] Duration period_within(double budget) const;
  // Type 1 on a bus whose polls take more than kConfiguringPollBusShare: the SYNC slows to that
  // share while any node is being configured, and is back at sync_period_ once none is.
  void ease_polls_while_configuring(TimePoint now);
  Duration poll_cycle_{};       // SYNC + the answers to one SYNC (staggered: one G-th of theirs)
  double heartbeat_share_ = 0;  // of the wire
  bool polls_eased_ = false;
  void warn_bus(const std::string& text);
  std::string poll_warning_;

  // --- staggered TPDOs (uc57_stack_stagger.cpp) ---
  [[nodiscard]] bool staggered(std::size_t n) const;  // set up staggered and not refused
  void plan_stagger();
  // 1800h:02 / 1801h:02 at set-up; the NMT start (and TPDO2's type) at the node's slots.
  ConfigOp tpdo_type_op(std::size_t n);
  ConfigOp nmt_start_op(std::size_t n);
  // NMT start right after the SYNC of TPDO1's slot, TPDO2's type written right after its own;
  // `current` false drops the rest (a new session), `done` gets a failure text.
  void start_in_slots(std::size_t n, const std::function<bool()>& current, const Continue& done);
  // Runs `run` right after the next periodic SYNC whose index is `slot` mod G.
  void at_slot(unsigned slot, std::function<void()> run);
  [[nodiscard]] bool sync_due(TimePoint now);
  [[nodiscard]] TimePoint next_sync_check() const;
  void on_sync_handed();
  void on_tpdo_seen(std::size_t n, unsigned pdo);
  // The index of the SYNC a TPDO received now answers (echoed SYNCs where the transport echoes).
  [[nodiscard]] std::uint64_t sync_index() const { return echoes_ ? syncs_on_wire_ : syncs_handed_; }
  void run_slot_waiters();
  // No periodic SYNC for node n's sake until released or `until` (its set-up exchanges).
  void hold_sync(std::size_t n, TimePoint until) { sync_holds_[n] = until; }
  void release_sync(std::size_t n) { sync_holds_.erase(n); }
  unsigned stagger_g_ = 0;
  bool stagger_separate_ = true;               // TPDO1 and TPDO2 of a node in slots of their own (G = 2S)
  std::uint64_t syncs_handed_ = 0;             // SYNCs handed to the transport (= the producer's sent())
  std::deque<std::uint64_t> syncs_in_flight_;  // their indexes, awaiting their echo
  Duration asked_period_{};                    // 1 / poll_hz
  // What an SDO exchange may wait on the wire behind the TPDOs answering one SYNC, on top of the
  // configured timeout (fit_sync_period()).
  Duration sdo_allowance_{};
  bool echoes_ = false;              // the transport echoes our frames (on_transmitted)
  std::uint64_t syncs_on_wire_ = 0;  // echoes of our SYNCs
  bool sync_awaiting_echo_ = false;
  TimePoint sync_handed_at_{};
  TimePoint next_sync_at_ = kNever;  // staggered pacing: not before (one sync_period_ apart)
  TimePoint start_at_ = kNever;      // a scheduled start (prepare_fire), until fire()
  unsigned answers_left_ = 0;        // TPDOs still expected for the last SYNC
  TimePoint answers_due_ = kNever;
  std::map<std::size_t, TimePoint> sync_holds_;
  // Staggered pacing by the wire: polls may use poll_share_ of it, less what every other frame
  // seen on it took (commands, answers, other masters; not the heartbeats, whose share is kept
  // apart): a credit of wire time that each frame seen spends; a SYNC needs it positive.
  void spend_wire(const can::Frame& frame, TimePoint now);
  [[nodiscard]] TimePoint credit_ready_at() const;  // when the credit is back to 0
  double poll_share_ = kPollBusShare;
  Duration poll_credit_{};
  TimePoint credit_at_{};
  std::vector<std::pair<unsigned, std::function<void()>>> slot_waiters_;

  // --- SDO with retries and reasons ---
  using SdoDone = std::function<void(std::error_code, std::span<const std::uint8_t>)>;
  void sdo_read(std::size_t n, canopen::ObjectAddress object, SdoDone done, unsigned attempt = 0);
  void sdo_write(std::size_t n, canopen::ObjectAddress object, const std::vector<std::uint8_t>& data, SdoDone done,
                 unsigned attempt = 0);
  void count_sdo_result(std::error_code error);
  // How long the node's heartbeat may be missing: heartbeat_loss_factor periods and sdo_allowance_.
  [[nodiscard]] Duration heartbeat_consumer_time(const Node& node) const;
  // The node's SDO timeout on this bus: the configured one and sdo_allowance_.
  [[nodiscard]] Duration sdo_timeout(const Node& node) const;
  [[nodiscard]] std::string sdo_failure(std::size_t n, bool write, canopen::ObjectAddress object,
                                        std::error_code error) const;
  // Runs writes in order; `done` gets the first failure's text.
  void sdo_write_all(std::size_t n, std::vector<std::pair<canopen::ObjectAddress, std::vector<std::uint8_t>>> writes,
                     Continue done);

  // --- process data ---
  void on_pdo(std::size_t n, const can::Frame& frame, TimePoint now);
  void on_statusword(std::size_t n, TimePoint now);
  // Takes a TPDO1's statusword, inputs and mode and runs on_statusword; true when what it reports changed.
  // `sample`: the SYNC index it answers (image_applied of a staggered node).
  bool take_tpdo1(std::size_t n, const Tpdo1& tpdo, TimePoint now, std::uint64_t sample);
  void queue_image(std::size_t n, const RpdoImage& image);
  [[nodiscard]] RpdoImage latest_image(std::size_t n) const;
  void send_image(std::size_t n, const RpdoImage& image);
  void run_sync_cycle(TimePoint now);
  // A periodic SYNC due within kQuietBeforeStart before start_at_ is moved after it.
  void keep_sync_off_start(TimePoint now);
  // Every frame of the master (SYNC, SDO, NMT) goes through here: counted, or held for a start.
  void send_master_frame(const can::Frame& frame);
  [[nodiscard]] bool holding_for_start() const;  // within the quiet time of start_at_
  void release_held_frames();
  std::vector<can::Frame> held_for_start_;
  // Preloading (scheduled starts): once every node of an ARM_MOVE waiting for a trigger is armed,
  // each node's start image (bit 4 = 1) goes out at once in its synchronous RPDO1 (transmission
  // type 1: applied at the next SYNC, UC57 manual §5 "RPDO communication parameters", CiA 301
  // §7.2.2.2), so that at fire() only the SYNC goes on the wire. Any other SYNC before the fire
  // must not apply it: masked_sync() sends the armed image (bit 4 = 0) of every preloaded node
  // before it and the start image again after it; a node whose move is no longer armed gets its
  // armed image back and leaves the preload.
  void preload(const Job& job);
  void send_preload(std::size_t n);
  void masked_sync(TimePoint now, const std::function<void()>& sync);
  [[nodiscard]] bool image_applied(std::size_t n);  // the last queued image is in the drive for sure
  void publish_status(std::size_t n);

  // --- commands ---
  void part_done(std::int64_t command_id, std::size_t n);
  void part_failed(std::int64_t command_id, std::size_t n, std::int32_t code, const std::string& reason);
  void part_armed(std::int64_t command_id, std::size_t n, TimePoint now);
  void end_task(std::size_t n, std::int32_t code, const std::string& reason);  // fails the node's running task
  void start_task(std::size_t n, TaskKind kind, std::int64_t command_id, TimePoint deadline);
  void start_power(std::size_t n, Job& job, cia402::State target, TimePoint now);
  void apply_power_action(std::size_t n, const cia402::PowerController::Action& action);
  void start_arm(std::size_t n, Job& job, const motionlcm::axis_command_t& axis, TimePoint now);
  void start_jog(std::size_t n, Job& job, const motionlcm::axis_command_t& axis, TimePoint now);
  void start_home(std::size_t n, Job& job, const motionlcm::axis_command_t& axis, TimePoint now);
  void start_halt(std::size_t n, Job& job, bool idle, TimePoint now);  // idle: at_rest() before the STOP
  [[nodiscard]] bool at_rest(std::size_t n);                           // no task, nothing queued, the motor not running
  // A reason (reply code, text) why `command` can never run for `axis` on node n, checked before
  // any part of the command starts.
  [[nodiscard]] std::optional<std::pair<std::int32_t, std::string>> refuse(std::size_t n,
                                                                           const motionlcm::gateway_command_t& command,
                                                                           const motionlcm::axis_command_t& axis) const;
  void start_quick_stop(std::size_t n, Job& job, TimePoint now);
  void start_outputs(std::size_t n, Job& job, const motionlcm::axis_command_t& axis);
  void start_set_position(std::size_t n, Job& job, const motionlcm::axis_command_t& axis);
  void start_param(std::size_t n, Job& job);
  // 2006h:00 and 200Eh:00, what the drive model is made of (uc57_stack_params.cpp).
  [[nodiscard]] static bool is_model_object(canopen::ObjectAddress object);
  // Why a PARAM_WRITE of `param` is refused on node n: one of those objects while a move is armed
  // or moving (it was planned with the present value).
  [[nodiscard]] std::optional<std::pair<std::int32_t, std::string>> refuse_model_write(
      std::size_t n, const motionlcm::param_t& param) const;
  // Reads 2006h and 200Eh again, takes them and reports the drive facts (after a PARAM_WRITE).
  void reread_model_objects(std::size_t n, Continue done);
  // Reports what was read (resolution, start speed, start mechanism) to the gateway (DriveFacts).
  void report_facts(std::size_t n);
  void disarm(const Job& disarm_job);
  // The target in node `n` set to where it stands, bit 4 = 0, sent at once (a released move).
  void neutralize(std::size_t n);
  // STOP/ESTOP of a node that does not answer: its halt / quick stop sent in RPDO1 anyway; false
  // when its process data was never set up.
  bool send_blind_stop(std::size_t n, bool quick);
  void fire_jobs(const std::vector<std::int64_t>& command_ids, TimePoint now);
  // A move "at once" (trigger 0) whose last node is armed. Its start SYNC is one more SYNC than
  // the periodic ones, and every synchronous node answers it (type 1: TPDO1 + TPDO2 each, which
  // outrank SDO traffic; heartbeats, 700h + node, come last). So a start SYNC keeps the SYNC's bus
  // budget: it goes no sooner after the previous SYNC than start_sync_gap(), and the moves armed
  // meanwhile share it. Where the SYNC period was lengthened to fit that budget, the gap is the
  // period: a start then comes when the periodic SYNC would have (and restarts the period).
  // Sent at once instead, on 32 type-1 nodes at 125 kbit/s, ten moves armed within one burst of
  // answers sent six SYNCs within 15 ms: the bus was saturated for about 350 ms, an SDO answer
  // waited 240 ms (timed out, retried) and heartbeats were missed.
  void fire_at_once(std::int64_t command_id, TimePoint now);
  // Fires the waiting moves once the gap has passed, or now when the periodic SYNC is due (the
  // start SYNC takes its place: the periodic one, handed over earlier than the echo the gap is
  // counted from, would otherwise come first every time).
  void fire_deferred_at_once(TimePoint now, bool periodic_due);
  // The shortest gap between SYNCs that keeps SYNC + answers + heartbeats within the bus budget in
  // force (kPollBusShare; kConfiguringPollBusShare while nodes are configured on a type-1 bus).
  [[nodiscard]] Duration start_sync_gap() const;
  std::vector<std::int64_t> at_once_;  // armed moves "at once" waiting for their SYNC
  TimePoint at_once_due_ = kNever;
  Duration budget_gap_{};            // start_sync_gap() outside set-up (fit_sync_period)
  TimePoint last_sync_at_ = kNever;  // the last SYNC: handed over, then its echo (or seen, kernel_sync)
  void check_task_timeouts(TimePoint now);
  // Switches the mode by SDO (6060h) and keeps the RPDO image's mode byte consistent.
  void set_mode(std::size_t n, std::int8_t mode, Continue done);

  [[nodiscard]] std::optional<cia402::State> drive_state(std::size_t n) const;
  // How often a node reports at most: one SYNC, or G of them (and one for the TPDO2 behind TPDO1).
  // Type 1: the longest period the SYNC may run at, the one of a set-up (ease_polls_while_configuring),
  // so that a deadline counted in cycles holds while another node is being configured.
  [[nodiscard]] Duration cycle() const {
    if (stagger_g_ > 0) return sync_period_ * (stagger_g_ + 1);
    return std::max(sync_period_, period_within(kConfiguringPollBusShare));
  }
  void event(std::size_t n, std::int16_t kind, std::int8_t severity, std::int32_t code, const std::string& text);
  [[nodiscard]] std::string offline_text(std::size_t n) const;  // "<label> is offline: <why>"
  [[nodiscard]] std::string tpdo_text(std::size_t n) const;     // "every SYNC", "event-driven", ...

  gateway::CanStackContext context_;
  Options options_;
  std::string bus_;
  Duration sync_period_;
  std::vector<std::unique_ptr<Node>> nodes_;
  std::map<canopen::NodeId, std::size_t> node_index_;
  std::set<std::uint32_t> relocated_emcy_ids_;  // 1014h values other than 80h + node-ID
  canopen::Master master_;
  gateway::CommandLedger<JobData> jobs_{[this](motionlcm::gateway_reply_t reply) {
    if (context_.out != nullptr) context_.out->command_reply(std::move(reply));
  }};
  Counters counters_;
  bool started_ = false;
  std::uint32_t bitrate_ = 125000;
  std::size_t configuration_window_ = 1;  // nodes configured at once (set_configuration_window)
  Duration wire_sent_{};                  // wire time of every frame handed to the transport (start skew)
  Duration last_sync_end_{};              // wire_sent_ after the last SYNC
  std::vector<std::pair<std::uint64_t, std::function<void()>>> sync_waiters_;
  TimePoint now_{};  // the `now` of the entry point running (callbacks run inside one)
};

}  // namespace motion::uc57_driver
