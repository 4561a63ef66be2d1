// Gateway (gateway.hpp): what a previous gateway process of the bus left behind: the position
// record kept across the gateway's own restarts (position_record.hpp), and drives it left moving
// (README "Safety and faults").
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <motionlcm/event_t.hpp>

#include <cstdlib>

#include "motion/gateway/gateway.hpp"
#include "motion/gateway/power_up_watch.hpp"

namespace motion::gateway {

void Gateway::stop_if_found_moving(const std::string& axis, const DriveStatus& status) {
  if (!status.moving || commanded_.contains(axis)) return;
  const config::Axis& cfg = *axes_.at(axis);
  DriveEvent e;
  e.kind = motionlcm::event_t::GATEWAY_RESTARTED;
  e.severity = motionlcm::event_t::WARNING;
  e.text = fmt::format(
      "{} found axis {} moving (at {:.6g} {}, {} counts) when it first heard of it, before sending it anything "
      "(a previous gateway process's move): {}",
      process_name(), axis,
      AxisScale{cfg.steps_per_unit, cfg.invert}.to_units(static_cast<double>(status.position_counts)), cfg.unit,
      status.position_counts, driver_ ? "stopping it" : "no bus driver to stop it");
  const auto stop = own_command(motionlcm::gateway_command_t::STOP, {axis});
  if (driver_) driver_->execute(stop);
  axis_event(axis, e);
}

void Gateway::set_position_record(const std::string& path) {
  records_.emplace(path);
  record_writer_.emplace(path);
  if (std::string why = records_->load(); !why.empty()) {
    spdlog::warn("position record not used ({}): nothing is known of where the axes of bus {} were", why, bus_);
    return;
  }
  spdlog::info("position record {}", path);
}

void Gateway::check_record(const std::string& axis, const DriveStatus& status) {
  record_checked_.insert(axis);
  const AxisRecord* record = records_->find(axis);
  if (record == nullptr) return;  // never recorded (first start): nothing is known
  const std::string drive = config_.drive_of(*axes_.at(axis))->name;
  if (!record->lost.empty()) {  // lost before, and neither homed nor set since: still lost
    position_lost(axis, record->lost);
    return;
  }
  const auto facts = facts_.find(axis);
  const bool drive_keeps_homed = facts != facts_.end() && facts->second.drive_keeps_homed;
  // The same slack as the running gateway's watch of a drive that sends nothing at power-up.
  constexpr auto kTolerance = static_cast<std::int64_t>(PowerUpWatch::kSlackCounts);
  if (auto why = power_cycle_evidence(*record, status, drive_keeps_homed, kTolerance, drive)) {
    // A UIM342's origin set to another value than 0 lives in its driver, not in the drive (OG
    // zeroes the counter, UIM342 manual §5.22): a restart of the gateway alone shifts it too.
    if (config_.drive_of(*axes_.at(axis))->family == config::Family::kUim342)
      *why += ", or the origin offset (SET_POSITION or homing offset) the previous gateway process kept is gone";
    position_lost(axis, *why);
    return;
  }
  // Homed by a previous gateway process, and no sign of a power cycle since: still homed (a
  // family whose drive keeps the flag itself says so on its own).
  if (record->homed && !drive_keeps_homed) restored_homed_.insert(axis);
  spdlog::info("axis {}: {} at {} counts, as recorded ({}){}", axis, drive, status.position_counts,
               record->moving ? "moving" : "at rest", record->homed ? ", homed" : "");
}

void Gateway::keep_record(const std::string& axis, const DriveStatus& status, bool homed) {
  AxisRecord next;
  next.homed = homed;
  if (const auto lost = position_lost_.find(axis); lost != position_lost_.end()) next.lost = lost->second;
  next.moving = status.moving;
  next.position_counts = status.position_counts;
  next.target_counts = status.moving ? status.target_counts : status.position_counts;
  // Moving: where the move was seen starting stays the record's position (the drive is somewhere
  // between it and the target until the move ends), so a move writes the file twice, not per poll.
  // At rest, a few counts of jitter (a closed-loop drive holding its position) are not worth a
  // write: far below what the comparison at start tolerates.
  constexpr std::int64_t kRestJitter = 8;
  if (const AxisRecord* old = records_->find(axis); old != nullptr) {
    if (old->moving && next.moving && old->target_counts == next.target_counts) {
      next.position_counts = old->position_counts;
    } else if (!old->moving && !next.moving && std::abs(next.position_counts - old->position_counts) <= kRestJitter) {
      next.position_counts = old->position_counts;
      next.target_counts = old->target_counts;
    }
  }
  if (!records_->update(axis, next)) return;
  // The outcome of the previous write (the writer's thread has finished it by now, or reports it
  // with the next change): logged once per distinct failure.
  std::string error = record_writer_->last_error();
  if (!error.empty() && error != record_error_) spdlog::warn("position record not written: {}", error);
  record_error_ = std::move(error);
  record_writer_->write(records_->text());  // never waits for the disk (durable_file.hpp)
}

}  // namespace motion::gateway
