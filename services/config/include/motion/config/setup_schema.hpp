// Per-family drive set-up keys (the `setup:` map of a drive): what the gateway applies at
// start-up so nobody needs the vendor's Windows tool. One table per family; the config loader
// validates against it and the family drivers read the same keys.
#pragma once

#include <span>
#include <string_view>
#include <vector>

#include "motion/config/config.hpp"

namespace motion::config {

enum class SetupType { kBool, kInt, kNumber, kChoice };

struct SetupKey {
  std::string_view key;
  SetupType type;
  double min = 0;  // kInt/kNumber inclusive range
  double max = 0;
  std::vector<long long> allowed_ints;    // kInt: when non-empty, the only values accepted
  std::vector<std::string_view> choices;  // kChoice
  std::string_view meaning;
};

[[nodiscard]] std::span<const SetupKey> setup_schema(Family family);
[[nodiscard]] const SetupKey* find_setup_key(Family family, std::string_view key);

}  // namespace motion::config
