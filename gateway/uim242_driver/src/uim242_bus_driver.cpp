#include "motion/uim242_driver/uim242_bus_driver.hpp"

#include <utility>

#include "motion/gateway/serial_line.hpp"
#include "motion/uim242_driver/uim242_stack.hpp"

namespace motion::uim242_driver {

Uim242BusDriver::Uim242BusDriver(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                 gateway::GatewayOutput& out)
    : SerialBusDriver(
          loop, bus.name, gateway::serial_device_path(config, bus), gateway::serial_line_settings(bus), out,
          [&loop, &config, &bus, &out](Write write) {
            CoreContext context;
            // A lost write is not retried here: the request times out and is retried
            // or failed by the core's channel, naming drive, node and instruction.
            context.send = [write = std::move(write)](std::span<const std::uint8_t> bytes) { (void)write(bytes); };
            context.out = &out;
            // Loop time -> wall clock (trigger and sample utimes on LCM).
            context.utime_of = [&loop](TimePoint t) {
              return wall_time_us() - std::chrono::duration_cast<std::chrono::microseconds>(loop.now() - t).count();
            };
            return std::make_unique<Uim242Stack>(config, bus.name, std::move(context));
          }) {}

std::unique_ptr<Uim242BusDriver> Uim242BusDriver::create(EventLoop& loop, const config::Config& config,
                                                         const config::Bus& bus, gateway::GatewayOutput& out) {
  return std::make_unique<Uim242BusDriver>(loop, config, bus, out);
}

}  // namespace motion::uim242_driver
