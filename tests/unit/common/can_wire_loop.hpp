// The loop of a bit-timed wire rig shared by the CAN stacks' wire tests (uim342_wire_rig.hpp,
// uc57_wire_rig.hpp) and bench_canopen: the simulated bus's passive core (simbus::Bus: frames
// serialized for their exact bit time, arbitration by identifier, own echo at the end of frame)
// between one gateway stack and simulated drives, on a simulated clock. Every frame that reaches
// the gateway's endpoint is recorded as it went over the wire (`Record{frame, end of frame, ours,
// bitrate}`), then handed to the stack: its own frames as echoes (on_transmitted), the others as
// received (on_frame). A rig derives from it, attaches the endpoints and makes the stack.
// Thread contract: single-threaded test code; needs no test framework (bench_canopen uses it).
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "motion/can_frame/frame.hpp"
#include "motion/core/clock.hpp"
#include "motion/sim/can_drive.hpp"
#include "motion/simbus/bus.hpp"

namespace motion::testing {

template <typename Stack, typename Record>
class CanWireLoop : public simbus::BusSink {
 public:
  void deliver(simbus::EndpointId to, const can::Frame& frame, bool own_echo) override {
    inbox_.push_back({to, frame, own_echo});
  }
  void notify(simbus::EndpointId, const can::BusEvent&) override {}

  // Runs the wire, the stack and the drives until `span` has passed; false when they do not
  // advance (100000 steps at one instant: stuck() says so).
  bool run_for(Duration span) {
    const auto end = now + span;
    for (int same_instant = 0; same_instant < 100'000; ++same_instant) {
      bus_.advance(now, *this);
      dispatch();
      TimePoint next = std::min(stack->process(now), bus_.next_deadline());
      for (auto& [id, d] : drives_) next = std::min(next, d->process(now));
      next = std::min(next, bus_.next_deadline());  // what process() just submitted
      if (next > end) {
        now = end;
        return true;
      }
      if (next > now) same_instant = 0;
      now = std::max(now, next);
    }
    stuck();
    return false;
  }
  // Runs in steps of 1 ms until `done` (true) or `limit` has passed or the rig is stuck (false).
  bool run_until(const std::function<bool()>& done, Duration limit) {
    for (Duration spent{}; spent < limit; spent += std::chrono::milliseconds(1)) {
      if (done()) return true;
      if (!run_for(std::chrono::milliseconds(1))) return false;
    }
    return done();
  }

  std::unique_ptr<Stack> stack;
  std::vector<Record> wire;                              // every frame, in end-of-frame order
  std::vector<std::pair<TimePoint, can::Frame>> handed;  // the stack's frames, when handed over
  TimePoint now = TimePoint{} + std::chrono::seconds(10);

 protected:
  CanWireLoop(std::uint32_t bitrate, std::size_t queue)
      : bus_(simbus::BusConfig{bitrate, true, std::chrono::seconds(1), queue, 0}), bitrate_(bitrate) {
    gateway_ = bus_.attach("gateway", /*own_echo=*/true);
  }
  CanWireLoop(const CanWireLoop&) = delete;
  CanWireLoop& operator=(const CanWireLoop&) = delete;
  ~CanWireLoop() override = default;
  // The rig did not advance: report it (a test failure, a message).
  virtual void stuck() = 0;
  // What the stack's context sends: recorded as handed over, then submitted to the wire.
  bool send(const can::Frame& frame) {
    handed.emplace_back(now, frame);
    return !bus_.submit(gateway_, frame, now);
  }
  // A simulated drive on its own endpoint (not yet powered up).
  simbus::EndpointId attach_drive(const std::string& name,
                                  const std::function<std::unique_ptr<sim::CanDriveSim>(simbus::EndpointId)>& make) {
    const auto endpoint = bus_.attach(name);
    drives_[endpoint] = make(endpoint);
    return endpoint;
  }
  void power_up_drives() {
    for (auto& [id, d] : drives_) d->power_up(now);
  }

  simbus::Bus bus_;
  simbus::EndpointId gateway_ = 0;
  std::map<simbus::EndpointId, std::unique_ptr<sim::CanDriveSim>> drives_;

 private:
  struct Delivery {
    simbus::EndpointId to;
    can::Frame frame;
    bool own_echo;
  };
  // Every frame reaches the gateway's endpoint once: its own as an echo, the drives' as
  // received; a frame for an endpoint that is neither (another master's) is dropped.
  void dispatch() {
    auto inbox = std::move(inbox_);
    inbox_.clear();
    for (const auto& d : inbox) {
      if (d.to == gateway_) {
        wire.push_back(Record{d.frame, now, d.own_echo, bitrate_});
        if (d.own_echo) {
          stack->on_transmitted(d.frame, now);
        } else {
          stack->on_frame(d.frame, now);
        }
      } else if (const auto it = drives_.find(d.to); it != drives_.end()) {
        it->second->on_frame(d.frame, now);
      }
    }
  }

  std::uint32_t bitrate_;
  std::vector<Delivery> inbox_;
};

}  // namespace motion::testing
