#include "motion/sim/can_bus_host.hpp"

#include <spdlog/spdlog.h>

#include <filesystem>

#include "motion/can/socketcan.hpp"
#include "motion/core/file_access.hpp"

namespace motion::sim {

CanBusHost::CanBusHost(EventLoop& loop, const config::Config& config, const config::Bus& bus, Reporter reporter)
    : loop_(loop), config_(config), bus_(bus), reporter_(std::move(reporter)) {}

CanBusHost::~CanBusHost() {
  for (auto& [name, d] : drives_) {
    loop_.cancel(d.timer);
    if (d.endpoint && d.endpoint->fd() >= 0) loop_.unwatch(d.endpoint->fd());
  }
}

std::unique_ptr<CanBusHost> CanBusHost::open(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                             const std::map<config::Family, CanDriveFactory>& factories,
                                             Reporter reporter, std::error_code& error) {
  std::unique_ptr<CanBusHost> host(new CanBusHost(loop, config, bus, std::move(reporter)));
  std::string why;
  const auto access = config::sim_file_access(config, &why);
  if (!access) {
    spdlog::error("simulated CAN bus {}: {}", bus.name, why);
    error = std::make_error_code(std::errc::invalid_argument);
    return nullptr;
  }
  simbus::HubOptions options;
  options.bus_name = bus.target;
  options.access = *access;
  options.socket_dir = config::sim_runtime_dir(config);
  // The folder is the owner's (0700; 0710 with simulation.group), set explicitly: not the umask's.
  if ((error = make_private_dir(options.socket_dir, options.access))) return nullptr;
  options.bus.bitrate = static_cast<std::uint32_t>(bus.bitrate);
  options.bus.timing = bus.bus_timing;
  host->hub_ = simbus::Hub::open(loop, options, error);
  if (!host->hub_) return nullptr;
  simbus::Hub& hub = *host->hub_;
  error = host->attach_drives(factories,
                              [&hub](const config::Drive& drive, std::error_code&) -> std::unique_ptr<can::Transport> {
                                return hub.attach_local("sim:" + drive.name);
                              });
  if (error) return nullptr;
  return host;
}

std::unique_ptr<CanBusHost> CanBusHost::open_socketcan(EventLoop& loop, const config::Config& config,
                                                       const config::Bus& bus,
                                                       const std::map<config::Family, CanDriveFactory>& factories,
                                                       Reporter reporter, std::error_code& error) {
  // One socket per drive: like separate nodes on the wire, each drive receives the frames of
  // the gateway and of the other drives (the kernel loops them back to every other socket on the
  // interface) but not its own (own echo off).
  const std::string interface = bus.target;
  const auto bitrate = static_cast<std::uint32_t>(bus.bitrate);
  return open_with(
      loop, config, bus, factories, std::move(reporter),
      [interface, bitrate](const config::Drive& drive, std::error_code& ec) -> std::unique_ptr<can::Transport> {
        auto transport = std::make_unique<can::SocketCanTransport>();
        can::SocketCanOptions options;
        options.bitrate = bitrate;
        ec = transport->open(interface, options);
        if (ec) return nullptr;
        transport->on_bus_event([name = drive.name](const can::BusEvent& event) {
          spdlog::warn("sim: drive {}: {} {}", name, can::to_string(event.state), event.text);
        });
        return transport;
      },
      error);
}

std::unique_ptr<CanBusHost> CanBusHost::open_with(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                                  const std::map<config::Family, CanDriveFactory>& factories,
                                                  Reporter reporter, const EndpointFactory& endpoints,
                                                  std::error_code& error) {
  std::unique_ptr<CanBusHost> host(new CanBusHost(loop, config, bus, std::move(reporter)));
  error = host->attach_drives(factories, endpoints);
  if (error) return nullptr;
  return host;
}

std::error_code CanBusHost::attach_drives(const std::map<config::Family, CanDriveFactory>& factories,
                                          const EndpointFactory& endpoints) {
  factories_ = factories;
  for (const auto& drive : config_.drives) {
    if (drive.bus != bus_.name) continue;
    auto factory = factories.find(drive.family);
    if (factory == factories.end()) {
      missing_.push_back(drive.name + " (" + std::string(config::to_string(drive.family)) + ")");
      continue;
    }
    std::error_code error;
    auto endpoint = endpoints(drive, error);
    if (!endpoint) return error ? error : std::make_error_code(std::errc::no_such_device);
    Drive& d = drives_[drive.name];
    d.config = &drive;
    d.latency = std::chrono::microseconds(config_.simulation.reply_latency_us);
    d.endpoint = std::move(endpoint);
    create(d, factory->second);
    if (auto* local = dynamic_cast<simbus::LocalEndpoint*>(d.endpoint.get())) {
      local->on_ready([this, &d] { on_readable(d); });  // no descriptor per simulated drive
    } else {
      loop_.watch(d.endpoint->fd(), [this, &d] { on_readable(d); });
    }
  }
  return {};
}

void CanBusHost::create(Drive& d, const CanDriveFactory& factory) {
  SimDriveContext ctx;
  ctx.drive = d.config->name;
  ctx.bus = bus_.name;
  ctx.send = [this, &d](const can::Frame& frame) {
    if (d.silent || d.corrupt) return;
    if (d.latency <= Duration::zero()) {
      transmit(d, frame);
      return;
    }
    loop_.call_after(d.latency, [this, &d, frame] {
      if (!d.silent && !d.corrupt) transmit(d, frame);
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

void CanBusHost::transmit(Drive& d, const can::Frame& frame) {
  const std::error_code error = d.endpoint->send(frame);
  if (error && !d.send_failed) {
    spdlog::warn("sim: drive {} cannot send on {}: {} (further send errors are not logged)", d.config->name,
                 d.endpoint->name(), error.message());
  }
  d.send_failed = d.send_failed || static_cast<bool>(error);
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
    if (c.action == motionlcm::sim_control_t::BUS_DROP && hub_) {
      // value N > 0: the next N frames vanish; 0 (or less): frames are no longer dropped (what is
      // left of every drop given before ends). On a bus where little is sent, N frames can take
      // minutes to pass: a fault meant to last a while is ended with value 0.
      if (c.value <= 0) {
        for (const simbus::FaultId id : drops_) hub_->clear_fault(id);
        drops_.clear();
        return true;
      }
      drops_.push_back(hub_->inject(simbus::Fault::drop(static_cast<std::uint64_t>(c.value))));
      return true;
    }
    if (c.action == motionlcm::sim_control_t::BUS_OFF && hub_) {
      const auto gateway = hub_->find_endpoint("gateway:" + bus_.name);
      if (!gateway) {
        spdlog::warn("sim: bus-off of bus {}: no gateway is attached to it", bus_.name);
        return false;
      }
      if (c.value <= 0) return hub_->recover(*gateway);
      spdlog::info("sim: the gateway of bus {} goes bus-off for {} ms", bus_.name, c.value);
      return hub_->set_bus_off(*gateway, std::chrono::milliseconds(c.value));
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
    case motionlcm::sim_control_t::REPLY_LATENCY: d.latency = std::chrono::microseconds(c.value); return true;
    case motionlcm::sim_control_t::CRC_ERRORS:
      // A frame failing the CAN CRC is discarded by every receiver (ISO 11898-1: CRC error, error frame) and
      // retransmitted; a node whose frames keep failing counts itself to error passive and then
      // bus-off. So the drive goes on executing what it receives, and nothing it sends arrives.
      d.corrupt = c.value != 0;
      spdlog::info("sim: drive {} {}", c.drive,
                   d.corrupt ? "sends frames that fail the CAN CRC" : "sends intact frames again");
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
