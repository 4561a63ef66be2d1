// The gateway process's core: LCM <-> one BusDriver.
//  - subscribes to GW_COMMAND_<bus>, GW_COMMAND2_<bus> (gateway_command2_t: motion values as
//    integers of the drive models' grids, checked against the models this gateway published,
//    grid_command.hpp), GW_SCOMMAND_<bus> (either type signed by the coordinator) and
//    SYNC_TRIGGER2 (and the deprecated SYNC_TRIGGER); validates that every axis of a command belongs to this bus (FAILED with a
//    reason otherwise, never silence);
//  - signed commands pass the coordinator's key (set_coordinator_key) when there is one; with
//    security.mode enforce, plain commands and signed ones that do not verify are refused with a
//    SECURITY event and no reply (their command ids cannot be trusted);
//  - the same for triggers and ACTIVE_MOVES: signed copies (signed_message_t on SSYNC_TRIGGER,
//    SSYNC_TRIGGER2, SACTIVE_MOVES) pass the coordinator's key (set_coordinator_key); with
//    enforce, plain ones and signed ones that do not verify do nothing but a SECURITY event.
//    SECURITY events are rate-limited: 5 a second, then a count of the suppressed ones;
//  - schedules triggers on the steady clock: a SYNC_TRIGGER2 fires the driver at this bus's
//    send_utime (the drives act on the start frames at act_utime), its start frames in the order
//    it gives; a SYNC_TRIGGER (from a coordinator that does not send SYNC_TRIGGER2) at its
//    fire_utime; one trigger id fires once whichever arrives first (SYNC_TRIGGER2 reschedules);
//  - checks every command's positions, velocities and ramps against the axis limits of the
//    configuration, whoever sent it (FAILED code 3 and a PROTOCOL_ERROR event otherwise);
//  - watches jogging axes' statuses and stops one (its own STOP, negative command id, and a LIMIT
//    event) before it crosses its limit;
//  - converts DriveStatus (counts) to axis_state_t (user units, with invert and scale);
//  - publishes AXIS_STATE, EVENT, GW_REPLY and the heartbeat's bus statistics; with a gateway key
//    (set_gateway_key, config security.gateway_key) also AXIS_STATE, GW_REPLY, DRIVE_MODEL and
//    ORPHANED_MOVES signed (signed_message_t on SAXIS_STATE, SGW_REPLY, SDRIVE_MODEL,
//    SORPHANED_MOVES); with enforce GW_REPLY and ORPHANED_MOVES go out signed only (the
//    coordinator acts on nothing else), AXIS_STATE and DRIVE_MODEL plain too, for observers; its
//    EVENTs plain and signed as GW_EVENT on SGW_EVENT; its heartbeats (the HealthPublisher it is
//    given) plain and signed on SHEALTH;
//  - publishes each axis's drive model (DRIVE_MODEL, drive_model_t, made by the ModelBuilder the
//    process installs) when the axis first comes online and whenever what the driver read from the
//    drive (DriveFacts) changes it, and every model it has on a DRIVE_MODEL_REQUEST for its bus;
//    each with the axis's arming time (ARM_TIMING, arm_timing_t, made by the ArmingBuilder) and
//    what a start frame may wait behind on the bus (LINE_TIMING, line_timing_t: the driver's
//    start_wait(), the longest exchange a serial line may have under way);
//  - publishes, for every SYNC_TRIGGER2 it acts on, when it heard it (TRIGGER_HEARD,
//    trigger_heard_t), once the start is scheduled: the coordinator's trigger lead adapts to these;
//  - publishes with every heartbeat the counters of its command ledger (LEDGER_STATS,
//    ledger_stats_t: the driver's parts by lifecycle state, now and in total, and the commands sent
//    again that it answered from its CommandMemory);
//  - releases a move armed for a trigger that no trigger starts within the arm expiry
//    (arm_watch.hpp; config coordinator.arm_expiry_ms): its own DISARM to the driver, a TIMEOUT
//    event per axis, the move's one FAILED reply saying "never triggered within N ms", and a
//    trigger heard later for it fires nothing;
//  - keeps each axis's position record across its own restarts (set_position_record,
//    position_record.hpp): a drive that lost power while no gateway ran is reported as having lost
//    its position, exactly as one that loses it while the gateway runs.
// Thread contract: loop thread only.
#pragma once

