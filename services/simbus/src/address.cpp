#include "motion/simbus/address.hpp"

#include <algorithm>
#include <cstdlib>
#include <string>

namespace motion::simbus {

std::filesystem::path default_socket_dir() {
  for (const char* variable : {"MOTION_SIM_DIR", "XDG_RUNTIME_DIR"}) {
    const char* value = std::getenv(variable);
    if (value != nullptr && *value != '\0') return value;
  }
  return "/tmp";
}

bool valid_bus_name(std::string_view name) {
  return !name.empty() && name.size() <= 64 && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '.' ||
           c == '-';
  });
}

std::filesystem::path socket_path(std::string_view bus_name, const std::filesystem::path& dir) {
  const std::filesystem::path base = dir.empty() ? default_socket_dir() : dir;
  return base / ("motion-simbus-" + std::string(bus_name) + ".sock");
}

}  // namespace motion::simbus
