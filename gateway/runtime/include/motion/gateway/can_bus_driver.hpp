// A CAN bus in the gateway: one transport, several protocol stacks (UIM342 on 29-bit frames,
// CANopen on 11-bit frames) sharing it.
//
// Each stack is a passive core (frames and `now` in, frames and its next deadline out). This
// driver owns the poll-loop side: it reads the transport when its fd is readable, hands every
// frame to the stacks, keeps one timer at the earliest deadline, and splits a gateway command
// among the stacks whose axes it names, combining their replies into the one reply per command
// the coordinator expects: one CommandLedger part per stack (command_ledger.hpp), so ARMED when
// all are armed, STARTED with the earliest trigger time and the spread between the stacks' start
// frames, DONE when all are done, FAILED on the first failure, and never a second terminal reply.
// A reply is the part of the stack the driver is calling when it comes (every stack call goes
// through this driver). After the combined STARTED each stack's later replies pass on as they come. Own echo is turned on: a STARTED reply waits (at most kEchoWait) for the echo of the
// command's start frames and carries their time on the wire as trigger_utime; echoes go to the
// stacks' on_transmitted(), never to on_frame(). The stacks' deadlines run on a PreciseTimer (timerfd, absolute time), so a
// SYNC period or a scheduled start keeps to the kernel's timer slack, not the loop's.
// On a SocketCAN bus (use_cyclic()) the stacks may also hand periodic frames to the kernel's
// broadcast manager (CAN_BCM; CanStackContext::start_cyclic): the kernel sends them, their period
// owes nothing to the loop's wake-ups. The kernel loops each one back to the bus's CAN_RAW socket
// (as it does every frame of the host's other sockets); a received frame equal to a job's frame,
// while the job runs or stamped before its stop, is that job's: it goes to the stacks'
// on_cyclic_sent(), never to on_frame() (a SYNC producer counts its SYNCs by them). A command
// whose start frame is a job's first frame (the start SYNC) gets that frame's time as
// trigger_utime, as with own echo. The jobs end with the driver (closing the BCM socket deletes
// them, also when the process dies); after the interface was recreated the BCM socket is opened
// again on it and its jobs restarted.
// Thread contract: the loop's thread only.
#pragma once

#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "motion/can/socketcan_cyclic.hpp"
#include "motion/can/transport.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/core/precise_timer.hpp"
#include "motion/gateway/bus_driver.hpp"
#include "motion/gateway/command_ledger.hpp"
#include "motion/gateway/held_output.hpp"
#include "motion/gateway/tx_echo_tracker.hpp"

