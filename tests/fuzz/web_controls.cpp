// The web page's commands (services/web controls.hpp): any text a browser sends over the
// WebSocket is either a request for the coordinator or an error that names what was wrong, never a
// crash. The lab is a small fixed configuration; the access token is the one the seeds carry.
#include <string_view>

#include "fuzz_targets.hpp"
#include "motion/config/config.hpp"
#include "motion/web/controls.hpp"

namespace motion::fuzz {
namespace {

constexpr std::string_view kLab = R"(lcm: {url: "udpm://239.255.76.67:7667?ttl=0"}
buses:
  - {name: can0, transport: "simcan:can0", bitrate: 500000}
drives:
  - {name: x-drive, family: uim342, bus: can0, node_id: 5}
  - {name: a-drive, family: uc57, bus: can0, node_id: 1}
axes:
  - {name: x, drive: x-drive, unit: mm, steps_per_unit: 640, limits: {min: -10, max: 300, velocity: 50, acceleration: 400}}
  - {name: a, drive: a-drive, unit: deg, steps_per_unit: 8.8888889, limits: {min: -720, max: 720, velocity: 360, acceleration: 1440}}
)";
constexpr std::string_view kToken = "00112233445566778899aabbccddeeff";

const config::Config& lab() {
  static const config::Config config = [] {
    auto loaded = config::load_string(kLab, "fuzz-web.yaml");
    if (!loaded.ok()) __builtin_trap();  // the fixed lab must load
    return *loaded.config;
  }();
  return config;
}

}  // namespace

int web_controls(const std::uint8_t* data, std::size_t size) {
  (void)web::parse_control(std::string_view(reinterpret_cast<const char*>(data), size), lab(), kToken);
  return 0;
}

}  // namespace motion::fuzz
