#include "ledger_view.hpp"

#include <cstdio>
#include <set>

namespace motion::ctl {
namespace {

std::set<std::string> buses_of(const config::Config& c) {
  std::set<std::string> out;
  for (const auto& b : c.buses) out.insert(b.name);
  return out;
}

long long ll(std::int64_t v) { return static_cast<long long>(v); }

}  // namespace

void print_ledgers(const config::Config& c, const HeardLedgers& heard) {
  for (const auto& bus : buses_of(c)) {
    const auto it = heard.find(bus);
    if (it == heard.end()) {
      std::printf("%s: no LEDGER_STATS heard (its gateway is not running)\n", bus.c_str());
      continue;
    }
    const auto& m = it->second;
    std::printf("%s: %s, up %.1f s\n", bus.c_str(), m.process.c_str(), m.uptime_s);
    std::printf("  parts now     loading %d, armed %d, started %d, done %d, failed %d, stopped %d\n", m.now_loading,
                m.now_armed, m.now_started, m.now_done, m.now_failed, m.now_stopped);
    std::printf("  parts total   accepted %lld, armed %lld, started %lld, done %lld, failed %lld, stopped %lld\n",
                ll(m.accepted), ll(m.armed), ll(m.started), ll(m.done), ll(m.failed), ll(m.stopped));
    std::printf("  failed as     refused %lld, fault %lld, offline %lld, timeout %lld, other %lld\n",
                ll(m.failed_refused), ll(m.failed_fault), ll(m.failed_offline), ll(m.failed_timeout),
                ll(m.failed_other));
    std::printf("  sent again    %lld answered with their latest reply, %lld before any reply; %lld released\n",
                ll(m.repeats_answered), ll(m.repeats_unanswered), ll(m.released));
    std::printf("  refused       %lld transitions, %lld terminals, %lld ids in use\n", ll(m.refused_transitions),
                ll(m.refused_terminals), ll(m.refused_adds));
  }
}

nlohmann::json ledgers_json(const config::Config& c, const HeardLedgers& heard, std::int64_t now_us) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& bus : buses_of(c)) {
    const auto it = heard.find(bus);
    if (it == heard.end()) {
      out[bus] = nullptr;
      continue;
    }
    const auto& m = it->second;
    out[bus] = {
        {"process", m.process},
        {"uptime_s", m.uptime_s},
        {"age_s", static_cast<double>(now_us - m.utime) / 1e6},
        {"now",
         {{"loading", m.now_loading},
          {"armed", m.now_armed},
          {"started", m.now_started},
          {"done", m.now_done},
          {"failed", m.now_failed},
          {"stopped", m.now_stopped}}},
        {"total",
         {{"accepted", m.accepted},
          {"armed", m.armed},
          {"started", m.started},
          {"done", m.done},
          {"failed", m.failed},
          {"stopped", m.stopped}}},
        {"failed_as",
         {{"refused", m.failed_refused},
          {"fault", m.failed_fault},
          {"offline", m.failed_offline},
          {"timeout", m.failed_timeout},
          {"other", m.failed_other}}},
        {"repeats_answered", m.repeats_answered},
        {"repeats_unanswered", m.repeats_unanswered},
        {"released", m.released},
        {"refused",
         {{"transitions", m.refused_transitions}, {"terminals", m.refused_terminals}, {"adds", m.refused_adds}}}};
  }
  return out;
}

}  // namespace motion::ctl
