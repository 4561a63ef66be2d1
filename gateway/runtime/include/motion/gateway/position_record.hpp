// What a gateway remembers of its axes across its own restarts (README "Safety and faults"): per
// axis, the last position it knew in counts (at rest: where it stood; moving: where the move was
// seen starting, with its target), whether it was homed, and whether its position was lost (and
// why). A gateway that starts after its drive lost power cannot tell from the drive alone (the
// counter simply reads its power-on value); with the record it can: a drive that answers outside
// what the record allows, or shows the family's power-on marker, lost its position while no
// gateway watched.
//
// The record of one bus is one small text file, written whole and durably (core/durable_file.hpp:
// temporary file, fsync, rename; a reader, a crash or a power cut sees the old record or the new
// one, never half of one), mode 0600. No file (first start ever): nothing is known, nothing changes.
//
// Thread contract: none. The Gateway keeps the records on its loop thread and hands text() to a
// BackgroundFileWriter, so the loop never waits on the disk; save() blocks (tests, tools).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "motion/gateway/bus_driver.hpp"

namespace motion::gateway {

struct AxisRecord {
  std::int64_t position_counts = 0;  // at rest: where it stood; moving: where the move was seen starting
  std::int64_t target_counts = 0;    // moving: where it was going
  bool moving = false;
  bool homed = false;
  std::string lost;  // why its position is not the machine's; empty: valid
  bool operator==(const AxisRecord&) const = default;
};

class PositionRecords {
 public:
  PositionRecords() = default;
  explicit PositionRecords(std::string path) : path_(std::move(path)) {}

  [[nodiscard]] const std::string& path() const { return path_; }
  // Reads the file: empty when it was read or does not exist, else what is wrong with it (the
  // records are then empty: nothing is known).
  [[nodiscard]] std::string load();
  [[nodiscard]] const AxisRecord* find(const std::string& axis) const;
  // Replaces the record of `axis`; true when it changed (then save()).
  bool update(const std::string& axis, const AxisRecord& record);
  // The file's text for every record.
  [[nodiscard]] std::string text() const;
  // Writes every record now (write_file_durably, mode 0600): empty, or what failed. Blocks.
  [[nodiscard]] std::string save() const;

  // The text of the file and back (load() and save() use them; unit tests too). parse returns
  // what is wrong with the text, or empty.
  [[nodiscard]] static std::string format(const std::map<std::string, AxisRecord>& records);
  [[nodiscard]] static std::string parse(const std::string& text, std::map<std::string, AxisRecord>& records);

 private:
  std::string path_;
  std::map<std::string, AxisRecord> records_;
};

// What the record of an axis says of its drive's first online status after the gateway started:
// why the drive must have lost power (or been reset) meanwhile, or nullopt. Evidence:
//  - the drive's own power-on marker: where the homed flag is the drive's own (`drive_keeps_homed`,
//    e.g. UC57 status word bit 8 "homing attained"), the drive reports not homed where the record
//    says homed at rest (the drive clears it only at power-on/reset or a new homing);
//  - at rest, a position more than `tolerance` counts from the recorded one;
//  - moving, a position outside the recorded start..target by more than `tolerance`.
// `drive` names the drive in the text.
[[nodiscard]] std::optional<std::string> power_cycle_evidence(const AxisRecord& record, const DriveStatus& status,
                                                              bool drive_keeps_homed, std::int64_t tolerance,
                                                              const std::string& drive);

}  // namespace motion::gateway
