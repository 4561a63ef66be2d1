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
// When stderr is the systemd journal (stderr_is_journal()), lines carry no timestamp and start
// with their syslog priority ("<3>" for errors, sd-daemon(3)) so journald keeps their level;
// otherwise "2026-01-02T03:04:05.678 name[pid] level: text".
bool init(std::string_view process_name, std::string_view level = "info");

// True when $JOURNAL_STREAM names the device and inode of this process's stderr (systemd.exec(5)).
[[nodiscard]] bool stderr_is_journal();

}  // namespace motion::log
