// motionctl commission BUS: reads back, per drive of the bus, the set-up values whose meaning the
// manuals leave to the drive (docs/protocols.md), says what it found and what the gateway will do
// about it, and which simulated variant stays unknowable from reads. Moves nothing. Exit 1 when
// something the drive reports contradicts the configuration (the gateway's set-up has run, so a
// difference did not take hold), 4 when a drive does not answer. UC57: which rpdo_sync variant
// holds, from 1400h:02 and the start mechanism in the drive model (the gateway's acceptance test).
// With --small-move PERCENT (0 = none, the default) each axis also moves that share of its travel
// range out and back (toward the side with more room, never beyond a limit), and the counts its
// drive reports must change by what the configuration implies (steps_per_unit, invert) and come
// back: exit 1 otherwise. Requests go through the coordinator (PARAM_READ, MOVE_ABSOLUTE), so the
// gateway of the bus and the coordinator must run. On a uimessage: bus it first prints the CRC
// coverage the gateway uses and how it knows (configured, or detected from the gateway's frames).
#include "motionctl.hpp"

#include "motion/lcm/channels.hpp"

#include <unistd.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include <motionlcm/drive_model_request_t.hpp>
#include <motionlcm/drive_model_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/param_t.hpp>
#include <motionlcm/reply_t.hpp>

