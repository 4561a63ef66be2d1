#include "motion/sim/adam_serial_host.hpp"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>

#include <spdlog/spdlog.h>

#include "motion/adam/rtu.hpp"
#include "motion/serial/serial_port.hpp"

namespace motion::sim {

namespace rtu = adam::rtu;

namespace {
Duration silence_of(const config::Bus& bus) {
  rtu::SerialFormat format;
  format.baud = static_cast<std::uint32_t>(bus.baud);
  format.parity = bus.parity == 'N' ? rtu::Parity::none : bus.parity == 'E' ? rtu::Parity::even : rtu::Parity::odd;
  format.stop_bits = static_cast<std::uint8_t>(bus.stop_bits);
  return rtu::frame_timing(format).t3_5;
}
}  // namespace

AdamSerialHost::AdamSerialHost(EventLoop& loop, const config::Config& config, const config::Bus& bus, Reporter reporter)
    : loop_(loop), bus_(bus), reporter_(std::move(reporter)), framer_(silence_of(bus)) {
  const Duration latency = std::chrono::microseconds(config.simulation.reply_latency_us);
  for (const auto& d : config.drives) {
    if (d.bus != bus.name) continue;
    if (d.family != config::Family::kAdamModbus) {
      missing_.push_back(d.name + " (" + std::string(config::to_string(d.family)) + ")");
      continue;
    }
    auto drive = std::make_unique<Drive>();
    drive->config = &d;
    drive->slave.unit = static_cast<std::uint8_t>(d.node_id);
    drive->latency = latency;
    drives_[d.name] = std::move(drive);
  }
}

bool AdamSerialHost::serves(const config::Config& config, const config::Bus& bus) {
  return std::any_of(config.drives.begin(), config.drives.end(), [&](const config::Drive& d) {
    return d.bus == bus.name && d.family == config::Family::kAdamModbus;
  });
}

std::unique_ptr<AdamSerialHost> AdamSerialHost::open(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                                     Reporter reporter, std::error_code& error) {
  auto host = std::unique_ptr<AdamSerialHost>(new AdamSerialHost(loop, config, bus, std::move(reporter)));
  host->link_ = serial::PtyLink::create(serial::simserial_link_path(config, bus), serial::settings_from(bus), error);
  if (!host->link_) return nullptr;
  loop.watch(host->link_->master_fd(), [h = host.get()] { h->on_readable(); });
  const TimePoint now = loop.now();
  for (auto& [name, d] : host->drives_) host->report(*d, motionlcm::sim_report_t::POWERED_UP, wall_time_us(), now);
  return host;
}

AdamSerialHost::~AdamSerialHost() {
  if (link_) loop_.unwatch(link_->master_fd());
  if (silence_timer_ != 0) loop_.cancel(silence_timer_);
  for (auto& [name, d] : drives_) {
    if (d->finish_timer != 0) loop_.cancel(d->finish_timer);
  }
}

void AdamSerialHost::on_readable() {
  std::array<std::uint8_t, 512> buffer{};
  const TimePoint now = loop_.now();
  for (;;) {
    const ssize_t n = ::read(link_->master_fd(), buffer.data(), buffer.size());
    if (n <= 0) break;  // EAGAIN: drained (the slave fd kept open here means no EIO)
    framer_.push(std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(n)), now);
    // Close every complete frame the header announces (a pty delivers frames back to back).
    for (;;) {
      const auto pending = framer_.pending();
      const auto size = rtu::request_frame_size(pending);
      if (!size || pending.size() < *size || !rtu::crc_ok(pending.first(*size))) break;
      std::vector<std::uint8_t> all = framer_.complete_now();
      std::vector<std::uint8_t> frame(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(*size));
      framer_.push(std::span<const std::uint8_t>(all).subspan(*size), now);
      serve_frame(frame, now);
    }
  }
  if (silence_timer_ != 0) loop_.cancel(silence_timer_);
  silence_timer_ = 0;
  if (framer_.deadline() != kNever) {
    silence_timer_ = loop_.call_at(framer_.deadline(), [this] {
      silence_timer_ = 0;
      on_silence();
    });
  }
}

