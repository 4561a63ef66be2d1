// Table data (§8.54) and the synchronized start it enables: the only documented way to start
// DIFFERENT targets on several ADAM drives with ONE frame (a broadcast, §5, of 0x00DD, §8.54).
//
// Layout: the table lives in the programming area (register 300 = kProgrammingAreaFirst and up).
// 0x00AC holds its start as an offset from register 300 (inferred from the §8.54 example: offset 200
// for data at register 500); entry k (INT32, low word first) occupies registers
// 300 + start + 2k and +1. 0x00AA = number of entries, 0x00AB = pointer of the next entry.
// Writing 0x00DD (TableExecute) runs the entry at the pointer (absolute target or relative
// distance), then moves the pointer by ± step.
//
// Synchronized start: preload every node with unicast frames (profile, table entry, size,
// pointer, start), then send ONE broadcast 0x00DD = TableExecute{absolute, add, 0}
// (00 06 00 DD 00 00 18 21); nobody replies, so poll each node's status afterwards.
// Whether the real drive needs a Save (0x00DC = 1) before table data can be executed is not
// stated (§8.54, §8.69); this preload does not save (flash wear), the driver must verify on hardware.
//
// Thread contract: pure functions, thread-safe.
#pragma once

#include <chrono>
#include <cstdint>
#include <span>
#include <vector>

#include "motion/adam/commands.hpp"
#include "motion/adam/registers.hpp"
#include "motion/adam/result.hpp"
#include "motion/adam/rtu.hpp"

namespace motion::adam {

inline constexpr std::uint16_t kRegistersPerTableEntry = 2;
inline constexpr std::uint16_t kMaxTableEntries = 2048;  // 0x00AA range
inline constexpr std::uint16_t kMaxTablePointer = 4095;  // 0x00AB range

// Register of table entry `index` for table start offset `start_offset` (0x00AC value).
[[nodiscard]] constexpr std::uint32_t table_entry_address(std::uint16_t start_offset, std::uint16_t index) noexcept {
  return std::uint32_t{kProgrammingAreaFirst} + start_offset + std::uint32_t{kRegistersPerTableEntry} * index;
}

// FC 0x10 frames that store `entries` from entry 0 at `start_offset`, at most
// `max_registers_per_frame` registers (even, ≤ 95) per frame. Errors: empty_table,
// too_many_registers (frame limit or table past register 0xFFFF / 2048 entries).
[[nodiscard]] Result<std::vector<rtu::Request>> table_data_writes(
    std::uint8_t unit, std::uint16_t start_offset, std::span<const std::int32_t> entries,
    std::uint16_t max_registers_per_frame = kMaxDriveWriteRegisters - 1);

// Table entry 0 = `target` loaded and selected: its data, then 0x00AA = 1, 0x00AB = 0 and 0x00AC =
// `start_offset` (§8.54). Also what readies a drive that must not move on a broadcast start: its
// entry 0 at its own position.
[[nodiscard]] Result<std::vector<rtu::Request>> single_entry_writes(std::uint8_t unit, std::uint16_t start_offset,
                                                                    std::int32_t target);

// The drive's reply latency, assumed (the manual gives none).
inline constexpr std::chrono::milliseconds kAssumedReplyLatency{1};
// Line time of one addressed transaction as the master runs it: the request, kAssumedReplyLatency,
// the reply (a read: 5 bytes + 2 per register; a write: 8), t3.5 after each frame, and a Save's
// flash erase (kSaveEraseTime).
[[nodiscard]] std::chrono::nanoseconds transaction_time(const rtu::SerialFormat& format, const rtu::Request& request);

// Motion profile preloaded per drive before a synchronized start (§8.40–§8.44, §8.64; assumed, not
// stated: all moves use the working speed). Start/stop speeds rpm, ramp times ms, speed in 0.01 rpm.
struct MotionProfile {
  std::uint16_t start_speed_rpm = 50;    // 0x0096, 0…300
  std::uint16_t stop_speed_rpm = 50;     // 0x0097, 0…1000
  std::uint16_t acceleration_ms = 120;   // 0x0098
  std::uint16_t deceleration_ms = 120;   // 0x0099
  std::int32_t speed_centi_rpm = 30000;  // 0x00D8, 0…999999 (positive: direction comes from the target)
  friend bool operator==(const MotionProfile&, const MotionProfile&) = default;
};
// Two FC 0x10 frames: 0x0096…0x0099 (4 registers) and 0x00D8 (2 registers, low word first).
// 0x009A is not written: 0x009A (§8.44) and 0x00D8 (§8.64) are taken as one setpoint (an assumption).
[[nodiscard]] Result<std::vector<rtu::Request>> profile_writes(std::uint8_t unit, const MotionProfile& profile);

// Everything one node needs before the broadcast: the profile, the target as table entry 0 at
// `start_offset`, table size 1, pointer 0, start offset — in that order, all unicast.
struct SyncMovePreload {
  MotionProfile profile;
  std::int32_t target_pulses = 0;    // absolute target (TableEntryKind::kAbsolute)
  std::uint16_t start_offset = 200;  // table at register 500, clear of a program at 300…499
};
[[nodiscard]] Result<std::vector<rtu::Request>> sync_move_preload(std::uint8_t unit, const SyncMovePreload& preload);

// The broadcast trigger: unit 0, 0x00DD = TableExecute{absolute, add, 0} unless given.
// Error: value_out_of_range for a pointer step above 4095.
[[nodiscard]] Result<rtu::Request> table_execute_broadcast(const TableExecute& execute = {});

}  // namespace motion::adam