namespace motion::ctl {
namespace {

using motionlcm::param_t;
using motionlcm::reply_t;

struct Check {
  std::string what;  // "MT[0] micro-steps"
  param_t param;
  std::optional<long long> expected;
  long long mask = -1;       // bits that exist (UIM242 ICFG 15..4 read 0)
  std::string if_different;  // what set-up does about a difference
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

constexpr const char* kRpdo1Type = "1400h:02 RPDO1 transmission type";

// UC57 rpdo_sync (docs/protocols.md UC57 #1) from RPDO1's transmission type as read and the start
// mechanism the gateway's acceptance test left in the drive model: refused when set-up had to fall
// back to an asynchronous type, honoured when the model offers the SYNC start, on_reception when
// type 1 holds but the model offers only the node's own RPDO1.
std::string rpdo_sync_variant(long long transmission_type, const motionlcm::drive_model_t* model) {
  if (transmission_type > 240) return "refused";
  if (model == nullptr) return "unknown (no drive model from the gateway)";
  for (const auto kind : model->start_kinds) {
    if (kind == motionlcm::drive_model_t::START_CANOPEN_SYNC) return "honoured";
  }
  return "on_reception";
}

// The checks of one drive and the notes on what reads cannot tell (docs/protocols.md).
std::pair<std::vector<Check>, std::vector<std::string>> checks_of(const config::Drive& d) {
  std::vector<Check> checks;
  std::vector<std::string> notes;
  switch (d.family) {
    case config::Family::kUim342: {
      constexpr int kPP = 0x01, kMT = 0x10, kQE = 0x3D;  // SimpleCAN 3.0 function codes (UIM342 manual §5)
      const auto steps = d.setup_integer("micro_steps");
      checks.push_back({"MT[0] micro-steps", uim342(kMT, 0), steps, -1,
                        "set-up stores it with the driver off and restarts (SY[1])"});
      checks.push_back({"QE[4] counts/rev", uim342(kQE, 4),
                        steps ? std::optional<long long>(*steps * 200) : std::nullopt, -1,
                        "set-up stores it with MT[0] and restarts"});
      if (d.group_id != 0)
        checks.push_back({"PP[8] group id", uim342(kPP, 8), d.group_id, -1, "set-up writes PP[8] and restarts"});
      notes.push_back(
          "micro_steps_apply: not readable (a value written while the driver was on reads back but applies only after "
          "a "
          "restart); power-cycle once after commissioning to be sure");
      break;
    }
    case config::Family::kUim242: {
      const auto icfg = d.setup_integer("icfg");
      checks.push_back({"ICFG", uim242("ICF"), icfg ? std::optional<long long>(*icfg & 0xF) : std::nullopt, 0xF,
                        "set-up writes ICF once and waits out the auto reboot"});
      checks.push_back({"MCS micro-steps", uim242("MCS"), d.setup_integer("micro_steps"), -1, "set-up writes MCS"});
      notes.push_back("reboot_ms: set-up waits for the controller to answer after an ICF write (up to 5 s)");
      notes.push_back(
          "move start (spd0_position_move): the gateway probes it at the drive's first armed move (--small-move "
          "makes one and reports what it found)");
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
      p.index = 0x1400;  // RPDO1 communication parameter, sub 2 transmission type (UC57 manual §5 comm. table)
      p.subindex = 2;
      checks.push_back({kRpdo1Type, p, std::nullopt, -1, ""});
      break;
    }
  }
  return {checks, notes};
}

// The small move of one axis: out by `percent` of its travel range and back. What the drive's
// counter (the axis state's position_counts, as the gateway read it) did against the counts the
// configuration implies.
// (bugprone-exception-escape: nlohmann::json's destructor allocates while freeing nested values;
// a bad_alloc there ends the program, as in any destructor.)
struct SmallMove {  // NOLINT(bugprone-exception-escape)
  bool checked = false;
  bool contradiction = false;
  std::string line;
  nlohmann::json json;
};

SmallMove small_move(client::Client& client, const config::Axis& axis, double percent) {
  SmallMove out;
  const auto state = [&client, &axis]() -> const motionlcm::axis_state_t* {
    const auto it = client.axes().find(axis.name);
    return it == client.axes().end() ? nullptr : &it->second;
  };
  client.wait_until([&] { return state() != nullptr && !state()->moving; }, std::chrono::seconds(3));
  const auto* s = state();
  if (s == nullptr || !s->online || !s->enabled || s->moving) {
    out.line = "not checked: the axis is " + std::string(s == nullptr  ? "not heard from"
                                                         : !s->online  ? "offline"
                                                         : !s->enabled ? "disabled"
                                                                       : "moving");
    out.json = {{"error", out.line}};
    return out;
  }
  const double start = s->position;
  const std::int64_t start_counts = s->position_counts;
  const double range = axis.limits.max_position - axis.limits.min_position;
  const double up = axis.limits.max_position - start;
  const double down = start - axis.limits.min_position;
  const double distance = std::min(range * percent / 100.0, std::max(up, down));
  const double delta = up >= down ? distance : -distance;
  const double counts_per_unit = axis.steps_per_unit * (axis.invert ? -1.0 : 1.0);
  const std::int64_t expected = std::llround(delta * counts_per_unit);
  std::ostringstream what;
  what << (delta >= 0 ? "+" : "") << delta << " " << axis.unit << " = " << expected << " counts";
  out.json = {{"distance", delta}, {"expected_counts", expected}};
  if (expected == 0) {
    out.line = "not checked: " + what.str() + " (less than one count)";
    return out;
  }
  std::int64_t counted = 0;
  std::int64_t back = 0;
  for (const double target : {start + delta, start}) {
    const auto reply = client.call(client::Client::make(std::int8_t{motionlcm::request_t::MOVE_ABSOLUTE},
                                                        std::map<std::string, double>{{axis.name, target}}),
                                   std::chrono::seconds(60));
    if (reply.status != motionlcm::reply_t::DONE) {
      out.line = "not checked: the move to " + std::to_string(target) + " " + axis.unit + " ended " + reply.reason;
      out.json["error"] = out.line;
      return out;
    }
    // The state the move led to came before its DONE.
    (target == start ? back : counted) = state()->position_counts - start_counts;
  }
  out.checked = true;
  out.json["counted"] = counted;
  out.json["back"] = back;
  std::ostringstream line;
  line << what.str() << " out and back: the drive counted " << (counted >= 0 ? "+" : "") << counted << ", back at "
       << (back >= 0 ? "+" : "") << back;
  if (counted == expected && back == 0) {
    line << " (as expected)";
  } else {
    out.contradiction = true;
    out.json["contradiction"] = true;
    line << " CONTRADICTS the configuration (" << expected << " and 0 at steps_per_unit " << axis.steps_per_unit
         << (axis.invert ? ", inverted" : "") << "): check steps_per_unit and the drive's micro-stepping";
    if (counted != 0 && expected % counted == 0) line << " (" << expected / counted << " times the counts it made)";
  }
  out.line = line.str();
  return out;
}

// UIM242's move start (docs/protocols.md, UIM242 #3) as the gateway's probe found it during this
// run, or why there is no finding.
struct MoveStart {
  std::string line;
  nlohmann::json json;
};

MoveStart move_start_of(const config::Drive& d, const std::vector<motionlcm::event_t>& findings) {
  const std::string prefix = d.name + " (node " + std::to_string(d.node_id) + "): ";
  for (const auto& e : findings) {
    if (e.text.rfind(prefix, 0) != 0 || e.text.find("spd0_position_move") == std::string::npos) continue;
    return {"probed: " + e.text.substr(prefix.size()), {{"probed", e.text.substr(prefix.size())}}};
  }
  if (const auto configured = d.setup_text("spd0_position_move"); configured && *configured != "detect") {
    return {"spd0_position_move " + *configured + " from the configuration (not probed)",
            {{"configured", *configured}}};
  }
  return {
      "not probed in this run: the gateway probes a drive once, at its first armed move since the gateway "
      "started (its CONFIG_MISMATCH event then says what it found)",
      {{"probed", nullptr}}};
}

// A uimessage: bus's CRC coverage (docs/protocols.md, UIMessage row 1) as its gateway uses it:
// from the bus statistics of the gateway's heartbeat ("uimessage:DEV (CRC ID..d8 (12 bytes),
// detected from the gateway's frames)"). Empty when no heartbeat said it within `wait`.
std::string uimessage_crc_of(app::Service& service, const std::string& bus, std::chrono::milliseconds wait) {
  // Shared: the subscription outlives this call (a node cannot unsubscribe).
  auto found = std::make_shared<std::string>();
  service.node().subscribe<motionlcm::health_t>(
      lcm::channels::kHealth, [found, bus](const motionlcm::health_t& h, const std::string&) {
        for (const auto& b : h.buses) {
          const auto at = b.transport.find(" (CRC ");
          if (b.name != bus || at == std::string::npos || b.transport.back() != ')') continue;
          *found = b.transport.substr(at + 6, b.transport.size() - at - 7);  // without the parentheses
        }
      });
  const auto deadline = service.loop().now() + wait;
  while (found->empty() && service.loop().now() < deadline) {
    service.loop().run_once(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - service.loop().now()));
  }
  return *found;
}

}  // namespace

void add_commission_command(CLI::App& cli, Context& ctx) {
  auto* cmd = cli.add_subcommand(
      "commission",
      "Read back each drive's set-up on a bus and say what the manuals leave open (moves nothing unless "
      "--small-move)");
  auto bus = std::make_shared<std::string>();
  cmd->add_option("bus", *bus, "Bus name from the configuration")->required();
  auto percent = std::make_shared<double>(0.0);
  cmd->add_option("--small-move", *percent,
                  "Also move each axis this percent of its travel range out and back (never beyond a limit) and check "
                  "the counts its drive reports (0: move nothing)")
      ->check(CLI::Range(0.0, 50.0));
  cmd->callback([&ctx, bus, percent] {
    ctx.result = ctx.with_node([&](app::Service& service) -> int {
      const auto& cfg = service.config();
      if (cfg.find_bus(*bus) == nullptr) {
        std::cerr << "motionctl: no bus '" << *bus << "' in the configuration\n";
        return app::kExitUsage;
      }
      client::Client client(service.loop(), service.node(), "motionctl-" + std::to_string(::getpid()));
      if (!ctx.sign_requests(client, service.config())) return ctx.result;
      // The drive models (DRIVE_MODEL) of the bus's UC57 axes: how their gateway starts them.
      std::map<std::string, motionlcm::drive_model_t> models;
      std::size_t uc57_axes = 0;
      for (const auto& d : cfg.drives) {
        if (d.bus == *bus && d.family == config::Family::kUc57) ++uc57_axes;
      }
      if (uc57_axes > 0) {
        service.node().subscribe<motionlcm::drive_model_t>(lcm::channels::kDriveModel,
                                                           [&](const motionlcm::drive_model_t& m, const std::string&) {
                                                             if (m.bus == *bus) models[m.drive] = m;
                                                           });
        motionlcm::drive_model_request_t ask{};
        ask.utime = wall_time_us();
        ask.requester = "motionctl-commission";
        service.node().publish(lcm::channels::kDriveModelRequest, ask);
        const auto deadline = service.loop().now() + std::chrono::seconds(3);
        while (models.size() < uc57_axes && service.loop().now() < deadline) {
          service.loop().run_once(
              std::chrono::duration_cast<std::chrono::milliseconds>(deadline - service.loop().now()));
        }
      }
      // What the gateway finds out at a drive's first armed move (UIM242's move-start probe: a
      // CONFIG_MISMATCH INFO event of that drive), reported after the small move.
      std::vector<motionlcm::event_t> findings;
      client.on_event([&findings](const motionlcm::event_t& e) {
        if (e.kind == motionlcm::event_t::CONFIG_MISMATCH) findings.push_back(e);
      });
      int result = app::kExitOk;
      nlohmann::json out = nlohmann::json::array();
      // A UIROBOT serial gateway: which bytes its CRC covers, as the gateway process found it.
      std::string crc;
      if (cfg.find_bus(*bus)->kind == config::TransportKind::kUiMessage) {
        crc = uimessage_crc_of(service, *bus, std::chrono::seconds(3));
        if (crc.empty()) crc = "unknown (no heartbeat from gateway:" + *bus + " said it)";
        if (!ctx.json) std::cout << "bus " << *bus << ": UIMessage CRC " << crc << "\n";
      }
      for (const auto& d : cfg.drives) {
        if (d.bus != *bus) continue;
        const config::Axis* axis = nullptr;
        for (const auto& a : cfg.axes) {
          if (a.drive == d.name) axis = &a;
        }
        nlohmann::json jd{{"drive", d.name}, {"family", config::to_string(d.family)}, {"node_id", d.node_id}};
        if (!crc.empty()) jd["uimessage_crc"] = crc;
        if (!ctx.json) std::cout << d.name << " (" << config::to_string(d.family) << ", node " << d.node_id << ")\n";
        if (axis == nullptr) {
          if (!ctx.json) std::cout << "  no axis uses it: not checked\n";
          continue;
        }
        const auto [checks, notes] = checks_of(d);
        for (const auto& c : checks) {
          auto request =
              client::Client::make(std::int8_t{motionlcm::request_t::PARAM_READ}, std::vector<std::string>{axis->name});
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
                        ": restart the gateway, and if it stays, put " + std::to_string(value) +
                        " in the configuration or fix the drive";
                jc["contradiction"] = true;
                result = std::max(result, int{app::kExitFailure});
              }
            }
          }
          if (c.what == kRpdo1Type && r.status == reply_t::DONE) {
            const auto model = models.find(d.name);
            const std::string variant =
                rpdo_sync_variant(r.param.value, model == models.end() ? nullptr : &model->second);
            line += "; rpdo_sync: " + variant;
            jd["rpdo_sync"] = variant;
            const auto configured = d.setup_text("rpdo_sync");
            if (configured && *configured != "detect" && (variant == "honoured" || variant == "on_reception") &&
                *configured != variant) {
              line += " CONTRADICTS the configuration (rpdo_sync: " + *configured +
                      "); the gateway goes by the drive: put " + variant + " in the configuration";
              jc["contradiction"] = true;
              result = std::max(result, int{app::kExitFailure});
            } else if (variant == "on_reception" || variant == "refused") {
              line += " (moves start node by node; STARTED reports the skew)";
            }
          }
          if (!ctx.json) std::cout << "  " << c.what << ": " << line << "\n";
          jd["checks"].push_back(jc);
        }
        if (*percent > 0) {
          const auto moved = small_move(client, *axis, *percent);
          if (!ctx.json) std::cout << "  small move: " << moved.line << "\n";
          jd["small_move"] = moved.json;
          if (moved.contradiction) result = std::max(result, int{app::kExitFailure});
          if (!moved.checked) result = std::max(result, int{app::kExitUnavailable});
          if (d.family == config::Family::kUim242) {
            const auto start = move_start_of(d, findings);
            if (!ctx.json) std::cout << "  move start: " << start.line << "\n";
            jd["move_start"] = start.json;
          }
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