namespace motion::gateway {

class CanStack {
 public:
  virtual ~CanStack() = default;
  [[nodiscard]] virtual std::string family() const = 0;
  // Axes this stack drives (names from the configuration).
  [[nodiscard]] virtual std::vector<std::string> axes() const = 0;
  virtual void start(TimePoint now) = 0;
  // A received frame; false when it is not this stack's (the next stack gets it).
  virtual bool on_frame(const can::Frame& frame, TimePoint now) = 0;
  // A frame this bus's driver sent has been on the wire (its own echo, at its end of frame); every
  // stack sees every echo. A stack that paces its frames by the wire (UIM342 polls) uses it to
  // hand the next one. Transports without own echo never call it. Default: nothing.
  virtual void on_transmitted(const can::Frame& /*frame*/, TimePoint /*now*/) {}
  // A frame of a cyclic job (CanStackContext::start_cyclic) was on the wire: every stack sees
  // each one. Default: nothing.
  virtual void on_cyclic_sent(const can::Frame& /*frame*/, TimePoint /*now*/) {}
  // Timeouts, retries, polling; returns the next deadline or kNever.
  virtual TimePoint process(TimePoint now) = 0;
  // A command naming only this stack's axes; replies go through the stack's GatewayOutput.
  virtual void execute(const motionlcm::gateway_command_t& command, TimePoint now) = 0;
  virtual void fire(std::int64_t trigger_id, TimePoint now) = 0;
  // A fire is scheduled at `at`: keep the bus quiet around it where the stack can (e.g. no
  // periodic SYNC whose answers would still be on the wire). Default: nothing.
  virtual void prepare_fire(TimePoint /*at*/, TimePoint /*now*/) {}
  // How long before `at` prepare_fire() must come for it to keep the bus quiet (LINE_TIMING: the
  // bus's start wait is the largest of its stacks'). Default 0.
  [[nodiscard]] virtual Duration start_wait() const { return Duration::zero(); }
  [[nodiscard]] virtual bool ready() const = 0;
  // Adds this stack's counters (timeouts, retries, drives online/total) to the bus's.
  virtual void add_statistics(motionlcm::bus_stats_t& stats) const = 0;
  // The command ledger's counters (its parts by lifecycle state, what it refused): LEDGER_STATS.
  // Default: none.
  [[nodiscard]] virtual LedgerCounters ledger_counters() const { return {}; }
};

// What a stack is built with: how to send, where to report.
struct CanStackContext {
  std::function<bool(const can::Frame&)> send;  // false when the transport refused it
  GatewayOutput* out = nullptr;
  // Optional: the frame just sent (by its identifier) starts the move `command_id` (a group BG,
  // the SYNC of synchronous RPDOs). The driver then dates the command's STARTED reply by the
  // frame's echo, i.e. when it was on the wire (TxEchoTracker), not when it was handed over.
  std::function<void(std::int64_t command_id, const can::Frame& frame)> start_frame;
  // Optional (SocketCAN buses with kernel_sync on): periodic frames the kernel sends (CAN_BCM).
  // start_cyclic sends `frame` now, then every `period` until stop_cyclic, replacing the job of
  // the same identifier (new phase); false when refused (then no job of that identifier runs
  // once stop_cyclic was called). Every frame of a job seen on the wire reaches
  // CanStack::on_cyclic_sent. Empty on other buses.
  std::function<bool(const can::Frame& frame, Duration period)> start_cyclic;
  std::function<void(const can::Frame& frame)> stop_cyclic;
  // The running job's interval from its next timer run on (nothing sent now); false: refused.
  std::function<bool(const can::Frame& frame, Duration interval)> retime_cyclic;
};

class CanBusDriver final : public BusDriver {
 public:
  CanBusDriver(EventLoop& loop, std::string bus, std::unique_ptr<can::Transport> transport, GatewayOutput& out);
  ~CanBusDriver() override;

  // The kernel's cyclic sender on this bus's interface (SocketCAN): the contexts given out after
  // this call offer start_cyclic/stop_cyclic.
  void use_cyclic(std::unique_ptr<can::SocketCanCyclic> cyclic);
  // The context a stack of this bus is constructed with (its replies are combined here).
  CanStackContext context();
  void add_stack(std::unique_ptr<CanStack> stack);
  // The stacks' deadlines (SYNC periods, start frames) wake the loop `spin` early and are waited
  // for busy (PreciseTimer::set_spin; the bus key timer_spin_us).
  void set_timer_spin(Duration spin) { timer_.set_spin(spin); }

  void start() override;
  void execute(const motionlcm::gateway_command_t& command) override;
  void fire(std::int64_t trigger_id) override;
  // The stacks fire in the order of the first of their commands in `command_order` (the others
  // after them). What they send meanwhile is kept, in order, and handed to the transport back to
  // back once every stack has fired, so that no stack's work after its start frames (its replies,
  // its bookkeeping) comes between them and the next stack's; what the stacks publish meanwhile
  // (replies, statuses) goes out after that. Not on a bus whose stacks use the kernel's cyclic
  // sender: a job started there sends its first frame at once, ahead of any kept frame.
  void fire_ordered(std::int64_t trigger_id, const std::vector<std::int64_t>& command_order) override;
  void prepare_fire(TimePoint at) override;
  [[nodiscard]] Duration start_wait() const override;
  // The stacks' process() (their polls, SYNCs, timeouts) is not called over the hold; their
  // received frames are.
  void hold_traffic(TimePoint from, TimePoint until) override;
  [[nodiscard]] std::vector<motionlcm::bus_stats_t> statistics() const override;
  [[nodiscard]] bool ready() const override;
  // The stacks' ledgers summed (one part per node/axis), with the releases and refusals of the
  // driver's own combining ledger (its parts, one per stack, are not counted again).
  [[nodiscard]] LedgerCounters ledger_counters() const override;

  // Frames sent and received, for the RAW_<bus> mirror (optional).
  void on_frame_traffic(std::function<void(const can::Frame&, bool transmitted)> tap) { tap_ = std::move(tap); }