void AdamSerialHost::on_silence() {
  // Whatever is left after t3.5 of silence is one frame: usually a bad-CRC one to discard.
  if (auto frame = framer_.take_if_silent(loop_.now())) serve_frame(*frame, loop_.now());
}

void AdamSerialHost::serve_frame(const std::vector<std::uint8_t>& frame, TimePoint received) {
  const std::int64_t frame_utime = wall_time_us() - std::chrono::duration_cast<std::chrono::microseconds>(loop_.now() - received).count();
  for (auto& [name, d] : drives_) {
    if (d->silent) continue;
    d->sim.set_now(received);
    const adam::ServeResult result = adam::serve(frame, d->slave, d->sim);
    if (result.outcome == adam::ServeOutcome::discarded && name == drives_.begin()->first) {
      spdlog::debug("bus {}: discarded {}-byte frame ({})", bus_.name, frame.size(),
                    result.frame_error ? make_error_code(*result.frame_error).message() : "?");
    }
    if (d->sim.take_motion_started()) {
      report(*d, motionlcm::sim_report_t::MOTION_STARTED, frame_utime, received);
      watch_motion(*d);
    }
    if (result.reply.empty()) continue;
    std::vector<std::uint8_t> reply = result.reply;
    if (d->corrupt_replies) reply.back() ^= 0xFF;  // SIM_CONTROL CRC_ERRORS
    loop_.call_after(d->latency, [this, reply = std::move(reply)] {
      if (::write(link_->master_fd(), reply.data(), reply.size()) < 0)
        spdlog::warn("bus {}: reply not written: {}", bus_.name, std::error_code(errno, std::generic_category()).message());
    });
  }
}

void AdamSerialHost::watch_motion(Drive& d) {
  if (d.finish_timer != 0) loop_.cancel(d.finish_timer);
  d.finish_timer = 0;
  const TimePoint end = d.sim.motion_end();
  if (end == kNever) return;  // jogging: finished by a later stop command
  d.finish_timer = loop_.call_at(end, [this, drive = &d] {
    drive->finish_timer = 0;
    if (drive->sim.settle(loop_.now())) report(*drive, motionlcm::sim_report_t::MOTION_FINISHED, wall_time_us(), loop_.now());
  });
}

void AdamSerialHost::report(const Drive& d, std::int8_t kind, std::int64_t frame_utime, TimePoint now) const {
  if (!reporter_) return;
  motionlcm::sim_report_t r{};
  r.utime = wall_time_us();
  r.drive = d.config->name;
  r.bus = bus_.name;
  r.kind = kind;
  r.frame_utime = frame_utime;
  r.position_counts = d.sim.position(now);
  r.target_counts = d.sim.target();
  reporter_(std::move(r));
}

bool AdamSerialHost::control(const motionlcm::sim_control_t& c) {
  const auto it = drives_.find(c.drive);
  if (it == drives_.end()) return false;
  Drive& d = *it->second;
  const TimePoint now = loop_.now();
  switch (c.action) {
    case motionlcm::sim_control_t::ALARM: d.sim.inject_alarm(static_cast<adam::AlarmCode>(c.value & 0x0F), now); break;
    case motionlcm::sim_control_t::STALL: d.sim.inject_alarm(adam::AlarmCode::position_error, now); break;
    case motionlcm::sim_control_t::SILENCE: d.silent = c.value != 0; break;
    case motionlcm::sim_control_t::CRC_ERRORS: d.corrupt_replies = c.value != 0; break;
    case motionlcm::sim_control_t::REPLY_LATENCY: d.latency = std::chrono::microseconds(c.value); break;
    case motionlcm::sim_control_t::SET_INPUT: d.sim.set_input(static_cast<unsigned>(c.value - 1), c.level != 0, now); break;
    case motionlcm::sim_control_t::POWER_CYCLE:
      d.sim.power_cycle(now);
      report(d, motionlcm::sim_report_t::POWERED_UP, wall_time_us(), now);
      break;
    default: return false;
  }
  return true;
}

}  // namespace motion::sim
