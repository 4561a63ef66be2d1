// The adaptive trigger lead (trigger_lead.hpp).
#include "motion/coordinator/trigger_lead.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace motion::coordinator {

void TriggerLead::published(std::int64_t trigger_id, std::int64_t utime) {
  published_[trigger_id] = Published{utime, {}};
  while (published_.size() > kRememberedTriggers) published_.erase(published_.begin());  // the oldest id
}

bool TriggerLead::heard(const std::string& bus, std::int64_t trigger_id, std::int64_t heard_utime) {
  const auto it = published_.find(trigger_id);
  if (it == published_.end() || !it->second.heard_by.insert(bus).second) return false;
  add(bus, heard_utime - it->second.utime);
  return true;
}

void TriggerLead::add(const std::string& bus, std::int64_t delay_us) {
  auto& d = delays_[bus];
  d.push_back(std::max<std::int64_t>(0, delay_us));
  while (d.size() > std::max<std::size_t>(settings_.window, 1)) d.pop_front();
}

std::optional<std::int64_t> TriggerLead::p99_us(const std::string& bus) const {
  const auto it = delays_.find(bus);
  if (it == delays_.end() || it->second.empty()) return std::nullopt;
  std::vector<std::int64_t> sorted(it->second.begin(), it->second.end());
  // Nearest rank: with up to 100 samples, the largest.
  const auto rank = static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(sorted.size())));
  const auto nth = sorted.begin() + static_cast<std::ptrdiff_t>(std::max<std::size_t>(rank, 1) - 1);
  std::nth_element(sorted.begin(), nth, sorted.end());
  return *nth;
}

std::size_t TriggerLead::samples(const std::string& bus) const {
  const auto it = delays_.find(bus);
  return it == delays_.end() ? 0 : it->second.size();
}

std::int64_t TriggerLead::lead_us(const std::set<std::string>& buses) const {
  std::int64_t slowest = 0;
  for (const auto& bus : buses) {
    const auto p99 = p99_us(bus);
    if (!p99 || samples(bus) < settings_.enough) return settings_.max_us;
    slowest = std::max(slowest, *p99);
  }
  const auto lead = std::llround(static_cast<double>(slowest) * settings_.margin) + settings_.floor_us;
  return std::clamp<std::int64_t>(lead, std::min(settings_.min_us, settings_.max_us), settings_.max_us);
}

}  // namespace motion::coordinator
