// The systemd service-manager protocol of the daemons (sd_notify(3), sd_watchdog_enabled(3)):
// READY=1, STATUS=..., WATCHDOG=1 and STOPPING=1 for units of Type=notify. Every function is a
// no-op when the process was not started with $NOTIFY_SOCKET (not under systemd, or another unit
// type), and when the build has no libsystemd (MOTION_HAVE_SYSTEMD unset).
// Thread contract: the loop's thread. One datagram to the service manager per call, which reads
// them at once: no call waits in practice.
#pragma once

#include <string>
#include <string_view>

#include "motion/core/clock.hpp"
#include "motion/core/event_loop.hpp"

namespace motion::app::systemd {

// True when the service manager listens ($NOTIFY_SOCKET set and libsystemd built in).
[[nodiscard]] bool notify_socket_set();

// READY=1 with a STATUS= line: the process does what its unit starts it for.
void notify_ready(std::string_view status);
// STATUS=<status> (shown by `systemctl status`).
void notify_status(std::string_view status);
// STOPPING=1: a clean shutdown has begun.
void notify_stopping();

// When the unit sets WatchdogSec= ($WATCHDOG_USEC, and $WATCHDOG_PID naming this process if set),
// sends WATCHDOG=1 from a timer of `loop` every half the interval: a loop that stops turning stops
// the pings, and systemd kills and restarts the process. Returns the ping period, zero when no
// watchdog was asked for.
Duration start_watchdog(EventLoop& loop);

}  // namespace motion::app::systemd
