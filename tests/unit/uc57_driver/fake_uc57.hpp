// A scripted fake UC57 node for the driver tests: an SDO server over a small in-memory object
// dictionary, NMT states with boot-up and heartbeat, PDOs honouring the mapping and transmission
// type the master configured (synchronous RPDOs buffered until SYNC), and a CiA 402 drive whose
// state follows motion::cia402's transition table. Motion is abstract: a set-point, a homing run
// or a jog takes `motion_syncs` SYNC periods.
//
// Not a simulator (services/sim owns that): only what the tests need, deterministic.
// Thread contract: single-threaded test code.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <vector>

#include "motion/can_frame/frame.hpp"
#include "motion/canopen/cob_id.hpp"
#include "motion/canopen/emcy.hpp"
#include "motion/canopen/nmt.hpp"
#include "motion/canopen/pdo.hpp"
#include "motion/canopen/sdo.hpp"
#include "motion/cia402/state_machine.hpp"
#include "motion/cia402/words.hpp"
#include "motion/core/clock.hpp"

namespace motion::uc57_driver::testing {

class FakeUc57 {
 public:
  struct Entry {
    std::int64_t value = 0;
    std::uint8_t size = 4;
    bool writable = true;
  };

  explicit FakeUc57(canopen::NodeId id) : id_(id) { reset_dictionary(); }

  // --- switches ---
  bool silent = false;                                   // answers nothing (powered off / unplugged)
  bool pdo_remap_writable = true;                        // CiA 301; false = the manual's RO 1400h:01 / 1600h:00
  bool refuse_enable = false;                            // ignores Switch on (for timeout tests)
  int motion_syncs = 3;                                  // SYNC periods a move / homing run takes
  std::map<std::uint32_t, std::uint32_t> forced_aborts;  // key(index, sub) -> abort code
  std::set<std::uint32_t> unanswered_once;               // key(index, sub): the next write is applied, its answer lost

  static constexpr std::uint32_t key(std::uint16_t index, std::uint8_t sub) {
    return (std::uint32_t{index} << 8) | sub;
  }

  // --- observations ---
  std::vector<std::uint16_t> controlwords;  // every controlword applied, in order
  std::optional<std::uint64_t> move_started_at_sync;
  std::uint64_t syncs = 0;
  cia402::State state() const { return state_; }
  canopen::NmtState nmt() const { return nmt_; }
  std::int64_t value(std::uint16_t index, std::uint8_t sub = 0) const { return od_.at(key(index, sub)).value; }
  void set_value(std::uint16_t index, std::uint8_t sub, std::int64_t v) { od_[key(index, sub)].value = v; }

  // --- inputs ---
  std::vector<can::Frame> on_frame(const can::Frame& frame, TimePoint now);
  // Heartbeats; returns frames due at `now`.
  std::vector<can::Frame> tick(TimePoint now);
  [[nodiscard]] TimePoint next_tick() const;
  // Power-on: boot-up message, dictionary back to defaults.
  std::vector<can::Frame> power_on(TimePoint now);
  // A drive alarm: 603Fh bit, Fault, EMCY.
  std::vector<can::Frame> inject_fault(std::uint16_t emcy_code, std::uint16_t fault_bits);

 private:
  void reset_dictionary();
  std::vector<can::Frame> on_sdo(const can::Frame& frame);
  void on_nmt(const can::Frame& frame, TimePoint now, std::vector<can::Frame>& out);
  void apply_rpdo(std::span<const std::uint8_t> payload);
  void apply_controlword(std::uint16_t controlword);
  void write_object(std::uint16_t index, std::uint8_t sub, std::int64_t value);
  void step_motion();
  void transmit_tpdos(std::vector<can::Frame>& out, bool sync_event);
  [[nodiscard]] std::uint16_t statusword() const;
  [[nodiscard]] canopen::PdoMapping mapping(std::uint16_t index) const;

  canopen::NodeId id_;
  std::map<std::uint32_t, Entry> od_;
  canopen::NmtState nmt_ = canopen::NmtState::kPreOperational;
  cia402::State state_ = cia402::State::kSwitchOnDisabled;
  std::uint16_t controlword_ = 0;
  std::optional<std::vector<std::uint8_t>> rpdo_buffer_;
  TimePoint next_heartbeat_ = kNever;
  // Operation-mode status.
  bool set_point_ack_ = false;
  bool target_reached_ = true;
  bool running_ = false;
  bool in_position_ = false;
  bool homed_ = false;
  bool alarm_ = false;
  int motion_left_ = 0;
  std::int64_t motion_target_ = 0;
  std::optional<std::vector<std::uint8_t>> last_tpdo1_, last_tpdo2_;
};

}  // namespace motion::uc57_driver::testing
