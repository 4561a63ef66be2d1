#include "motion/gateway/serial_bus_driver.hpp"

#include <array>
#include <utility>

#include <spdlog/spdlog.h>

#include <motionlcm/event_t.hpp>

namespace motion::gateway {

SerialBusDriver::SerialBusDriver(EventLoop& loop, std::string bus, std::string device_path, serial::SerialSettings line,
                                 GatewayOutput& out, const CoreFactory& make_core)
    : loop_(loop), bus_(std::move(bus)), device_path_(std::move(device_path)), line_(line), out_(out) {
  core_ = make_core([this](std::span<const std::uint8_t> bytes) { return write(bytes); });
}

SerialBusDriver::~SerialBusDriver() {
  if (timer_ != 0) loop_.cancel(timer_);
  if (reopen_timer_ != 0) loop_.cancel(reopen_timer_);
  if (port_) loop_.unwatch(port_->fd());
}

void SerialBusDriver::start() { try_open(); }

void SerialBusDriver::try_open() {
  reopen_timer_ = 0;
  std::error_code error;
  port_ = serial::SerialPort::open(device_path_, line_, error);
  if (!port_) {
    const std::string text = "cannot open " + device_path_ + " for bus " + bus_ + ": " + error.message();
    closed_because_ = "cannot open " + device_path_ + ": " + error.message();
    if (text != last_open_error_) {  // one event per distinct cause, not one per retry
      spdlog::warn("bus {}: {} (retrying every {} ms)", bus_, closed_because_,
                   std::chrono::duration_cast<std::chrono::milliseconds>(reopen_period).count());
      DriveEvent e;
      e.kind = motionlcm::event_t::OFFLINE;
      e.severity = motionlcm::event_t::ERROR;
      e.text = text;
      out_.axis_event({}, e);
      last_open_error_ = text;
    }
    reopen_timer_ = loop_.call_after(reopen_period, [this] { try_open(); });
    return;
  }
  last_open_error_.clear();
  closed_because_.clear();
  if (port_->is_socket()) {
    spdlog::info("bus {}: {} is a simulated line's socket (no termios; any parity bit counted in the character time)",
                 bus_, device_path_);
  } else if (port_->parity_modelled()) {
    spdlog::info(
        "bus {}: {} is a pseudo-terminal that refuses parity: opened 8N{}, the parity bit counted in the character "
        "time",
        bus_, device_path_, line_.stop_bits);
  }
  loop_.watch(port_->fd(), [this] { on_readable(); });
  core_->start(loop_.now());
  pump();
}

void SerialBusDriver::close_port(const std::string& why) {
  if (!port_) return;
  loop_.unwatch(port_->fd());
  port_.reset();
  closed_because_ = device_path_ + " lost: " + why;
  core_->line_lost(why, loop_.now());
  if (reopen_timer_ == 0) reopen_timer_ = loop_.call_after(reopen_period, [this] { try_open(); });
}

bool SerialBusDriver::write(std::span<const std::uint8_t> bytes) {
  if (!port_) return false;
  if (const auto error = port_->write(bytes)) {
    spdlog::debug("bus {}: {}-byte write to {} failed: {}", bus_, bytes.size(), device_path_, error.message());
    return false;
  }
  return true;
}

void SerialBusDriver::on_readable() {
  std::array<std::uint8_t, 512> buffer{};
  for (;;) {
    if (!port_) return;
    std::error_code error;
    const std::size_t n = port_->read(buffer, error);
    if (error) {
      close_port(error.message());
      break;
    }
    if (n == 0) break;
    core_->on_bytes(std::span<const std::uint8_t>(buffer.data(), n), loop_.now());
  }
  pump();
}

void SerialBusDriver::pump() {
  const TimePoint deadline = core_->process(loop_.now());
  if (timer_ != 0) loop_.cancel(timer_);
  timer_ = 0;
  if (deadline == kNever) return;
  timer_ = loop_.call_at(deadline, [this] {
    timer_ = 0;
    pump();
  });
}

void SerialBusDriver::execute(const motionlcm::gateway_command_t& command) {
  core_->execute(command, loop_.now());
  pump();
}

void SerialBusDriver::fire(std::int64_t trigger_id) {
  if (const std::string busy = core_->exchange_under_way(loop_.now()); !busy.empty())
    spdlog::info("bus {}: trigger {}: its start waits for the exchange under way, {}", bus_, trigger_id, busy);
  core_->fire(trigger_id, loop_.now());
  pump();
}

void SerialBusDriver::prepare_fire(TimePoint at) {
  core_->reserve_line(at, loop_.now());
  pump();
}

std::vector<motionlcm::bus_stats_t> SerialBusDriver::statistics() const {
  auto stats = core_->statistics();
  if (!port_) stats.state = closed_because_.empty() ? std::string{"closed"} : "closed: " + closed_because_;
  return {stats};
}

bool SerialBusDriver::ready() const { return port_ != nullptr && core_->ready(); }

}  // namespace motion::gateway
