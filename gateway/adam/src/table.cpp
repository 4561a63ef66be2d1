#include "motion/adam/table.hpp"

#include <algorithm>

namespace motion::adam {

Result<std::vector<rtu::Request>> table_data_writes(std::uint8_t unit, std::uint16_t start_offset,
                                                    std::span<const std::int32_t> entries,
                                                    std::uint16_t max_registers_per_frame) {
  if (entries.empty()) return AdamErrc::kEmptyTable;
  if (max_registers_per_frame < kRegistersPerTableEntry || max_registers_per_frame > kMaxDriveWriteRegisters)
    return AdamErrc::kTooManyRegisters;
  if (entries.size() > kMaxTableEntries) return AdamErrc::kTooManyRegisters;
  const auto count = static_cast<std::uint16_t>(entries.size());
  if (table_entry_address(start_offset, count) - 1 > 0xFFFF) return AdamErrc::kTooManyRegisters;

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
  if (!in_range(Reg::kStartSpeed, p.start_speed_rpm) || !in_range(Reg::kStopSpeed, p.stop_speed_rpm) ||
      !in_range(Reg::kTargetSpeed, p.speed_centi_rpm) || p.speed_centi_rpm < 0)
    return AdamErrc::kValueOutOfRange;
  std::vector<rtu::Request> frames;
  frames.push_back(
      {unit, rtu::WriteRegisters{address(Reg::kStartSpeed),
                                 {p.start_speed_rpm, p.stop_speed_rpm, p.acceleration_ms, p.deceleration_ms}}});
  frames.push_back(write32(unit, Reg::kTargetSpeed, p.speed_centi_rpm));
  return frames;
}

Result<std::vector<rtu::Request>> sync_move_preload(std::uint8_t unit, const SyncMovePreload& preload) {
  if (unit == rtu::kBroadcastUnit || unit > kMaxNodeAddress) return AdamErrc::kInvalidUnitAddress;
  if (preload.start_offset > info(Reg::kTableStart).max) return AdamErrc::kValueOutOfRange;
  auto frames = profile_writes(unit, preload.profile);
  if (!frames) return frames;
  auto entry = single_entry_writes(unit, preload.start_offset, preload.target_pulses);
  if (!entry) return entry.error();
  auto& out = frames.value();
  out.insert(out.end(), entry.value().begin(), entry.value().end());
  return frames;
}

Result<std::vector<rtu::Request>> single_entry_writes(std::uint8_t unit, std::uint16_t start_offset,
                                                      std::int32_t target) {
  const std::int32_t entries[] = {target};
  auto out = table_data_writes(unit, start_offset, entries);
  if (!out) return out;
  out.value().push_back(write16(unit, Reg::kTableSize, 1));
  out.value().push_back(write16(unit, Reg::kTablePointer, 0));
  out.value().push_back(write16(unit, Reg::kTableStart, start_offset));
  return out;
}

std::chrono::nanoseconds transaction_time(const rtu::SerialFormat& format, const rtu::Request& request) {
  const auto frame = rtu::encode_request(request);
  const std::size_t request_bytes = frame ? frame.value().size() : 8U;
  const auto* read = std::get_if<rtu::ReadRegisters>(&request.pdu);
  const std::size_t reply_bytes = read != nullptr ? 5U + 2U * read->quantity : 8U;  // §5: read / write replies
  std::chrono::nanoseconds t = rtu::transmission_time(format, request_bytes) + kAssumedReplyLatency +
                               rtu::transmission_time(format, reply_bytes) + 2 * rtu::frame_timing(format).t3_5;
  if (is_save(request)) t += kSaveEraseTime;
  return t;
}

Result<rtu::Request> table_execute_broadcast(const TableExecute& execute) {
  const auto word = encode(execute);
  if (!word) return word.error();
  return write16(rtu::kBroadcastUnit, Reg::kTableExecute, word.value());
}

}  // namespace motion::adam
