#include "motion/sim/can_bus_host.hpp"

#include <spdlog/spdlog.h>

#include <filesystem>

namespace motion::sim {

CanBusHost::CanBusHost(EventLoop& loop, const config::Config& config, const config::Bus& bus, Reporter reporter)
    : loop_(loop), config_(config), bus_(bus), reporter_(std::move(reporter)) {}

CanBusHost::~CanBusHost() {
  for (auto& [name, d] : drives_) {
    loop_.cancel(d.timer);
    if (d.endpoint) loop_.unwatch(d.endpoint->fd());
  }
}

std::unique_ptr<CanBusHost> CanBusHost::open(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                             const std::map<config::Family, CanDriveFactory>& factories, Reporter reporter,
                                             std::error_code& error) {
  std::unique_ptr<CanBusHost> host(new CanBusHost(loop, config, bus, std::move(reporter)));
  simbus::HubOptions options;
  options.bus_name = bus.target;
  options.socket_dir = config::sim_runtime_dir(config);
  std::filesystem::create_directories(options.socket_dir, error);
  if (error) return nullptr;
  options.bus.bitrate = static_cast<std::uint32_t>(bus.bitrate);
  options.bus.timing = bus.bus_timing;
  host->hub_ = simbus::Hub::open(loop, options, error);
  if (!host->hub_) return nullptr;
  host->factories_ = factories;
  for (const auto& drive : config.drives) {
    if (drive.bus != bus.name) continue;
    auto factory = factories.find(drive.family);
    if (factory == factories.end()) {
      host->missing_.push_back(drive.name + " (" + std::string(config::to_string(drive.family)) + ")");
      continue;
    }
    Drive& d = host->drives_[drive.name];
    d.config = &drive;
    d.latency = std::chrono::microseconds(config.simulation.reply_latency_us);
    d.endpoint = host->hub_->attach_local("sim:" + drive.name);
    host->create(d, factory->second);
    CanBusHost* self = host.get();
    loop.watch(d.endpoint->fd(), [self, &d] { self->on_readable(d); });
  }
  return host;
}

void CanBusHost::create(Drive& d, const CanDriveFactory& factory) {
  SimDriveContext ctx;
  ctx.drive = d.config->name;
  ctx.bus = bus_.name;
  ctx.send = [this, &d](const can::Frame& frame) {
    if (d.silent) return;
    if (d.latency <= Duration::zero()) {
      d.endpoint->send(frame);
      return;
    }
    loop_.call_after(d.latency, [&d, frame] {
      if (!d.silent) d.endpoint->send(frame);
    });
  };
  ctx.report = [this, &d](std::int8_t kind, std::int64_t frame_utime, std::int64_t position, std::int64_t target) {
    motionlcm::sim_report_t r{};
    r.utime = wall_time_us();
    r.drive = d.config->name;
    r.bus = bus_.name;
    r.kind = kind;
    r.frame_utime = frame_utime;
    r.position_counts = position;
    r.target_counts = target;
    reporter_(std::move(r));
  };
  d.sim = factory(*d.config, std::move(ctx));
  d.sim->power_up(loop_.now());
  reschedule(d);
}

void CanBusHost::on_readable(Drive& d) {
  while (auto frame = d.endpoint->receive()) {
    if (d.silent) continue;
    d.sim->on_frame(*frame, loop_.now());
  }
  reschedule(d);
}

void CanBusHost::reschedule(Drive& d) {
  loop_.cancel(d.timer);
  const TimePoint next = d.sim->process(loop_.now());
  if (next == kNever) return;
  d.timer = loop_.call_at(next, [this, &d] { reschedule(d); });
}

bool CanBusHost::control(const motionlcm::sim_control_t& c) {
  if (c.drive.empty()) {
    if (c.bus != bus_.name) return false;
    if (c.action == motionlcm::sim_control_t::BUS_DROP) {
      hub_->inject(simbus::Fault::drop(static_cast<std::uint64_t>(std::max(0, c.value))));
      return true;
    }
    return false;
  }
  auto it = drives_.find(c.drive);
  if (it == drives_.end()) return false;
  Drive& d = it->second;
  switch (c.action) {
    case motionlcm::sim_control_t::SILENCE:
      d.silent = c.value != 0;
      spdlog::info("sim: drive {} {}", c.drive, d.silent ? "silenced" : "answers again");
      return true;
    case motionlcm::sim_control_t::REPLY_LATENCY:
      d.latency = std::chrono::microseconds(c.value);
      return true;
    case motionlcm::sim_control_t::POWER_CYCLE:
      spdlog::info("sim: power-cycling drive {}", c.drive);
      create(d, factories_.at(d.config->family));
      return true;
    default: {
      const bool ok = d.sim->control(c, loop_.now());
      reschedule(d);
      return ok;
    }
  }
}

}  // namespace motion::sim
