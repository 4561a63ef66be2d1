// motionctl commission BUS: reads back, per drive of the bus, the set-up values whose meaning the
// manuals leave to the drive (docs/protocols.md), says what it found and what the gateway will do
// about it, and which simulated variant stays unknowable from reads. Moves nothing. Exit 1 when
// something the drive reports contradicts the configuration (the gateway's set-up has run, so a
// difference did not take hold), 4 when a drive does not answer. Requests go through the coordinator (PARAM_READ), so the gateway of the
// bus and the coordinator must run.
#include "motionctl.hpp"

#include <unistd.h>

#include <nlohmann/json.hpp>

#include <iostream>
#include <optional>

#include <motionlcm/param_t.hpp>
#include <motionlcm/reply_t.hpp>

namespace motion::ctl {
namespace {

using motionlcm::param_t;
using motionlcm::reply_t;

struct Check {
  std::string what;            // "MT[0] micro-steps"
  param_t param;
  std::optional<long long> expected;
  long long mask = -1;         // bits that exist (UIM242 ICFG 15..4 read 0)
  std::string if_different;    // what set-up does about a difference
};

param_t uim342(int function, int sub) {
  param_t p{};
  p.space = param_t::UIM342_INSTRUCTION;
  p.index = function;
  p.subindex = sub;
  return p;
}
param_t uim242(const std::string& mnemonic) {
  param_t p{};
  p.space = param_t::UIM242_INSTRUCTION;
  p.mnemonic = mnemonic;
  p.subindex = -1;
  return p;
}
param_t modbus(int reg, int width) {
  param_t p{};
  p.space = param_t::MODBUS_REGISTER;
  p.index = reg;
  p.subindex = -1;
  p.width = static_cast<std::int8_t>(width);
  return p;
}

// The checks of one drive and the notes on what reads cannot tell (docs/protocols.md).
std::pair<std::vector<Check>, std::vector<std::string>> checks_of(const config::Drive& d) {
  std::vector<Check> checks;
  std::vector<std::string> notes;
  switch (d.family) {
    case config::Family::kUim342: {
      constexpr int kPP = 0x01, kMT = 0x10, kQE = 0x3D;  // SimpleCAN 3.0 function codes (UIM342 manual §5)
      const auto steps = d.setup_integer("micro_steps");
      checks.push_back({"MT[0] micro-steps", uim342(kMT, 0), steps, -1, "set-up stores it with the driver off and restarts (SY[1])"});
      checks.push_back({"QE[4] counts/rev", uim342(kQE, 4), steps ? std::optional<long long>(*steps * 200) : std::nullopt, -1,
                        "set-up stores it with MT[0] and restarts"});
      if (d.group_id != 0) checks.push_back({"PP[8] group id", uim342(kPP, 8), d.group_id, -1, "set-up writes PP[8] and restarts"});
      notes.push_back("micro_steps_apply: not readable (a value written while the driver was on reads back but applies only after a "
                      "restart); power-cycle once after commissioning to be sure");
      break;
    }
    case config::Family::kUim242: {
      const auto icfg = d.setup_integer("icfg");
      checks.push_back({"ICFG", uim242("ICF"), icfg ? std::optional<long long>(*icfg & 0xF) : std::nullopt, 0xF,
                        "set-up writes ICF once and waits out the auto reboot"});
      checks.push_back({"MCS micro-steps", uim242("MCS"), d.setup_integer("micro_steps"), -1, "set-up writes MCS"});
      notes.push_back("reboot_ms: set-up waits for the controller to answer after an ICF write (up to 5 s)");
      notes.push_back("move start (SPD 0; STP n; gSPD v): not checked without moving");
      break;
    }
    case config::Family::kAdamModbus: {
      std::optional<long long> ppr = d.setup_integer("pulses_per_revolution");
      if (!ppr) {
        if (const auto sub = d.setup_integer("subdivision")) ppr = *sub * 200;
      }
      checks.push_back({"0x0024 pulses/rev", modbus(0x0024, 2), ppr, -1, "set-up writes 0x0024"});
      checks.push_back({"0x009A working speed (rpm)", modbus(0x009A, 1), std::nullopt, -1, "the next move writes it"});
      notes.push_back(std::string("table_save: ") + (d.setup_flag("table_save").value_or(true) ? "true" : "false") +
                      " (whether the drive runs unsaved table data is not readable; true is right either way)");
      notes.push_back("table_speed_register: not needed, the gateway writes 0x009A and 0x00D8");
      break;
    }
    case config::Family::kUc57: {
      param_t p{};
      p.space = param_t::CANOPEN_OBJECT;
      p.index = 0x2006;
      p.subindex = 0;
      checks.push_back({"2006h resolution code", p, std::nullopt, -1, "the drive model carries what it reads"});
      notes.push_back("rpdo_sync: not yet checked (docs/protocols.md)");
      break;
    }
  }
  return {checks, notes};
}

}  // namespace

void add_commission_command(CLI::App& cli, Context& ctx) {
  auto* cmd = cli.add_subcommand("commission", "Read back each drive's set-up on a bus and say what the manuals leave open (moves nothing)");
  auto bus = std::make_shared<std::string>();
  cmd->add_option("bus", *bus, "Bus name from the configuration")->required();
  cmd->callback([&ctx, bus] {
    ctx.result = ctx.with_node([&](app::Service& service) -> int {
      const auto& cfg = service.config();
      if (cfg.find_bus(*bus) == nullptr) {
        std::cerr << "motionctl: no bus '" << *bus << "' in the configuration\n";
        return app::kExitUsage;
      }
      client::Client client(service.loop(), service.node(), "motionctl-" + std::to_string(::getpid()));
      if (!ctx.sign_requests(client, service.config())) return ctx.result;
      int result = app::kExitOk;
      nlohmann::json out = nlohmann::json::array();
      for (const auto& d : cfg.drives) {
        if (d.bus != *bus) continue;
        const config::Axis* axis = nullptr;
        for (const auto& a : cfg.axes) {
          if (a.drive == d.name) axis = &a;
        }
        nlohmann::json jd{{"drive", d.name}, {"family", config::to_string(d.family)}, {"node_id", d.node_id}};
        if (!ctx.json) std::cout << d.name << " (" << config::to_string(d.family) << ", node " << d.node_id << ")\n";
        if (axis == nullptr) {
          if (!ctx.json) std::cout << "  no axis uses it: not checked\n";
          continue;
        }
        const auto [checks, notes] = checks_of(d);
        for (const auto& c : checks) {
          auto request = client::Client::make(std::int8_t{motionlcm::request_t::PARAM_READ}, std::vector<std::string>{axis->name});
          request.param = c.param;
          const reply_t r = client.call(request, std::chrono::seconds(5));
          nlohmann::json jc{{"check", c.what}};
          std::string line;
          if (r.status != reply_t::DONE) {
            line = "no answer: " + r.reason;
            jc["error"] = r.reason;
            result = std::max(result, int{app::kExitUnavailable});
          } else {
            const long long value = r.param.value & c.mask;
            jc["value"] = value;
            line = std::to_string(value);
            if (c.expected) {
              jc["configured"] = *c.expected;
              if (value == *c.expected) {
                line += " (as configured)";
              } else {
                // The gateway has set the drive up by now: a difference did not take hold.
                line += " CONTRADICTS the configuration (" + std::to_string(*c.expected) + "); " + c.if_different +
                        ": restart the gateway, and if it stays, put " + std::to_string(value) + " in the configuration or fix the drive";
                jc["contradiction"] = true;
                result = std::max(result, int{app::kExitFailure});
              }
            }
          }
          if (!ctx.json) std::cout << "  " << c.what << ": " << line << "\n";
          jd["checks"].push_back(jc);
        }
        for (const auto& n : notes) {
          if (!ctx.json) std::cout << "  " << n << "\n";
          jd["notes"].push_back(n);
        }
        out.push_back(jd);
      }
      if (ctx.json) std::cout << out.dump(2) << "\n";
      return result;
    });
  });
}

}  // namespace motion::ctl
