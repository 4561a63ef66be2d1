// The YAML configuration loader with its validation (services/config): any text is either a
// configuration or a list of errors, never a crash.
#include <string_view>

#include "fuzz_targets.hpp"
#include "motion/config/config.hpp"

namespace motion::fuzz {

int config_yaml(const std::uint8_t* data, std::size_t size) {
  (void)config::load_string(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.yaml");
  return 0;
}

}  // namespace motion::fuzz
