// The adaptive trigger lead (trigger_lead.hpp).
#include "motion/coordinator/trigger_lead.hpp"

#include <algorithm>
#include <cmath>

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

std::optional<std::int64_t> TriggerLead::envelope_us(const std::string& bus) const {
  const auto it = delays_.find(bus);
  if (it == delays_.end() || it->second.empty()) return std::nullopt;
  const auto& d = it->second;
  const double half_life = settings_.half_life > 0 ? settings_.half_life : 1.0;
  double envelope = 0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    const auto age = static_cast<double>(d.size() - 1 - i);
    envelope = std::max(envelope, static_cast<double>(d[i]) * std::exp2(-age / half_life));
  }
  return std::llround(envelope);
}

std::size_t TriggerLead::samples(const std::string& bus) const {
  const auto it = delays_.find(bus);
  return it == delays_.end() ? 0 : it->second.size();
}

std::int64_t TriggerLead::lead_us(const std::set<std::string>& buses) const {
  std::int64_t slowest = 0;
  for (const auto& bus : buses) {
    const auto envelope = envelope_us(bus);
    if (!envelope || samples(bus) < settings_.enough) return settings_.max_us;
    slowest = std::max(slowest, *envelope);
  }
  const auto lead = std::llround(static_cast<double>(slowest) * settings_.margin) + settings_.floor_us;
  return std::clamp<std::int64_t>(lead, std::min(settings_.min_us, settings_.max_us), settings_.max_us);
}

}  // namespace motion::coordinator
