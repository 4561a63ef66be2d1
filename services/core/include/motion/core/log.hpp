// Logging for every process: spdlog, one logger per process, level from the command line.
// Thread-safe (spdlog's _mt sinks). Not for the cyclic path of protocol cores: they return
// errors and events instead, and the process decides what to log.
#pragma once

#include <spdlog/spdlog.h>

#include <string>
#include <string_view>

namespace motion::log {

// Sets up the default logger named after the process, writing to stderr, at `level`
// ("trace", "debug", "info", "warn", "error", "off"). Returns false for an unknown level name.
bool init(std::string_view process_name, std::string_view level = "info");

}  // namespace motion::log