#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include <motionlcm/active_moves_t.hpp>
#include <motionlcm/arm_timing_t.hpp>
#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/drive_model_request_t.hpp>
#include <motionlcm/drive_model_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/gateway_command2_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/ledger_stats_t.hpp>
#include <motionlcm/line_timing_t.hpp>
#include <motionlcm/sync_trigger2_t.hpp>
#include <motionlcm/sync_trigger_t.hpp>
#include <motionlcm/trigger_heard_t.hpp>

#include "motion/config/config.hpp"
#include "motion/core/durable_file.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/core/precise_timer.hpp"
#include "motion/gateway/arm_watch.hpp"
#include "motion/gateway/axis_limits.hpp"
#include "motion/gateway/bus_driver.hpp"
#include "motion/gateway/command_memory.hpp"
#include "motion/gateway/position_record.hpp"
#include "motion/lcm/health.hpp"
#include "motion/lcm/malformed_limiter.hpp"
#include "motion/lcm/node.hpp"
#include "motion/lcm/start_quiet.hpp"
#include "motion/security/gateway_commands.hpp"
#include "motion/security/signed_messages.hpp"

namespace motion::gateway {

// User units <-> drive counts for one axis of the configuration.
struct AxisScale {
  double counts_per_unit = 1;
  bool invert = false;
  [[nodiscard]] double to_units(double counts) const { return (invert ? -counts : counts) / counts_per_unit; }
  [[nodiscard]] double to_counts(double units) const { return (invert ? -units : units) * counts_per_unit; }
};

// The drive model of an axis given what its driver read from the drive, or why there is none
// (the gateway app installs motion::drive_model::build).
using ModelBuilder = std::function<std::variant<motionlcm::drive_model_t, std::string>(const config::Axis& axis,
                                                                                       const DriveFacts& facts)>;

// How long arming a move of the axis takes on the bus, or why that is not known (the gateway app
// installs motion::drive_model::arming).
using ArmingBuilder = std::function<std::variant<motionlcm::arm_timing_t, std::string>(const config::Axis& axis)>;

class Gateway final : public GatewayOutput {
 public:
  // A start's traffic hold (schedule_fire, BusDriver::hold_traffic): from this long before the
  // start's quiet interval, and at least this long before the bus's fire; never longer than
  // kLongestTrafficHold.
  static constexpr auto kTrafficHoldBefore = std::chrono::milliseconds(1);
  static constexpr auto kLongestTrafficHold = std::chrono::milliseconds(15);
  Gateway(EventLoop& loop, lcm::Node& node, lcm::HealthPublisher& health, const config::Config& config,
          std::string bus);
  ~Gateway() override;

  // Installs the driver and starts it (the driver reports through *this).
  void attach(std::unique_ptr<BusDriver> driver);
  // Drives of this bus that no stack serves (family not implemented): health says so and their
  // axes' commands fail with that reason.
  void set_unsupported(const std::vector<const config::Drive*>& drives);
  // Why there is no driver yet (e.g. the bus cannot be opened; retried): shown in the health.
  void set_waiting(std::string why);
  // Verifies signed commands, triggers and ACTIVE_MOVES with `coordinator` from now on (none:
  // signed ones are unwrapped unverified), with config security.window_ms, for the channel prefix
  // of the gateway's node (the one the coordinator signs for).
  void set_coordinator_key(const std::optional<security::PublicKey>& coordinator);
  // security.coordinator_public_key of `config` (none when not set), or what is wrong with it.
  [[nodiscard]] static security::Loaded<std::optional<security::PublicKey>> load_coordinator_key(
      const config::Config& config);
  // Signs what the gateway publishes with `key` from now on (none: plain only), its heartbeats
  // included, for the channel prefix of the gateway's node.
  void set_gateway_key(const std::optional<security::KeyPair>& key);
  // security.gateway_key of `config` with "{bus}" replaced by `bus` (none when not set), or what is
  // wrong with it.
  [[nodiscard]] static security::Loaded<std::optional<security::KeyPair>> load_gateway_key(const config::Config& config,
                                                                                           const std::string& bus);

