#include "motion/sim/uimessage_gateway_sim.hpp"

#include "motion/config/sim_variants.hpp"
#include "motion/sim/uim342_drive.hpp"
#include "motion/uim342/message.hpp"

namespace motion::sim {
namespace {

uim342::CrcAcceptance strict(uim342::CrcCoverage crc) {
  return crc == uim342::CrcCoverage::kIdToAux ? uim342::CrcAcceptance::kIdToAux : uim342::CrcAcceptance::kStartToAux;
}

}  // namespace

UiMessageGatewaySim::UiMessageGatewaySim(const config::Config& config, const config::Bus& bus,
                                         SerialDeviceContext context, const CanDriveFactory& drives,
                                         uim342::CrcCoverage crc)
    : context_(std::move(context)),
      crc_(crc),
      reply_latency_(std::chrono::microseconds(config.simulation.reply_latency_us)),
      from_host_(strict(crc)) {
  for (const auto& d : config.drives) {
    if (d.bus != bus.name || d.family != config::Family::kUim342) continue;
    SimDriveContext drive_context;
    drive_context.drive = d.name;
    drive_context.bus = bus.name;
    drive_context.send = [this](const can::Frame& frame) { to_host(frame); };
    drive_context.report = [this, name = d.name](std::int8_t kind, std::int64_t frame_utime, std::int64_t position,
                                                 std::int64_t target) {
      if (context_.report) context_.report(name, kind, frame_utime, position, target);
    };
    drives_.push_back({d.name, drives(d, std::move(drive_context))});
  }
}

void UiMessageGatewaySim::power_up(TimePoint now) {
  for (auto& d : drives_) d.sim->power_up(now);
}

void UiMessageGatewaySim::to_host(const can::Frame& frame) {
  const auto message = uim342::decode_can(frame);
  if (!message) return;  // not SimpleCAN: a UIMessage cannot carry it
  const auto bytes = uim342::encode_ui_message(uim342::drive_message_to_ui(*message), crc_);
  if (bytes) context_.send(*bytes, reply_latency_);
}

TimePoint UiMessageGatewaySim::receive(std::span<const std::uint8_t> bytes, TimePoint now) {
  from_host_.feed(bytes);
  while (const auto decoded = from_host_.next()) {
    const auto frame = uim342::encode_can(uim342::instruction_from_ui(decoded->message));
    if (!frame) continue;
    can::Frame stamped = *frame;
    stamped.timestamp_us = context_.utime_of ? context_.utime_of(now) : 0;
    ++passed_;
    for (auto& d : drives_) d.sim->on_frame(stamped, now);
  }
  return process(now);
}

TimePoint UiMessageGatewaySim::process(TimePoint now) {
  TimePoint next = kNever;
  for (auto& d : drives_) next = std::min(next, d.sim->process(now));
  return next;
}

bool UiMessageGatewaySim::control(const motionlcm::sim_control_t& control, TimePoint now) {
  for (auto& d : drives_) {
    if (d.name == control.drive) return d.sim->control(control, now);
  }
  return false;
}

uim342::CrcCoverage uimessage_sim_crc(const config::Config& config, const config::Bus& bus) {
  return config::sim_bus_variant(config, bus, "crc_bytes") == "12" ? uim342::CrcCoverage::kIdToAux
                                                                   : uim342::CrcCoverage::kStartToAux;
}

SerialDeviceFactory uimessage_gateway_factory(const config::Config& config) {
  return [drives = uim342_factory(config)](const config::Config& cfg, const config::Bus& bus,
                                           SerialDeviceContext context) -> std::unique_ptr<SerialDeviceSim> {
    return std::make_unique<UiMessageGatewaySim>(cfg, bus, std::move(context), drives, uimessage_sim_crc(cfg, bus));
  };
}

}  // namespace motion::sim
