#include "bus_assembly.hpp"

#include <spdlog/spdlog.h>

#include <functional>
#include <map>

#include "motion/adam_driver/adam_bus_driver.hpp"
#include "motion/gateway/can_bus_driver.hpp"
#include "motion/gateway/can_transport_factory.hpp"
#include "motion/uc57_driver/uc57_stack.hpp"
#include "motion/uim242_driver/uim242_bus_driver.hpp"
#include "motion/uim342_driver/uim342_stack.hpp"

namespace motion::gateway {
namespace {

using CanStackFactory =
    std::function<std::unique_ptr<CanStack>(const config::Config&, const config::Bus&, CanStackContext)>;

// The protocol stacks a CAN bus can carry, by drive family. Each family's issue adds its line.
const std::map<config::Family, CanStackFactory>& can_stack_factories() {
  static const std::map<config::Family, CanStackFactory> factories{
      {config::Family::kUim342,
       [](const config::Config& config, const config::Bus& bus, CanStackContext context) -> std::unique_ptr<CanStack> {
         return std::make_unique<Uim342Stack>(config, bus.name, std::move(context));
       }},
      {config::Family::kUc57,
       [](const config::Config& config, const config::Bus& bus, CanStackContext context) -> std::unique_ptr<CanStack> {
         return std::make_unique<uc57_driver::Uc57Stack>(config, bus, std::move(context));
       }},
  };
  return factories;
}

std::map<config::Family, std::vector<const config::Drive*>> drives_by_family(const config::Config& config,
                                                                             const config::Bus& bus) {
  std::map<config::Family, std::vector<const config::Drive*>> out;
  for (const auto& drive : config.drives) {
    if (drive.bus == bus.name) out[drive.family].push_back(&drive);
  }
  return out;
}

void list_unsupported(const std::vector<const config::Drive*>& drives, std::vector<const config::Drive*>& out) {
  out.insert(out.end(), drives.begin(), drives.end());
}

BusAssembly assemble_can_bus(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                             GatewayOutput& out) {
  BusAssembly result;
  auto transport = open_can_transport(config, bus, "gateway:" + bus.name, result.error);
  if (!transport) {
    result.error_text = open_error_message(config, bus, result.error);
    return result;
  }
  auto driver = std::make_unique<CanBusDriver>(loop, bus.name, std::move(transport), out);
  driver->set_timer_spin(std::chrono::microseconds(bus.timer_spin_us));
  std::error_code cyclic_error;
  if (auto cyclic = open_cyclic_sender(bus, cyclic_error)) {
    driver->use_cyclic(std::move(cyclic));
  } else if (cyclic_error) {
    spdlog::warn("bus {}: kernel_sync: no CAN_BCM socket ({}); the gateway's loop sends the periodic SYNC", bus.name,
                 cyclic_error.message());
  }
  for (const auto& [family, drives] : drives_by_family(config, bus)) {
    const auto factory = can_stack_factories().find(family);
    if (factory == can_stack_factories().end()) {
      list_unsupported(drives, result.unsupported);
      continue;
    }
    driver->add_stack(factory->second(config, bus, driver->context()));
  }
  result.driver = std::move(driver);
  return result;
}

using SerialDriverFactory =
    std::function<std::unique_ptr<BusDriver>(EventLoop&, const config::Config&, const config::Bus&, GatewayOutput&)>;

// The serial bus drivers, by drive family. Each family's issue adds its line.
const std::map<config::Family, SerialDriverFactory>& serial_driver_factories() {
  static const std::map<config::Family, SerialDriverFactory> factories{
      {config::Family::kAdamModbus,
       [](EventLoop& loop, const config::Config& config, const config::Bus& bus, GatewayOutput& out)
           -> std::unique_ptr<BusDriver> { return adam_driver::AdamBusDriver::create(loop, config, bus, out); }},
      {config::Family::kUim242,
       [](EventLoop& loop, const config::Config& config, const config::Bus& bus, GatewayOutput& out)
           -> std::unique_ptr<BusDriver> { return uim242_driver::Uim242BusDriver::create(loop, config, bus, out); }},
  };
  return factories;
}

// A serial line carries one family (its own framing): the first family's driver serves the
// line, drives of any other family on it are unsupported.
BusAssembly assemble_serial_bus(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                GatewayOutput& out) {
  BusAssembly result;
  for (const auto& [family, drives] : drives_by_family(config, bus)) {
    const auto factory = serial_driver_factories().find(family);
    if (!result.driver && factory != serial_driver_factories().end()) {
      result.driver = factory->second(loop, config, bus, out);
      continue;
    }
    list_unsupported(drives, result.unsupported);
  }
  return result;
}

}  // namespace

BusAssembly assemble_bus(EventLoop& loop, const config::Config& config, const config::Bus& bus, GatewayOutput& out) {
  if (config::is_can(bus.kind)) return assemble_can_bus(loop, config, bus, out);
  return assemble_serial_bus(loop, config, bus, out);
}

}  // namespace motion::gateway
