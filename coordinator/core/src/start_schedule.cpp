#include "motion/coordinator/start_schedule.hpp"

#include <algorithm>
#include <map>

namespace motion::coordinator {

StartSchedule schedule_starts(std::vector<StartFrame> frames) {
  std::map<std::string, std::vector<StartFrame>> by_bus;
  for (auto& f : frames) {
    f.wire_us = std::max(0.0, f.wire_us);
    f.lead_in_us = std::max(0.0, f.lead_in_us);
    f.start_wait_us = std::max(0.0, f.start_wait_us);
    by_bus[f.bus].push_back(std::move(f));
  }
  StartSchedule out;
  for (auto& [bus, list] : by_bus) {
    // Longest first; equal frames in command order (deterministic).
    const auto line_us = [](const StartFrame& f) { return f.lead_in_us + f.wire_us; };
    std::sort(list.begin(), list.end(), [&](const StartFrame& a, const StartFrame& b) {
      return line_us(a) != line_us(b) ? line_us(a) > line_us(b) : a.command_id < b.command_id;
    });
    BusStart s;
    s.bus = bus;
    // Act instants from the first hand-over: frame i ends at `end`, its drives act over its
    // lead-in up to there.
    double end = 0;
    double first_act = 0;
    for (std::size_t i = 0; i < list.size(); ++i) {
      s.command_ids.push_back(list[i].command_id);
      s.start_wait_us = std::max(s.start_wait_us, list[i].start_wait_us);
      end += line_us(list[i]);
      const double act = end - list[i].lead_in_us;
      first_act = i == 0 ? act : std::min(first_act, act);
    }
    s.span_us = end - first_act;
    s.lead_us = first_act + s.span_us / 2.0;
    out.max_lead_us = std::max(out.max_lead_us, s.lead_us);
    out.max_ahead_us = std::max(out.max_ahead_us, s.lead_us + s.start_wait_us);
    out.predicted_spread_us = std::max(out.predicted_spread_us, s.span_us);
    out.buses.push_back(std::move(s));
  }
  return out;
}

std::optional<double> start_wire_us(const motionlcm::drive_model_t& model, std::int8_t kind) {
  const std::size_t n = std::min(
      {model.start_kinds.size(), model.start_wire_us.size(), static_cast<std::size_t>(std::max(model.num_starts, 0))});
  for (std::size_t i = 0; i < n; ++i) {
    if (model.start_kinds[i] == kind) return model.start_wire_us[i];
  }
  return std::nullopt;
}

}  // namespace motion::coordinator