  // Keeps the axes' record in the file `path` from now on (call before attach()): loads what the
  // previous gateway process of the bus recorded (a file that cannot be read or parsed is logged
  // and taken as no record), compares each axis's first online status with its record (evidence
  // of a power cycle: position_lost(); a recorded lost position stays lost; a recorded homed
  // state stays homed), and writes the record whenever an axis starts or ends a move, is homed,
  // loses or regains its position.
  void set_position_record(const std::string& path);

  // Without a builder no DRIVE_MODEL is published (and the coordinator refuses moves of the bus).
  void set_model_builder(ModelBuilder builder) { model_builder_ = std::move(builder); }
  // Without one no ARM_TIMING is published (the coordinator then allows arm_timeout_ms alone).
  // It also decides the default arm expiry (the longest arming line time of any bus is added).
  void set_arming_builder(ArmingBuilder builder);
  // How long a move armed for a trigger stays armed without one: coordinator.arm_expiry_ms, or by
  // default arm_timeout_ms + trigger_lead_ms + gateway_timeout_ms + the longest arming line time
  // of any bus of `config` (every drive of that bus armed or readied; 0 without `arming`).
  [[nodiscard]] static Duration arm_expiry(const config::Config& config, const ArmingBuilder& arming);
  [[nodiscard]] Duration arm_expiry() const { return arm_watch_.expiry(); }

  // GatewayOutput
  void drive_facts(const std::string& axis, const DriveFacts& facts) override;
  void axis_status(const std::string& axis, const DriveStatus& status) override;
  void axis_event(const std::string& axis, const DriveEvent& event) override;
  void command_reply(motionlcm::gateway_reply_t reply) override;
  // Latches "position lost" for `axis`: its states say so (homed false, fault_code
  // axis_state_t::POSITION_LOST while not faulted), a REBOOT event names it, and its ARM_MOVE and
  // JOG commands are refused (code 22) until a HOME or SET_POSITION of it is DONE.
  void position_lost(const std::string& axis, const std::string& why) override;

  [[nodiscard]] const std::string& bus() const { return bus_; }
  [[nodiscard]] std::string process_name() const { return "gateway:" + bus_; }
  // The LEDGER_STATS message published with `health` (the heartbeat it goes out with).
  [[nodiscard]] motionlcm::ledger_stats_t ledger_stats(const motionlcm::health_t& health) const;

