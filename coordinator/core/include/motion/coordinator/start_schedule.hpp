// Scheduled starts: when each bus's gateway hands its start frames to the wire so that the drives
// of a synchronized move ACT together (a drive acts at the end of its start frame: UIM342 BG,
// UIM342 manual §4 "BG"; a CANopen SYNC applying synchronous RPDOs of transmission type 1, UC57
// manual §5 "RPDO communication parameters"; an ADAM broadcast execute, whose end is the end of
// the RTU frame, ADAM Modbus manual §2 "broadcast" and its 3.5-character silent interval).
//
// One start frame per gateway command (the coordinator splits a move by start mechanism), with the
// wire time its drive model gives (drive_model_t.start_wire_us). Per bus:
//  * the frames go out back to back, longest first: the act instants on one bus are the frames'
//    ends e1 < e2 < ... < ek, their spread ek - e1 is the wire time of all frames but the first,
//    least when the first is the longest;
//  * those act instants are centred on the common act instant: the bus sends its first frame
//    lead = e1 + (ek - e1) / 2 before it. Every bus's span is then centred on the same instant and
//    the move's spread is the largest span, the least any schedule can give.
// A frame with a lead-in (a UIM242 crawl before its gSPD) takes lead-in + wire time on the line,
// and its drives act over the lead-in up to its end: the bus's span covers that too.
// CAN arbitration behind a frame already on the wire (at most one frame) is not in the lead: it is
// the remaining jitter, not a bias.
// A serial line may be in the middle of an exchange (a poll) when its gateway hears the trigger;
// from then on it begins none that would still run at the send time, so the line is free then if
// the trigger is heard at least the line's start wait (LINE_TIMING) before the bus's send time.
// That is not part of the lead (the frame does not wait once the line is free): it makes the
// schedule's first hand-over `ahead_us` = max over buses of (lead + start wait) from the trigger's
// hearing instead of max lead.
//
// Pure: thread-safe, no I/O.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <motionlcm/drive_model_t.hpp>

namespace motion::coordinator {

// One start mechanism of a move: the gateway command that carries it and its start frame.
struct StartFrame {
  std::string bus;
  std::int64_t command_id = 0;
  double wire_us = 0;  // the start frame's wire time on its bus (negative values count as 0)
  // Instructions that go out before the start frame and already start some of its drives, one
  // after the other (UIM242 crawls, drive model START_UIM242_CRAWL): on the line before the
  // frame, and the command's drives act over this span up to the frame's end.
  double lead_in_us = 0;
  // How long before its bus's send time the trigger must be heard for the line to be free
  // (LINE_TIMING start_wait_us; the largest of the bus's frames counts).
  double start_wait_us = 0;
};

struct BusStart {
  std::string bus;
  double lead_us = 0;                     // first frame handed to the wire this long before the act instant
  double span_us = 0;                     // spread of this bus's act instants (0: one frame)
  double start_wait_us = 0;               // heard at least this long before its first hand-over
  std::vector<std::int64_t> command_ids;  // wire order
};

struct StartSchedule {
  std::vector<BusStart> buses;  // sorted by bus name
  double max_lead_us = 0;
  double max_ahead_us = 0;         // the largest lead + start wait: the act instant after the trigger is heard
  double predicted_spread_us = 0;  // the largest span: what the schedule leaves between the first and last drive
};

[[nodiscard]] StartSchedule schedule_starts(std::vector<StartFrame> frames);

// The wire time of the start mechanism `kind` (drive_model_t::START_*) in `model`, if it has it.
[[nodiscard]] std::optional<double> start_wire_us(const motionlcm::drive_model_t& model, std::int8_t kind);

}  // namespace motion::coordinator
