#include "motion/sim/adam_line_sim.hpp"

#include <algorithm>

#include <spdlog/spdlog.h>

#include "motion/adam/rtu.hpp"
#include "motion/config/sim_variants.hpp"

namespace motion::sim {

namespace rtu = adam::rtu;

namespace {
Duration silence_of(const config::Bus& bus) {
  rtu::SerialFormat format;
  format.baud = static_cast<std::uint32_t>(bus.baud);
  format.parity = bus.parity == 'N' ? rtu::Parity::kNone : bus.parity == 'E' ? rtu::Parity::kEven : rtu::Parity::kOdd;
  format.stop_bits = static_cast<std::uint8_t>(bus.stop_bits);
  return rtu::frame_timing(format).t3_5;
}
}  // namespace

AdamLineSim::AdamLineSim(const config::Config& config, const config::Bus& bus, SerialDeviceContext context)
    : context_(std::move(context)), framer_(silence_of(bus)) {
  const Duration latency = std::chrono::microseconds(config.simulation.reply_latency_us);
  for (const auto& d : config.drives) {
    if (d.bus != bus.name || d.family != config::Family::kAdamModbus) continue;
    auto drive = std::make_unique<Drive>();
    drive->config = &d;
    drive->slave.unit = static_cast<std::uint8_t>(d.node_id);
    AdamTableVariants variants;
    const auto speed = config::sim_variant(config, d, "table_speed_register");
    variants.speed = speed == "0x00D8"   ? AdamTableVariants::Speed::kTarget00d8
                     : speed == "shared" ? AdamTableVariants::Speed::kShared
                                         : AdamTableVariants::Speed::kWorking009a;
    variants.needs_save = config::sim_variant(config, d, "table_needs_save") == "true";
    drive->sim = AdamDriveSim(variants);
    drive->latency = latency;
    drives_[d.name] = std::move(drive);
  }
}

std::int64_t AdamLineSim::position(const std::string& drive, TimePoint now) const {
  const auto it = drives_.find(drive);
  return it == drives_.end() ? 0 : it->second->sim.position(now);
}

int AdamLineSim::saves(const std::string& drive) const {
  const auto it = drives_.find(drive);
  return it == drives_.end() ? 0 : it->second->sim.saves();
}

void AdamLineSim::power_up(TimePoint now) {
  for (auto& [name, d] : drives_) report(*d, motionlcm::sim_report_t::POWERED_UP, context_.utime_of(now), now);
}

TimePoint AdamLineSim::receive(std::span<const std::uint8_t> bytes, TimePoint now) {
  framer_.push(bytes, now);
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
  return next_deadline();
}

TimePoint AdamLineSim::process(TimePoint now) {
  // Whatever is left after t3.5 of silence is one frame: usually a bad-CRC one to discard.
  if (auto frame = framer_.take_if_silent(now)) serve_frame(*frame, now);
  for (auto& [name, d] : drives_) {
    if (d->finish_at > now) continue;
    // Reported even when a poll's read settled the drive first (the read does the bookkeeping);
    // dated by the motion's end, not by when this runs.
    const TimePoint ended = d->finish_at;
    d->finish_at = kNever;
    d->sim.settle(now);
    report(*d, motionlcm::sim_report_t::MOTION_FINISHED, context_.utime_of(ended), now);
  }
  return next_deadline();
}

TimePoint AdamLineSim::next_deadline() const {
  TimePoint next = framer_.deadline();
  for (const auto& [name, d] : drives_) next = std::min(next, d->finish_at);
  return next;
}

void AdamLineSim::serve_frame(const std::vector<std::uint8_t>& frame, TimePoint received) {
  const std::int64_t frame_utime = context_.utime_of(received);
  for (auto& [name, d] : drives_) {
    if (d->silent || received < d->sim.busy_until()) continue;  // erasing flash: no answer (§8.69)
    d->sim.set_now(received);
    const int saves = d->sim.saves();
    const adam::ServeResult result = adam::serve(frame, d->slave, d->sim);
    if (result.outcome == adam::ServeOutcome::kDiscarded && name == drives_.begin()->first) {
      spdlog::debug("bus {}: discarded {}-byte frame ({})", context_.bus, frame.size(),
                    result.frame_error ? make_error_code(*result.frame_error).message() : "?");
    }
    if (d->sim.take_motion_started()) {
      report(*d, motionlcm::sim_report_t::MOTION_STARTED, frame_utime, received);
      d->finish_at = d->sim.motion_end();  // kNever while jogging: a later stop ends it
    }
    if (result.reply.empty()) continue;
    std::vector<std::uint8_t> reply = result.reply;
    if (d->corrupt_replies) reply.back() ^= 0xFF;  // SIM_CONTROL CRC_ERRORS
    // A Save answers when its flash erase is done.
    context_.send(reply, d->latency + (d->sim.saves() != saves ? d->sim.busy_until() - received : Duration{}));
  }
}

void AdamLineSim::report(const Drive& d, std::int8_t kind, std::int64_t frame_utime, TimePoint now) const {
  context_.report(d.config->name, kind, frame_utime, d.sim.position(now), d.sim.target());
}

bool AdamLineSim::control(const motionlcm::sim_control_t& c, TimePoint now) {
  const auto it = drives_.find(c.drive);
  if (it == drives_.end()) return false;
  Drive& d = *it->second;
  switch (c.action) {
    case motionlcm::sim_control_t::ALARM: d.sim.inject_alarm(static_cast<adam::AlarmCode>(c.value & 0x0F), now); break;
    case motionlcm::sim_control_t::STALL: d.sim.inject_alarm(adam::AlarmCode::kPositionError, now); break;
    case motionlcm::sim_control_t::SILENCE: d.silent = c.value != 0; break;
    case motionlcm::sim_control_t::CRC_ERRORS: d.corrupt_replies = c.value != 0; break;
    case motionlcm::sim_control_t::REPLY_LATENCY: d.latency = std::chrono::microseconds(c.value); break;
    case motionlcm::sim_control_t::SET_INPUT:
      d.sim.set_input(static_cast<unsigned>(c.value - 1), c.level != 0, now);
      break;
    case motionlcm::sim_control_t::POWER_CYCLE:
      d.sim.power_cycle(now);
      report(d, motionlcm::sim_report_t::POWERED_UP, context_.utime_of(now), now);
      break;
    default: return false;
  }
  return true;
}

SerialDeviceFactory adam_line_factory() {
  return [](const config::Config& config, const config::Bus& bus,
            SerialDeviceContext context) -> std::unique_ptr<SerialDeviceSim> {
    return std::make_unique<AdamLineSim>(config, bus, std::move(context));
  };
}

std::unique_ptr<SerialLineHost> open_adam_line(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                               SerialLineHost::Reporter reporter, std::error_code& error) {
  return SerialLineHost::open(loop, config, bus, {{config::Family::kAdamModbus, adam_line_factory()}},
                              std::move(reporter), error);
}

}  // namespace motion::sim