 private:
  void on_command(const motionlcm::gateway_command_t& command);
  // GW_COMMAND2_<bus> (gateway_command2.cpp): its grid integers checked against the models this
  // gateway published and turned into the stacks' command (grid_command.hpp), or refused (FAILED).
  void on_command2(const motionlcm::gateway_command2_t& command);
  // A command on GW_COMMAND_<bus> or GW_COMMAND2_<bus>: refused under enforce (unsigned), else
  // handed to `handler`.
  template <typename Command>
  void on_plain(const Command& command, void (Gateway::*handler)(const Command&));
  // A command sent again (CommandMemory): its latest reply repeated, if any; true then.
  template <typename Command>
  bool answered_again(const Command& command);
  // The checks every command passes (bus, axes, position lost, limits) and the driver.
  void execute_checked(const motionlcm::gateway_command_t& command);
  // Two models alike but for utime.
  [[nodiscard]] static bool same_model(motionlcm::drive_model_t a, motionlcm::drive_model_t b);
  void on_signed_command(const motionlcm::signed_gateway_command_t& envelope);
  // A command refused by the security policy: a SECURITY event, no reply.
  void refuse(const std::string& reason);
  // Publishes `message` signed on S<channel> when there is a gateway key, and plain on <channel>
  // unless there is one, the mode is enforce and not `plain_under_enforce`.
  template <typename Msg>
  void publish_own(std::string_view channel, const Msg& message, bool plain_under_enforce);
  // EVENT plain, and with a gateway key signed as GW_EVENT on SGW_EVENT.
  void publish_event(const motionlcm::event_t& event);
  // Triggers and ACTIVE_MOVES: signed ones verified (set_coordinator_key), plain ones refused
  // under enforce.
  void subscribe_coordinator_messages();
  template <typename Msg>
  void on_signed_message(std::optional<security::MessageVerifier>& verifier,
                         const motionlcm::signed_message_t& envelope, void (Gateway::*handler)(const Msg&));
  void on_trigger(const motionlcm::sync_trigger_t& trigger);
  void on_trigger2(const motionlcm::sync_trigger2_t& trigger);
  // Fires the driver for `trigger_id` at `send_utime` (wall clock; when the first start frame is to
  // begin on the wire) less the bus's egress_latency_us, or now when that has passed. The driver
  // holds its own traffic from kTrafficHoldBefore before `quiet_from_utime` (the start's quiet
  // interval, lcm/start_quiet.hpp; 0: this bus's fire) until the fire: at least kTrafficHoldBefore,
  // at most kLongestTrafficHold.
  void schedule_fire(std::int64_t trigger_id, std::int64_t send_utime, std::vector<std::int64_t> order,
                     std::int64_t quiet_from_utime = 0);
  // The coordinator's desired state: a request of this bus triggered before this process started
  // was the previous gateway process's; its axes are stopped and a GATEWAY_RESTARTED event says
  // what they were doing.
  void on_active_moves(const motionlcm::active_moves_t& moves);
  void on_health(const motionlcm::health_t& health);
  void on_model_request(const motionlcm::drive_model_request_t& request);
  // Builds the model of `axis` and publishes it when it differs from the last one (or `always`).
  void publish_model(const std::string& axis, bool always);
  void publish_line_timing();
  void update_health();
  // Armed moves past their expiry (gateway_arm_expiry.cpp): released by a DISARM of the gateway's
  // own; and the one timer at the next expiry.
  void release_expired();
  void rearm_expiry_timer();
  // Jog watch bookkeeping for a command about to go to the driver, and on its replies.
  void track_jogs(const motionlcm::gateway_command_t& command);
  void jog_reply(const motionlcm::gateway_reply_t& reply);
  // Stops `axis` (its jog reaches its limit): a STOP of the gateway's own and a LIMIT event.
  void check_jog(const std::string& axis);
  void forget_jog(const std::string& axis);
  // The position record (gateway_record.cpp): the first online status of `axis` against its record,
  // and the record of a status as published (`homed` as reported).
  void check_record(const std::string& axis, const DriveStatus& status);
  void keep_record(const std::string& axis, const DriveStatus& status, bool homed);
  // The first online status of `axis` in this process says it moves, and this process has sent
  // nothing for it yet: a previous gateway process's move (its request ended when the coordinator lost
  // that gateway, or its ACTIVE_MOVES row is gone). Stopped (a STOP of the gateway's own) with a
  // GATEWAY_RESTARTED event, before anything else is done with it.
  void stop_if_found_moving(const std::string& axis, const DriveStatus& status);

