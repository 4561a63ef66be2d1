#include "motion/core/clock.hpp"
#include "motionctl.hpp"

#include <nlohmann/json.hpp>

#include <iostream>
#include <map>

#include <motionlcm/health_t.hpp>

#include "motion/lcm/channels.hpp"
#include "motion/lcm/message_names.hpp"

namespace motion::ctl {

void add_health_command(CLI::App& cli, Context& ctx) {
  auto* cmd = cli.add_subcommand("health", "List live processes from their heartbeats");
  auto opts = std::make_shared<std::pair<double, std::vector<std::string>>>(1.5, std::vector<std::string>{});
  cmd->add_option("--listen", opts->first, "Seconds to listen for heartbeats")->capture_default_str();
  cmd->add_option("--expect", opts->second,
                  "Process names that must be heard (exit 4 otherwise); listening ends when all are heard");
  cmd->callback([&ctx, opts] {
    ctx.result = ctx.with_node([&](app::Service& service) -> int {
      std::map<std::string, motionlcm::health_t> seen;
      auto all_expected = [&] {
        if (opts->second.empty()) return false;
        for (const auto& name : opts->second) {
          if (!seen.contains(name)) return false;
        }
        return true;
      };
      service.node().subscribe<motionlcm::health_t>(lcm::channels::kHealth,
                                                    [&](const motionlcm::health_t& h, const std::string&) {
                                                      if (h.role != "client") seen[h.process] = h;
                                                      if (all_expected()) service.loop().stop();
                                                    });
      service.loop().call_after(std::chrono::duration_cast<Duration>(std::chrono::duration<double>(opts->first)),
                                [&] { service.loop().stop(); });
      service.loop().run();

      if (ctx.json) {
        nlohmann::json out = nlohmann::json::array();
        for (const auto& [name, h] : seen) {
          nlohmann::json buses = nlohmann::json::array();
          for (const auto& b : h.buses) {
            buses.push_back({{"name", b.name},
                             {"transport", b.transport},
                             {"state", b.state},
                             {"tx_frames", b.tx_frames},
                             {"rx_frames", b.rx_frames},
                             {"errors", b.errors},
                             {"timeouts", b.timeouts},
                             {"bus_load", b.bus_load},
                             {"drives_online", b.drives_online},
                             {"drives_total", b.drives_total}});
          }
          out.push_back({{"process", name},
                         {"role", h.role},
                         {"host", h.host},
                         {"pid", h.pid},
                         {"state", lcm::health_state_name(h.state)},
                         {"detail", h.detail},
                         {"uptime_s", h.uptime_s},
                         {"version", h.version},
                         {"buses", buses},
                         {"age_s", static_cast<double>(wall_time_us() - h.utime) / 1e6}});  // since its last heartbeat
        }
        std::cout << out.dump(2) << "\n";
      } else {
        std::printf("%-22s %-12s %-10s %-16s %8s %9s  %s\n", "PROCESS", "ROLE", "STATE", "HOST", "PID", "UPTIME",
                    "DETAIL");
        for (const auto& [name, h] : seen) {
          std::printf("%-22s %-12s %-10s %-16s %8d %8.1fs  %s\n", name.c_str(), h.role.c_str(),
                      lcm::health_state_name(h.state), h.host.c_str(), h.pid, h.uptime_s, h.detail.c_str());
          for (const auto& b : h.buses) {
            std::printf(
                "    bus %-10s %-22s %-14s tx %-8lld rx %-8lld err %-5lld timeouts %-5lld load %5.1f%%  drives %d/%d\n",
                b.name.c_str(), b.transport.c_str(), b.state.c_str(), static_cast<long long>(b.tx_frames),
                static_cast<long long>(b.rx_frames), static_cast<long long>(b.errors),
                static_cast<long long>(b.timeouts), 100.0 * b.bus_load, b.drives_online, b.drives_total);
          }
        }
        if (seen.empty())
          std::printf("(no heartbeat heard in %.1f s on %s)\n", opts->first, service.node().url().c_str());
      }
      for (const auto& name : opts->second) {
        if (!seen.contains(name)) {
          std::cerr << "motionctl: no heartbeat from '" << name << "'\n";
          return app::kExitUnavailable;
        }
      }
      return seen.empty() ? app::kExitUnavailable : app::kExitOk;
    });
  });
}

}  // namespace motion::ctl
