// `motionctl status --ledger`: the counters of each gateway's command ledger as it publishes them
// with its heartbeats (LEDGER_STATS, ledger_stats_t), as text and as JSON (ledger_view.cpp).
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include <motionlcm/ledger_stats_t.hpp>

#include "motion/config/config.hpp"

namespace motion::ctl {

// The latest LEDGER_STATS heard, by bus.
using HeardLedgers = std::map<std::string, motionlcm::ledger_stats_t>;

// Per bus of `c`: its parts now by lifecycle state, the totals since its gateway started, the
// commands sent again it answered, and what its ledgers refused (or a line saying none was heard).
void print_ledgers(const config::Config& c, const HeardLedgers& heard);
// Keyed by bus of `c`: its counters as published (null when none was heard).
nlohmann::json ledgers_json(const config::Config& c, const HeardLedgers& heard, std::int64_t now_us);

}  // namespace motion::ctl
