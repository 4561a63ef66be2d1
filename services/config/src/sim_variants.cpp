#include "motion/config/sim_variants.hpp"

#include <charconv>

namespace motion::config {
namespace {

// UIM342 manual §5.9 / §5.7: MT[0] and QE[4] "need to be powered off and restarted to take
// effect"; written while the driver is on they stay in RAM. Whether a drive also applies a RAM
// value at once is not said.
const std::vector<SimVariantKey> kUim342 = {
    {"micro_steps_apply",
     {"after_restart", "immediately"},
     0,
     0,
     "after_restart",
     "when a written MT[0] micro-step resolution takes effect"},
};

// UIM242 manual §5.1: an ICF write is burned into EEPROM "and the controller will auto reboot";
// how long the reboot takes is not said. STO (#42) takes about 20 ms.
const std::vector<SimVariantKey> kUim242 = {
    {"reboot_ms", {}, 0, 10000, "300", "how long the controller is silent after an ICF write (auto reboot)"},
    // §6.1 (PT mode), #37 SPD, #44 STP: no example loads a displacement at desired speed 0.
    {"spd0_position_move",
     {"holds", "runs_at_last_speed", "refused"},
     0,
     0,
     "holds",
     "STP at desired speed 0: held until a later SPD starts it, run at once at the last non-zero speed, or refused "
     "(EE 66)"},
};

// ADAM Modbus manual §8.44 (0x009A working speed), §8.64 (0x00D8 target speed), §8.65 (motion
// commands run at 0x009A), §8.54 (table data, "after sending ... send a save command"), §8.69
// (Save, 0x00DC: 0.1 s per flash erase).
const std::vector<SimVariantKey> kAdam = {
    {"table_speed_register",
     {"0x009A", "0x00D8", "shared"},
     0,
     0,
     "0x009A",
     "the register whose speed an executed table entry runs at (shared: one setpoint behind both)"},
    {"table_needs_save",
     {"false", "true"},
     0,
     0,
     "true",
     "whether table data written by Modbus is used only after a Save (0x00DC)"},
};

// UC57 manual §4.1.2 (SYNC: "assuming that the devices in the network support synchronous PDO
// function") and §5 (1400h:02 RPDO transmission type, RW/S, default FFh): whether a UC57 takes
// transmission type 1 and applies a synchronous RPDO at the next SYNC is not said.
const std::vector<SimVariantKey> kUc57 = {
    {"rpdo_sync",
     {"honoured", "on_reception", "refused"},
     0,
     0,
     "honoured",
     "RPDO transmission type 1: applied at the next SYNC, accepted but applied on reception, or refused by SDO abort"},
};

}  // namespace

std::span<const SimVariantKey> sim_variant_schema(Family family) {
  switch (family) {
    case Family::kUim342: return kUim342;
    case Family::kUc57: return kUc57;
    case Family::kAdamModbus: return kAdam;
    case Family::kUim242: return kUim242;
  }
  return {};
}

const SimVariantKey* find_sim_variant(Family family, std::string_view key) {
  for (const auto& k : sim_variant_schema(family)) {
    if (k.key == key) return &k;
  }
  return nullptr;
}

std::string sim_variant(const Config& config, const Drive& drive, std::string_view key) {
  if (const auto d = config.simulation.variants.find(drive.name); d != config.simulation.variants.end()) {
    if (const auto v = d->second.find(key); v != d->second.end()) return v->second;
  }
  const auto* k = find_sim_variant(drive.family, key);
  return k ? std::string(k->default_value) : std::string{};
}

long long sim_variant_int(const Config& config, const Drive& drive, std::string_view key) {
  const auto text = sim_variant(config, drive, key);
  long long value = 0;
  std::from_chars(text.data(), text.data() + text.size(), value);
  return value;
}

namespace {
// Built by appending: GCC 12 at -O3 reports a false -Wrestrict for "'" + std::string(...).
std::string quoted(std::string_view text) {
  std::string out;
  out.reserve(text.size() + 2);
  out += '\'';
  out += text;
  out += '\'';
  return out;
}
}  // namespace

namespace {

// Why `value` is not a value of `k` (empty when it is).
std::string value_error(const SimVariantKey& k, std::string_view value) {
  if (!k.choices.empty()) {
    std::string list;
    for (const auto c : k.choices) {
      if (c == value) return {};
      list += (list.empty() ? "" : ", ") + std::string(c);
    }
    return quoted(value) + " is not one of " + list;
  }
  long long number = 0;
  const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), number);
  if (ec != std::errc{} || end != value.data() + value.size() || number < k.min || number > k.max) {
    return quoted(value) + " is not an integer in " + std::to_string(k.min) + ".." + std::to_string(k.max);
  }
  return {};
}

std::string key_list(std::span<const SimVariantKey> schema) {
  std::string list;
  for (const auto& s : schema) list += (list.empty() ? "" : ", ") + std::string(s.key);
  return list.empty() ? std::string("none") : list;
}

const SimVariantKey* find_in(std::span<const SimVariantKey> schema, std::string_view key) {
  for (const auto& k : schema) {
    if (k.key == key) return &k;
  }
  return nullptr;
}

// UIM342 manual §2.6 / Appendix-1: the CRC of a UIMessage covers "0xAA ID CW ... d8, qty = 13";
// UIROBOT's own gateway software computes it over the 12 bytes ID..d8. The simulated UIM2513
// computes and checks it over `crc_bytes` and drops a frame whose CRC is wrong.
const std::vector<SimVariantKey> kUiMessageBus = {
    {"crc_bytes",
     {"13", "12"},
     0,
     0,
     "13",
     "the bytes the serial gateway's UIMessage CRC covers: 13 (SM..d8, the manual's text) or 12 (ID..d8)"},
};

}  // namespace

std::string sim_variant_error(Family family, std::string_view key, std::string_view value) {
  const auto* k = find_sim_variant(family, key);
  if (!k) {
    return quoted(key) + " is not a simulated variant of family " + std::string(to_string(family)) + " (" +
           key_list(sim_variant_schema(family)) + ")";
  }
  return value_error(*k, value);
}

std::span<const SimVariantKey> sim_bus_variant_schema(TransportKind kind) {
  if (kind == TransportKind::kUiMessage) return kUiMessageBus;
  return {};
}

std::string sim_bus_variant(const Config& config, const Bus& bus, std::string_view key) {
  if (const auto b = config.simulation.variants.find(bus.name); b != config.simulation.variants.end()) {
    if (const auto v = b->second.find(key); v != b->second.end()) return v->second;
  }
  const auto* k = find_in(sim_bus_variant_schema(bus.kind), key);
  return k ? std::string(k->default_value) : std::string{};
}

std::string sim_bus_variant_error(TransportKind kind, std::string_view key, std::string_view value) {
  const auto* k = find_in(sim_bus_variant_schema(kind), key);
  if (!k) {
    return quoted(key) + " is not a simulated variant of this bus (" + key_list(sim_bus_variant_schema(kind)) +
           "; only uimessage: buses have bus variants)";
  }
  return value_error(*k, value);
}

}  // namespace motion::config
