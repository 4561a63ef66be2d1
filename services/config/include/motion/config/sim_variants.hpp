// Per-drive behaviours of the simulated drives where a manual is silent or unclear
// (`simulation.variants: {DRIVE: {KEY: VALUE}}`, docs/protocols.md). One table per family: the
// key, its allowed values and its default (what the manual most likely describes). The config
// loader validates against it; motion-sim reads the values through sim_variant().
// Gateways never read these: they must work under every variant (detect, or use a set-up answer).
// Thread contract: pure functions over constant tables.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "motion/config/config.hpp"

namespace motion::config {

struct SimVariantKey {
  std::string_view key;
  std::vector<std::string_view> choices;  // empty: an integer in [min, max]
  long long min = 0;
  long long max = 0;
  std::string_view default_value;
  std::string_view meaning;
};

[[nodiscard]] std::span<const SimVariantKey> sim_variant_schema(Family family);
[[nodiscard]] const SimVariantKey* find_sim_variant(Family family, std::string_view key);
// The configured value of `key` for `drive`, else the family's default ("" for an unknown key).
[[nodiscard]] std::string sim_variant(const Config& config, const Drive& drive, std::string_view key);
// Same, as an integer (integer keys; 0 when not a number).
[[nodiscard]] long long sim_variant_int(const Config& config, const Drive& drive, std::string_view key);
// Why `value` is not a value of `key` (empty when it is).
[[nodiscard]] std::string sim_variant_error(Family family, std::string_view key, std::string_view value);

// Variants of a simulated bus rather than of a drive (`simulation.variants: {BUS: {KEY: VALUE}}`):
// the UIROBOT serial gateway of a uimessage: bus (crc_bytes). Empty for other transports.
[[nodiscard]] std::span<const SimVariantKey> sim_bus_variant_schema(TransportKind kind);
// The configured value of `key` for `bus`, else the default ("" for an unknown key).
[[nodiscard]] std::string sim_bus_variant(const Config& config, const Bus& bus, std::string_view key);
// Why `value` is not a value of the bus variant `key` of `kind` (empty when it is).
[[nodiscard]] std::string sim_bus_variant_error(TransportKind kind, std::string_view key, std::string_view value);

}  // namespace motion::config