 private:
  class Combiner;
  // Per command beside the parts: the stacks' replies so far, by status (the combined reply of a
  // status is built from them when the last part gets there).
  struct Pending {
    std::map<std::int8_t, std::vector<motionlcm::gateway_reply_t>> by_status;
  };
  // Calls `f` on stack `s`, attributing the replies it sends meanwhile to its part.
  template <typename F>
  void call(CanStack* s, F&& f) {
    CanStack* const outer = calling_;
    calling_ = s;
    f(*s);
    calling_ = outer;
  }
  [[nodiscard]] std::size_t part_of(const CanStack* s) const;
  void on_readable();
  void reschedule();
  void watch_uimessage_crc();  // uimessage: buses: detected CRC coverage -> INFO CONFIG_MISMATCH
  void on_stack_reply(motionlcm::gateway_reply_t reply);
  // Sends a combined STARTED now, or holds it until its start frames' echoes are in.
  void emit_started(motionlcm::gateway_reply_t reply);
  void release_started(std::int64_t command_id, std::int64_t echo_utime);
  struct Held {
    motionlcm::gateway_reply_t reply;
    EventLoop::TimerId fallback = 0;
  };
  // A kernel job (by its frame's identifier) and what tells its frames among those received.
  struct CyclicJob {
    can::Frame frame;
    bool running = false;
    std::int64_t started_us = 0;               // wall time just before its (re)start: its first frame is stamped after
    std::int64_t stopped_us = 0;               // wall time just after its stop: frames stamped before are its own
    bool first_pending = false;                // its first frame since the (re)start not seen yet
    std::vector<std::int64_t> start_commands;  // commands that frame starts (their STARTED waits for it)
  };
  bool start_cyclic(const can::Frame& frame, Duration period);
  void stop_cyclic(const can::Frame& frame);
  bool retime_cyclic(const can::Frame& frame, Duration interval);
  CyclicJob* cyclic_job(const can::Frame& frame);
  // A received frame of one of the jobs: handed to the stacks (true), else false.
  bool take_cyclic(const can::Frame& frame, TimePoint now);
  void reopen_cyclic_if_recreated();
  // Hands `frame` to the transport (and the tap): false when it refused it.
  bool hand_over(const can::Frame& frame);
  // While the stacks fire (fire_ordered) their frames are kept here, in order, for flush_kept().
  void flush_kept();

  EventLoop& loop_;
  std::string bus_;
  std::unique_ptr<can::Transport> transport_;
  HeldOutput out_;  // held while the stacks fire: start frames first, publications after
  std::unique_ptr<Combiner> combiner_;
  std::vector<std::unique_ptr<CanStack>> stacks_;
  std::map<std::string, CanStack*> stack_of_axis_;
  CommandLedger<Pending> pending_;
  CanStack* calling_ = nullptr;                                  // the stack being called (its replies are its part's)
  std::map<std::int64_t, std::vector<CanStack*>> armed_stacks_;  // ARM_MOVE command -> its stacks, until fired
  // The stacks' earliest deadline (SYNC periods, polls, timeouts): an absolute-time timer.
  PreciseTimer timer_;
  std::function<void(const can::Frame&, bool)> tap_;
  bool bus_off_ = false;
  bool own_echo_ = false;  // the transport took set_own_echo(true)
  TxEchoTracker echoes_;
  std::map<std::int64_t, std::int64_t> echoed_starts_;  // command -> echo time, before its STARTED
  std::map<std::int64_t, Held> held_;                   // STARTED replies waiting for their echo
  std::unique_ptr<can::SocketCanCyclic> cyclic_;        // SocketCAN: the BCM socket (nullptr: none)
  std::vector<CyclicJob> cyclic_jobs_;
  std::set<std::int64_t> cyclic_starts_;  // commands whose STARTED waits for a job's first frame
  std::uint64_t seen_reopens_ = 0;        // the SocketCAN transport's reopens handled
  bool keeping_ = false;                  // the stacks are firing: their frames are kept
  std::vector<can::Frame> kept_;
  TimePoint hold_from_{};  // hold_traffic(): [hold_from_, hold_until_), empty when not held
  TimePoint hold_until_{};
};

}  // namespace motion::gateway