  EventLoop& loop_;
  lcm::Node& node_;
  lcm::HealthPublisher& health_;
  const config::Config& config_;
  std::string bus_;
  std::map<std::string, const config::Axis*> axes_;  // axes of this bus
  std::unique_ptr<BusDriver> driver_;
  std::map<std::string, std::string> unsupported_;            // drive name -> family
  std::int64_t started_utime_ = 0;                            // wall clock when this process's gateway started
  std::set<std::pair<std::string, std::int64_t>> inherited_;  // (client, request) already stopped
  // A command of the gateway's own (negative id: a jog stopped at its limit, an axis found moving,
  // a move nobody triggered) for its driver: `kind` on `axes`.
  // The PROTOCOL_ERROR event of a command refused before it reached the driver (limits, grid):
  // "command N (request R) refused: <reason>", on `axis` (empty: the bus).
  void refusal_event(const std::string& axis, std::int64_t command_id, std::int64_t request_id, std::int32_t code,
                     const std::string& reason);
  motionlcm::gateway_command_t own_command(std::int8_t kind, const std::vector<std::string>& axes,
                                           std::int64_t trigger_id = 0);
  std::int64_t next_own_command_ = -1;  // ids of the gateway's own commands (negative)
  std::string waiting_;
  double poll_hz_ = 0;                              // status rate of this bus's drives
  std::map<std::string, CountLimits> limits_;       // axis -> its limits in counts
  std::map<std::string, DriveStatus> last_status_;  // axis -> its last reported status
  ModelBuilder model_builder_;
  ArmingBuilder arming_builder_;
  std::map<std::string, DriveFacts> facts_;  // axis -> what its driver read from the drive
  std::map<std::string, motionlcm::drive_model_t>
      models_;                            // axis -> its model as last published (utime: in force since)
  std::map<std::string, JogWatch> jogs_;  // axes jogging under watch
  // axis -> the latest motion command not answered yet (JOG: its watch; ARM_MOVE/HOME: none):
  // it replaces the watch once the driver has it (a move: once STARTED), a FAILED reply leaves the
  // watch as it was. STOP/ESTOP/DISABLE end the watch at once.
  struct PendingMotion {
    std::int64_t command_id = 0;
    std::optional<JogWatch> jog;
  };
  std::map<std::string, PendingMotion> pending_motion_;
  std::map<std::string, std::string> position_lost_;   // axis -> why its position is not the machine's
  std::optional<PositionRecords> records_;             // none: no record kept (set_position_record)
  std::optional<BackgroundFileWriter> record_writer_;  // writes records_ off the loop thread
  std::set<std::string> record_checked_;               // axes whose first online status was compared with the record
  std::set<std::string> seen_online_;                  // axes that reported online to this process
  std::set<std::string> commanded_;                    // axes named by a command this process handed to its driver
  std::set<std::string> restored_homed_;  // axes homed by a previous gateway process (record), not since lost
  std::string record_error_;              // the last failure to write the record (logged once)
  CommandMemory commands_seen_;           // a command sent again is answered, not run again
  std::int64_t repeats_answered_ = 0;     // commands sent again, answered with their latest reply
  std::int64_t repeats_unanswered_ = 0;   // commands sent again before any reply to them
  std::map<std::int64_t, std::vector<std::string>> referencing_;  // HOME/SET_POSITION command id -> its axes
  std::map<std::int64_t, std::string>
      stopped_at_limit_;                    // jog command id -> why the watch stopped it (before its reply)
  motionlcm::active_moves_t last_moves_{};  // this bus's rows of the latest ACTIVE_MOVES
  std::string coordinator_;                 // host:pid of the coordinator heard last
  std::int64_t coordinator_seen_utime_ = 0;
  EventLoop::TimerId health_timer_ = 0;
  ArmWatch arm_watch_{Duration::zero()};                                 // the expiry is set in the constructor
  EventLoop::TimerId arm_timer_ = 0;                                     // at arm_watch_.next_deadline() (0: none)
  std::map<std::int64_t, std::unique_ptr<PreciseTimer>> pending_fires_;  // trigger id -> its timer, until it fires
  lcm::StartQuiet start_quiet_{loop_, node_};                            // around each start it schedules
  std::uint64_t refused_fires_ = 0;        // triggers not scheduled: too many starts waiting already
  std::deque<std::int64_t> scheduled_v2_;  // recent trigger ids scheduled by SYNC_TRIGGER2
  std::deque<std::int64_t> fired_;         // recent trigger ids fired
  bool enforce_ = false;                   // security.mode enforce
  std::optional<security::GatewayCommandVerifier> verifier_;
  std::optional<security::MessageVerifier> trigger_verifier_;   // SSYNC_TRIGGER
  std::optional<security::MessageVerifier> trigger2_verifier_;  // SSYNC_TRIGGER2
  std::optional<security::MessageVerifier> moves_verifier_;     // SACTIVE_MOVES
  lcm::MalformedLimiter security_events_;                       // refusals reported (5 a second)
  std::optional<security::MessageSigner> signer_;               // the gateway key (security.gateway_key)
};

}  // namespace motion::gateway
