// The shipped lab (the embedded default configuration), loaded once: the web view's unit tests
// name its axes.
#pragma once

#include <stdexcept>

#include "motion/config/config.hpp"

namespace motion::web::testing {

inline const config::Config& lab() {
  static const config::Config config = [] {
    auto loaded = config::load_file(config::default_config_path());
    if (!loaded.ok()) throw std::runtime_error(loaded.error_text());
    return *loaded.config;
  }();
  return config;
}

}  // namespace motion::web::testing
