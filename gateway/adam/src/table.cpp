#include "motion/adam/table.hpp"

#include <algorithm>

namespace motion::adam {

Result<std::vector<rtu::Request>> table_data_writes(std::uint8_t unit, std::uint16_t start_offset,
                                                    std::span<const std::int32_t> entries,
                                                    std::uint16_t max_registers_per_frame) {
  if (entries.empty()) return AdamErrc::empty_table;
  if (max_registers_per_frame < kRegistersPerTableEntry || max_registers_per_frame > kMaxDriveWriteRegisters)
    return AdamErrc::too_many_registers;
  if (entries.size() > kMaxTableEntries) return AdamErrc::too_many_registers;
  const auto count = static_cast<std::uint16_t>(entries.size());
  if (table_entry_address(start_offset, count) - 1 > 0xFFFF) return AdamErrc::too_many_registers;

  const std::size_t entries_per_frame = max_registers_per_frame / kRegistersPerTableEntry;
  std::vector<rtu::Request> frames;
  for (std::size_t first = 0; first < entries.size(); first += entries_per_frame) {
    const std::size_t last = std::min(entries.size(), first + entries_per_frame);
    rtu::WriteRegisters write{
        static_cast<std::uint16_t>(table_entry_address(start_offset, static_cast<std::uint16_t>(first))), {}};
    for (std::size_t i = first; i < last; ++i) {
      const auto words = encode32(entries[i]);
      write.values.insert(write.values.end(), words.begin(), words.end());
    }
    frames.push_back({unit, std::move(write)});
  }
  return frames;
}

Result<std::vector<rtu::Request>> profile_writes(std::uint8_t unit, const MotionProfile& p) {
  const auto in_range = [](Reg reg, std::int64_t v) { return encode_value(info(reg), v).ok(); };
  if (!in_range(Reg::start_speed, p.start_speed_rpm) || !in_range(Reg::stop_speed, p.stop_speed_rpm) ||
      !in_range(Reg::target_speed, p.speed_centi_rpm) || p.speed_centi_rpm < 0)
    return AdamErrc::value_out_of_range;
  std::vector<rtu::Request> frames;
  frames.push_back(
      {unit, rtu::WriteRegisters{address(Reg::start_speed),
                                 {p.start_speed_rpm, p.stop_speed_rpm, p.acceleration_ms, p.deceleration_ms}}});
  frames.push_back(write32(unit, Reg::target_speed, p.speed_centi_rpm));
  return frames;
}

Result<std::vector<rtu::Request>> sync_move_preload(std::uint8_t unit, const SyncMovePreload& preload) {
  if (unit == rtu::kBroadcastUnit || unit > kMaxNodeAddress) return AdamErrc::invalid_unit_address;
  if (preload.start_offset > info(Reg::table_start).max) return AdamErrc::value_out_of_range;
  auto frames = profile_writes(unit, preload.profile);
  if (!frames) return frames;
  const std::int32_t target[] = {preload.target_pulses};
  auto data = table_data_writes(unit, preload.start_offset, target);
  if (!data) return data.error();
  auto& out = frames.value();
  out.insert(out.end(), data.value().begin(), data.value().end());
  out.push_back(write16(unit, Reg::table_size, 1));
  out.push_back(write16(unit, Reg::table_pointer, 0));
  out.push_back(write16(unit, Reg::table_start, preload.start_offset));
  return frames;
}

Result<rtu::Request> table_execute_broadcast(const TableExecute& execute) {
  const auto word = encode(execute);
  if (!word) return word.error();
  return write16(rtu::kBroadcastUnit, Reg::table_execute, word.value());
}

}  // namespace motion::adam
