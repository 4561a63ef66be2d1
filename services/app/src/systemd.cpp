#include "motion/app/systemd.hpp"

#include <cstdlib>
#include <string>

#include <spdlog/spdlog.h>

#ifdef MOTION_HAVE_SYSTEMD
#include <systemd/sd-daemon.h>
#endif

namespace motion::app::systemd {
namespace {

// A STATUS= value is one line: newlines would start new assignments of the notify message.
std::string one_line(std::string_view text) {
  std::string out(text);
  for (auto& c : out) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return out;
}

void send(const std::string& state) {
#ifdef MOTION_HAVE_SYSTEMD
  // unset_environment = 0: $NOTIFY_SOCKET stays for the STATUS=, WATCHDOG=1 and STOPPING=1 that
  // follow READY=1.
  const int r = ::sd_notify(0, state.c_str());
  if (r < 0) spdlog::debug("sd_notify({}) failed: error {}", state.substr(0, state.find('\n')), -r);
#else
  (void)state;
#endif
}

}  // namespace

bool notify_socket_set() {
#ifdef MOTION_HAVE_SYSTEMD
  const char* socket = std::getenv("NOTIFY_SOCKET");
  return socket != nullptr && *socket != '\0';
#else
  return false;
#endif
}

void notify_ready(std::string_view status) { send("READY=1\nSTATUS=" + one_line(status)); }

void notify_status(std::string_view status) { send("STATUS=" + one_line(status)); }

void notify_stopping() { send("STOPPING=1"); }

Duration start_watchdog(EventLoop& loop) {
#ifdef MOTION_HAVE_SYSTEMD
  std::uint64_t usec = 0;
  if (::sd_watchdog_enabled(0, &usec) <= 0 || usec == 0) return Duration::zero();
  // Half the interval, as sd_watchdog_enabled(3) advises: one late loop turn is not a restart.
  const auto period = std::chrono::duration_cast<Duration>(std::chrono::microseconds(usec / 2));
  loop.call_every(period, [] { send("WATCHDOG=1"); });
  send("WATCHDOG=1");
  spdlog::debug("systemd watchdog: {} us, pinging every {} us", usec, usec / 2);
  return period;
#else
  (void)loop;
  return Duration::zero();
#endif
}

}  // namespace motion::app::systemd
