#include "motion/sim/uim242_gateway_sim.hpp"

#include "motion/config/sim_variants.hpp"

#include <algorithm>

#include "uim242_controller_sim.hpp"

namespace motion::sim {

using uim242::Frame;
using uim242::Header;
using uim242::Instruction;
using uim242::Mnemonic;

// ---- Gateway ---------------------------------------------------------------------------------

Uim242GatewaySim::Uim242GatewaySim(std::vector<Uim242ControllerSetup> controllers, Uim242SimContext context,
                                   Uim242SimOptions options)
    : context_(std::move(context)), options_(options) {
  for (auto& c : controllers) controllers_.push_back(std::make_unique<Controller>(std::move(c), options_, context_));
}

Uim242GatewaySim::~Uim242GatewaySim() = default;

std::vector<Uim242ControllerSetup> Uim242GatewaySim::controllers_of(const config::Config& config,
                                                                    const std::string& bus) {
  std::vector<Uim242ControllerSetup> out;
  for (const auto& d : config.drives) {
    if (d.bus != bus || d.family != config::Family::kUim242) continue;
    Uim242ControllerSetup setup;
    setup.drive = d.name;
    setup.node_id = static_cast<std::uint8_t>(d.node_id);
    setup.reboot = std::chrono::milliseconds(config::sim_variant_int(config, d, "reboot_ms"));
    const auto spd0 = config::sim_variant(config, d, "spd0_position_move");
    setup.spd0_position_move = spd0 == "refused"              ? Uim242ControllerSetup::Spd0Move::kRefused
                               : spd0 == "runs_at_last_speed" ? Uim242ControllerSetup::Spd0Move::kRunsAtLastSpeed
                                                              : Uim242ControllerSetup::Spd0Move::kHolds;
    setup.home_switch = home_switch(config, d);
    out.push_back(setup);
  }
  return out;
}

SerialDeviceFactory uim242_line_factory() {
  return [](const config::Config& config, const config::Bus& bus,
            const SerialDeviceContext& line) -> std::unique_ptr<SerialDeviceSim> {
    const Duration latency = std::chrono::microseconds(config.simulation.reply_latency_us);
    Uim242SimContext context;
    context.bus = bus.name;
    context.send = [send = line.send, latency](std::span<const std::uint8_t> bytes) { send(bytes, latency); };
    context.report = line.report;
    context.utime_of = line.utime_of;
    return std::make_unique<Uim242GatewaySim>(Uim242GatewaySim::controllers_of(config, bus.name), std::move(context));
  };
}

int Uim242GatewaySim::icf_writes(const std::string& drive) const {
  const auto* c = find_drive(drive);
  return c ? c->icf_writes() : 0;
}

void Uim242GatewaySim::power_up(TimePoint now) {
  selected_ = 5;
  splitter_.reset();
  if (options_.greet_on_power_up) send(uim242::make_greeting(options_.version));
  for (auto& c : controllers_) c->power_up(now);
}

TimePoint Uim242GatewaySim::receive(std::span<const std::uint8_t> bytes, TimePoint now) {
  process(now);  // arrivals before these bytes come first
  for (const auto& chunk : splitter_.push(bytes)) execute(chunk, now);
  return process(now);
}

TimePoint Uim242GatewaySim::process(TimePoint now) {
  TimePoint next = kNever;
  for (auto& c : controllers_) {
    for (const auto& f : c->process(now)) {
      if (c->heard()) send(f);
    }
    next = std::min(next, c->deadline());
    if (c->sampling()) next = std::min(next, now + std::chrono::milliseconds(1));
  }
  return next;
}

bool Uim242GatewaySim::control(const motionlcm::sim_control_t& control, TimePoint now) {
  process(now);  // arrivals before the fault come first
  Controller* c = find_drive(control.drive);
  if (!c) return false;
  std::vector<Frame> out;
  switch (control.action) {
    case motionlcm::sim_control_t::STALL: out = c->stall(now); break;
    case motionlcm::sim_control_t::SET_INPUT:
      if (control.value < 1 || control.value > 3) return false;
      out = c->set_input(control.value, control.level != 0, now);
      break;
    case motionlcm::sim_control_t::SILENCE: c->set_silent(control.value != 0); return true;
    case motionlcm::sim_control_t::POWER_CYCLE: c->power_up(now); return true;
    case motionlcm::sim_control_t::CRC_ERRORS: c->set_corrupt(control.value != 0); return true;
    default: return false;
  }
  if (c->heard()) {
    for (const auto& f : out) send(f);
  }
  return true;
}

std::int64_t Uim242GatewaySim::position(const std::string& drive, TimePoint now) const {
  const Controller* c = find_drive(drive);
  return c ? c->position(now) : 0;
}
std::int64_t Uim242GatewaySim::physical_position(const std::string& drive, TimePoint now) const {
  const Controller* c = find_drive(drive);
  return c ? c->physical_position(now) : 0;
}
bool Uim242GatewaySim::moving(const std::string& drive, TimePoint now) const {
  const Controller* c = find_drive(drive);
  return c && c->moving(now);
}
bool Uim242GatewaySim::enabled(const std::string& drive) const {
  const Controller* c = find_drive(drive);
  return c && c->enabled();
}

Uim242GatewaySim::Controller* Uim242GatewaySim::find_node(int node) const {
  for (const auto& c : controllers_) {
    if (c->node() == node) return c.get();
  }
  return nullptr;
}

Uim242GatewaySim::Controller* Uim242GatewaySim::find_drive(const std::string& drive) const {
  for (const auto& c : controllers_) {
    if (c->drive() == drive) return c.get();
  }
  return nullptr;
}

void Uim242GatewaySim::send(const Frame& frame) {
  if (!context_.send) return;
  const auto bytes = uim242::serialize(frame);
  context_.send(bytes);
}

void Uim242GatewaySim::execute(const uim242::InstructionChunk& chunk, TimePoint now) {
  // Errors are never silent, not even inside a macro (EN/CN §2.3 do not say: assumed).
  if (chunk.oversize) {
    send(uim242::make_error(uim242::ErrorCode::kSyntaxError));
    return;
  }
  const auto parsed = uim242::parse_instruction(chunk.text);
  if (!parsed) {
    send(uim242::make_error(static_cast<uim242::ErrorCode>(parsed.error().value())));
    return;
  }
  const Instruction& in = *parsed;
  if (in.global || uim242::spec(in.mnemonic).target == uim242::Target::kGateway) {
    execute_gateway(in, now);
    return;
  }
  // MDL names its controller in the value (#22); everything else goes to the selected target.
  const int node = in.mnemonic == Mnemonic::kMDL && in.value ? static_cast<int>(*in.value) : selected_;
  Controller* c = find_node(node);
  if (!c || c->asleep(now)) return;  // nobody answers: the host times out
  for (const auto& f : c->execute(in, now, !chunk.silent)) {
    if ((f.header == Header::kError || !chunk.silent) && c->heard()) send(f);
  }
}

void Uim242GatewaySim::execute_gateway(const Instruction& in, TimePoint now) {
  const auto quantity = static_cast<std::uint8_t>(
      std::count_if(controllers_.begin(), controllers_.end(), [](const auto& c) { return !c->silent(); }));
  const auto form = uim242::reply_form(in, options_.org_reply);
  if (in.global) {
    if (in.mnemonic == Mnemonic::kREG) {
      std::array<std::int64_t, 8> ids{};
      std::size_t n = 0;
      for (const auto& c : controllers_) {
        if (!c->silent() && n < ids.size()) ids[n++] = c->node();
      }
      send(uim242::make_reply(form, quantity, ids));
      return;
    }
    Instruction local = in;
    local.global = false;
    for (auto& c : controllers_) {
      if (!c->silent()) (void)c->execute(local, now, false);
    }
    send(uim242::make_reply(form, quantity, {}));
    return;
  }
  switch (in.mnemonic) {
    case Mnemonic::kADR:
      selected_ = static_cast<int>(*in.value);
      send(uim242::make_reply(form, static_cast<std::uint8_t>(selected_), {}));
      return;
    case Mnemonic::kSET:
      // Only with a single controller wired (EN/CN §3.1); otherwise nobody answers.
      if (controllers_.size() != 1) return;
      controllers_.front()->set_node(static_cast<std::uint8_t>(*in.value));
      send(uim242::make_reply(form, controllers_.front()->node(), {}));
      return;
    case Mnemonic::kBTR: send(uim242::make_reply(form, static_cast<std::uint8_t>(in.value.value_or(0)), {})); return;
    case Mnemonic::kBDR: send(uim242::make_reply(form, 0, {})); return;
    case Mnemonic::kABC: send(uim242::make_greeting(options_.version)); return;
    default: return;
  }
}

}  // namespace motion::sim
