// motionctl commands that talk to the coordinator (requests) or watch axis state.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <deque>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>

#include <motionlcm/drive_model_request_t.hpp>
#include <motionlcm/sim_report_t.hpp>

#include "ledger_view.hpp"
#include "model_view.hpp"
#include "motion/client/client.hpp"
#include "motion/core/clock.hpp"
#include "motion/lcm/channels.hpp"
#include "motionctl.hpp"

namespace motion::ctl {
namespace {

using motionlcm::request_t;

// "x=120" -> ("x", 120); nullopt with a message on bad syntax.
std::optional<std::pair<std::string, double>> parse_assignment(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0) return std::nullopt;
  try {
    std::size_t used = 0;
    const double v = std::stod(text.substr(eq + 1), &used);
    if (used != text.size() - eq - 1 || !std::isfinite(v)) return std::nullopt;
    return std::pair{text.substr(0, eq), v};
  } catch (const std::exception&) { return std::nullopt; }
}

std::vector<std::string> all_axes(const config::Config& c) {
  std::vector<std::string> out;
  for (const auto& a : c.axes) out.push_back(a.name);
  return out;
}

void print_status_table(const config::Config& c, const std::map<std::string, motionlcm::axis_state_t>& states) {
  std::printf("%-8s %-12s %-7s %4s %5s %14s %-4s %-7s %-6s %-6s %s\n", "AXIS", "FAMILY", "BUS", "NODE", "GROUP",
              "POSITION", "UNIT", "ENABLED", "MOVING", "ONLINE", "FAULT");
  for (const auto& a : c.axes) {
    const auto* d = c.drive_of(a);
    auto it = states.find(a.name);
    if (it == states.end()) {
      std::printf("%-8s %-12s %-7s %4d %5d %14s %-4s %-7s %-6s %-6s %s\n", a.name.c_str(),
                  std::string(config::to_string(d->family)).c_str(), d->bus.c_str(), d->node_id, d->group_id, "-",
                  a.unit.c_str(), "-", "-", "no", "(no state heard)");
      continue;
    }
    const auto& s = it->second;
    // Not faulted but its drive lost power: the column says so (README "Safety and faults").
    const bool lost = !s.fault && s.fault_code == motionlcm::axis_state_t::POSITION_LOST;
    std::printf(
        "%-8s %-12s %-7s %4d %5d %14.4f %-4s %-7s %-6s %-6s %s\n", a.name.c_str(), s.family.c_str(), s.bus.c_str(),
        s.node_id, s.group_id, s.position, a.unit.c_str(), s.enabled ? "yes" : "no", s.moving ? "yes" : "no",
        s.online ? "yes" : "no",
        s.fault || lost ? (s.fault_text.empty() ? std::to_string(s.fault_code).c_str() : s.fault_text.c_str()) : "-");
  }
}

// age_s: how old each axis's last state is (its publication time against `now_us`, both wall
// clock), so that a script can tell a live value from a stale one.
nlohmann::json status_json(const config::Config& c, const std::map<std::string, motionlcm::axis_state_t>& states,
                           std::int64_t now_us) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& a : c.axes) {
    const auto* d = c.drive_of(a);
    nlohmann::json j = {{"family", config::to_string(d->family)},
                        {"bus", d->bus},
                        {"node", d->node_id},
                        {"group", d->group_id},
                        {"unit", a.unit}};
    if (auto it = states.find(a.name); it != states.end()) {
      const auto& s = it->second;
      j.update({{"position", s.position},
                {"position_counts", s.position_counts},
                {"velocity", s.velocity},
                {"enabled", s.enabled != 0},
                {"moving", s.moving != 0},
                {"in_position", s.in_position != 0},
                {"online", s.online != 0},
                {"fault", s.fault != 0},
                {"fault_code", s.fault_code},
                {"fault_text", s.fault_text},
                {"position_lost", s.fault == 0 && s.fault_code == motionlcm::axis_state_t::POSITION_LOST},
                {"homed", s.homed != 0},
                {"inputs", s.inputs},
                {"outputs", s.outputs},
                {"age_s", static_cast<double>(now_us - s.utime) / 1e6}});
    } else {
      j.update({{"position", nullptr},
                {"enabled", nullptr},
                {"moving", nullptr},
                {"online", false},
                {"fault", nullptr},
                {"age_s", nullptr}});
    }
    out[a.name] = j;
  }
  return out;
}

// The ground truth of a move's start on the simulated lab: when each simulated drive of the move's
// axes acted on its start frame (SIM_REPORT MOTION_STARTED, the first after the request was
// sent). Real drives send no such report, so on hardware there is none.
class StartTruth {
 public:
  StartTruth(app::Service& service, const request_t& request) {
    for (const auto& name : request.axes) {
      const auto* axis = service.config().find_axis(name);
      if (axis == nullptr) continue;
      drives_.insert(axis->drive);
      drive_of_[name] = axis->drive;
    }
    service.node().subscribe<motionlcm::sim_report_t>(lcm::channels::kSimReport,
                                                      [this](const motionlcm::sim_report_t& r, const std::string&) {
                                                        if (r.kind == motionlcm::sim_report_t::MOTION_STARTED &&
                                                            drives_.contains(r.drive) && !started_.contains(r.drive)) {
                                                          started_[r.drive] = r.frame_utime;
                                                        }
                                                      });
  }
  // Spread of the drives' start times, µs; nullopt unless every drive of the move reported.
  [[nodiscard]] std::optional<double> skew_us() const {
    if (drives_.empty() || started_.size() != drives_.size()) return std::nullopt;
    const auto [lo, hi] = std::minmax_element(started_.begin(), started_.end(),
                                              [](const auto& a, const auto& b) { return a.second < b.second; });
    return static_cast<double>(hi->second - lo->second);
  }
  // When the drive of `axis` acted on its start frame (µs since the epoch), if it reported.
  [[nodiscard]] std::optional<std::int64_t> start_of(const std::string& axis) const {
    const auto drive = drive_of_.find(axis);
    if (drive == drive_of_.end()) return std::nullopt;
    const auto it = started_.find(drive->second);
    if (it == started_.end()) return std::nullopt;
    return it->second;
  }

 private:
  std::set<std::string> drives_;
  std::map<std::string, std::string> drive_of_;
  std::map<std::string, std::int64_t> started_;
};

// Per axis: target, final position, when it started relative to the first axis (as the gateways
// measured it and, on the simulated lab, as the simulated drive acted: SIM START); then the
// measured duration and start skew beside the planner's predictions and the simulated drives'.
void print_move_summary(const motionlcm::reply_t& result, const StartTruth& truth) {
  std::int64_t first_start = 0;
  for (const std::int64_t t : result.start_utime) {
    if (t != 0 && (first_start == 0 || t < first_start)) first_start = t;
  }
  std::int64_t first_truth = 0;
  for (const auto& axis : result.axes) {
    if (const auto t = truth.start_of(axis); t && (first_truth == 0 || *t < first_truth)) first_truth = *t;
  }
  const auto offset = [](std::int64_t t, std::int64_t first) {
    return t == 0 ? std::string("-") : "+" + std::to_string(t - first) + " us";
  };
  std::printf("\n  %-8s %12s %12s %12s %10s", "AXIS", "TARGET", "FINAL", "ERROR", "START");
  if (first_truth != 0) std::printf(" %10s", "SIM START");
  for (std::size_t i = 0; i < result.axes.size(); ++i) {
    const std::int64_t start = i < result.start_utime.size() ? result.start_utime[i] : 0;
    std::printf("\n  %-8s %12.4f %12.4f %12.4f %10s", result.axes[i].c_str(), result.targets[i], result.positions[i],
                result.positions[i] - result.targets[i], offset(start, first_start).c_str());
    if (first_truth != 0) std::printf(" %10s", offset(truth.start_of(result.axes[i]).value_or(0), first_truth).c_str());
  }
  const std::optional<double> truth_skew_us = truth.skew_us();
  if (first_start != 0) {
    std::printf("\n  duration %.3f s (predicted %.3f s)", static_cast<double>(result.utime - first_start) / 1e6,
                result.predicted_duration_s);
  }
  if (result.measured_start_skew_us >= 0) {
    std::printf("\n  start skew %.0f us measured", result.measured_start_skew_us);
    if (truth_skew_us) std::printf(", %.0f us ground truth (the simulated drives)", *truth_skew_us);
    std::printf(" (predicted arrival spread %.0f us)", result.predicted_skew_us);
  }
}

// Sends `request` and reports its outcome; exit code 0 only on DONE (or STARTED without --wait).
int run_request(Context& ctx, app::Service& service, const request_t& request, bool wait, double timeout_s) {
  if (const auto unknown = unknown_axes(service.config(), request); !unknown.empty()) {
    for (const auto& line : unknown) std::cerr << "motionctl: " << line << "\n";
    return app::kExitUsage;
  }
  client::Client client(service.loop(), service.node(), "motionctl-" + std::to_string(::getpid()));
  if (!ctx.sign_requests(client, service.config())) return ctx.result;
  const bool tty = ::isatty(1) != 0 && !ctx.json;
  bool started = false;
  auto progress = [&](const motionlcm::reply_t& r) {
    if (r.status == motionlcm::reply_t::STARTED) started = true;
    if (tty && wait && (r.status == motionlcm::reply_t::PROGRESS || r.status == motionlcm::reply_t::STARTED)) {
      const int width = 30;
      const int filled = static_cast<int>(std::lround(r.progress * width));
      std::printf("\r[%s%s] %3.0f%%", std::string(static_cast<std::size_t>(filled), '#').c_str(),
                  std::string(static_cast<std::size_t>(width - filled), '.').c_str(), 100.0 * r.progress);
      std::fflush(stdout);
    }
  };
  const auto timeout = std::chrono::milliseconds(static_cast<long long>(timeout_s * 1000));
  motionlcm::reply_t result{};
  bool finished = false;
  bool answered = false;
  const bool moving_kind = request.kind == request_t::MOVE_ABSOLUTE || request.kind == request_t::MOVE_RELATIVE ||
                           request.kind == request_t::HOME;
  std::optional<StartTruth> truth;
  if (moving_kind) truth.emplace(service, request);
  const std::int64_t id = client.send(request, [&](const motionlcm::reply_t& r) {
    answered = true;
    progress(r);
    if (client::is_terminal(r.status)) {
      result = r;
      finished = true;
    }
  });
  const std::string where =
      service.node().url() + ", channel " +
      service.node().channel(client.signing() ? lcm::channels::kSignedRequest : lcm::channels::kRequest);
  // The coordinator answers at once (ACCEPTED or REJECTED): silence means nobody listens.
  // Sent again while nothing is heard of it: a lost request or reply costs a fraction of a second.
  if (!client.follow(
          id, [&] { return answered; }, std::min(timeout, client::Client::kAcceptTimeout))) {
    std::cerr << "motionctl: no reply from the coordinator within " << client::Client::kAcceptTimeout.count()
              << " ms: is motion-coordinator running on " << where << "?\n";
    return app::kExitUnavailable;
  }
  client.follow(
      id, [&] { return finished || (!wait && moving_kind && started); }, timeout);
  if (tty && wait) std::printf("\n");
  if (!finished && !wait && started) {
    std::cout << "started (not waiting; use --wait to follow it to the end)\n";
    return app::kExitOk;
  }
  if (!finished) {
    std::cerr << "motionctl: no terminal reply within " << timeout_s << " s (" << where << ")\n";
    return app::kExitUnavailable;
  }
  if (ctx.json) {
    nlohmann::json j = {{"status", client::status_name(result.status)},
                        {"reason", result.reason},
                        {"error_code", result.error_code},
                        {"predicted_duration_s", result.predicted_duration_s},
                        {"predicted_skew_us", result.predicted_skew_us},
                        {"measured_start_skew_us", result.measured_start_skew_us}};
    if (moving_kind) {
      const auto skew = truth->skew_us();
      j["ground_truth_start_skew_us"] = skew ? nlohmann::json(*skew) : nlohmann::json(nullptr);
    }
    for (std::size_t i = 0; i < result.axes.size(); ++i) {
      j["axes"][result.axes[i]] = {
          {"target", result.targets[i]}, {"position", result.positions[i]}, {"start_utime", result.start_utime[i]}};
      if (truth) {
        const auto t = truth->start_of(result.axes[i]);
        j["axes"][result.axes[i]]["ground_truth_start_utime"] = t ? nlohmann::json(*t) : nlohmann::json(nullptr);
      }
    }
    if (result.param.space != motionlcm::param_t::NONE) j["value"] = result.param.value;
    std::cout << j.dump(2) << "\n";
  } else if (result.status == motionlcm::reply_t::DONE) {
    std::cout << "done";
    if (result.param.space != motionlcm::param_t::NONE) std::cout << ": value " << result.param.value;
    if (moving_kind) print_move_summary(result, *truth);
    std::cout << "\n";
  }
  if (result.status != motionlcm::reply_t::DONE) {
    std::cerr << client::status_name(result.status) << ": " << result.reason << "\n";
    return app::kExitFailure;
  }
  return app::kExitOk;
}

struct AxisArgs {
  std::vector<std::string> items;
  bool wait = false;
  bool relative = false;
  double speed = 0;
  double timeout_s = std::chrono::duration<double>(client::Client::kRequestTimeout).count();
};

}  // namespace

void add_axis_commands(CLI::App& cli, Context& ctx) {
  // status / watch
  auto* status = cli.add_subcommand("status", "Table of every axis (--json for scripts)");
  auto listen = std::make_shared<double>(1.0);
  status->add_option("--listen", *listen, "Seconds to collect axis states")->capture_default_str();
  auto model = std::make_shared<bool>(false);
  status->add_flag("--model", *model, "Each axis's drive model (DRIVE_MODEL) as its gateway published it");
  auto ledger = std::make_shared<bool>(false);
  status->add_flag("--ledger", *ledger,
                   "Each bus's command ledger counters (LEDGER_STATS) as its gateway published them");
  status->callback([&ctx, listen, model, ledger] {
    ctx.result = ctx.with_node([&](app::Service& service) -> int {
      const auto& cfg = service.config();
      if (*ledger) {
        // The gateways publish them with every heartbeat: listen until every bus is heard.
        HeardLedgers heard;
        service.node().subscribe<motionlcm::ledger_stats_t>(
            lcm::channels::kLedgerStats,
            [&](const motionlcm::ledger_stats_t& m, const std::string&) { heard[m.bus] = m; });
        const auto deadline = service.loop().now() + std::chrono::milliseconds(static_cast<long long>(*listen * 1000));
        while (heard.size() < cfg.buses.size() && service.loop().now() < deadline) {
          service.loop().run_once(
              std::chrono::duration_cast<std::chrono::milliseconds>(deadline - service.loop().now()));
        }
        if (ctx.json) {
          std::cout << ledgers_json(cfg, heard, wall_time_us()).dump(2) << "\n";
        } else {
          print_ledgers(cfg, heard);
        }
        return heard.empty() ? app::kExitUnavailable : app::kExitOk;
      }
      if (*model) {
        // Ask every gateway (DRIVE_MODEL_REQUEST) and collect their answers: each model and, with
        // it, the axis's arming time.
        HeardModels heard;
        auto& models = heard.models;
        service.node().subscribe<motionlcm::drive_model_t>(
            lcm::channels::kDriveModel,
            [&](const motionlcm::drive_model_t& m, const std::string&) { models[m.axis] = m; });
        service.node().subscribe<motionlcm::arm_timing_t>(
            lcm::channels::kArmTiming,
            [&](const motionlcm::arm_timing_t& t, const std::string&) { heard.arming[t.axis] = t; });
        service.node().subscribe<motionlcm::line_timing_t>(
            lcm::channels::kLineTiming,
            [&](const motionlcm::line_timing_t& t, const std::string&) { heard.lines[t.bus] = t; });
        motionlcm::drive_model_request_t request{};
        request.utime = wall_time_us();
        request.requester = "motionctl";
        service.node().publish(lcm::channels::kDriveModelRequest, request);
        const auto deadline = service.loop().now() + std::chrono::milliseconds(static_cast<long long>(*listen * 1000));
        while ((models.size() < cfg.axes.size() || heard.arming.size() < cfg.axes.size()) &&
               service.loop().now() < deadline) {
          service.loop().run_once(
              std::chrono::duration_cast<std::chrono::milliseconds>(deadline - service.loop().now()));
        }
        if (ctx.json) {
          std::cout << models_json(cfg, heard).dump(2) << "\n";
        } else {
          print_models(cfg, heard);
        }
        return models.empty() ? app::kExitUnavailable : app::kExitOk;
      }
      client::Client client(service.loop(), service.node(), "motionctl-status");
      Context::verify_states(client, cfg);
      client.wait_until([&] { return client.axes().size() >= cfg.axes.size(); },
                        std::chrono::milliseconds(static_cast<long long>(*listen * 1000)));
      if (ctx.json) {
        std::cout << status_json(cfg, client.axes(), wall_time_us()).dump(2) << "\n";
      } else {
        print_status_table(cfg, client.axes());
      }
      return client.axes().empty() ? app::kExitUnavailable : app::kExitOk;
    });
  });
  auto* watch = cli.add_subcommand("watch", "Live axis table and events (Ctrl-C ends)");
  auto duration = std::make_shared<double>(0);
  watch->add_option("--for", *duration, "Stop after this many seconds (0 = until Ctrl-C)");
  watch->callback([&ctx, duration] {
    ctx.result = ctx.with_node([&](app::Service& service) -> int {
      client::Client client(service.loop(), service.node(), "motionctl-watch");
      Context::verify_states(client, service.config());
      const bool tty = ::isatty(1) != 0 && !ctx.json;
      // On a terminal the table is redrawn four times a second with the latest events kept below
      // it; elsewhere (a pipe, a file, --json) every event is one line as it comes, and --json
      // prints the axis table as one JSON line per redraw period.
      constexpr std::size_t kEventsShown = 12;
      std::deque<std::string> recent;
      client.on_event([&](const motionlcm::event_t& e) {
        char when[16] = "";
        const std::time_t seconds = static_cast<std::time_t>(e.utime / 1'000'000);
        std::tm local{};
        if (::localtime_r(&seconds, &local) != nullptr) std::strftime(when, sizeof when, "%H:%M:%S", &local);
        if (ctx.json) {
          const nlohmann::json j = {{"event",
                                     {{"utime", e.utime},
                                      {"source", e.source},
                                      {"bus", e.bus},
                                      {"axis", e.axis},
                                      {"severity", e.severity},
                                      {"kind", e.kind},
                                      {"code", e.code},
                                      {"text", e.text}}}};
          std::printf("%s\n", j.dump().c_str());
          return;
        }
        char line[1024];
        std::snprintf(line, sizeof line, "event %s %s %s%s: %s (code %d)", when, e.source.c_str(), e.bus.c_str(),
                      e.axis.empty() ? "" : ("/" + e.axis).c_str(), e.text.c_str(), e.code);
        if (!tty) {
          std::printf("%s\n", line);
          return;
        }
        recent.emplace_back(line);
        if (recent.size() > kEventsShown) recent.pop_front();
      });
      service.loop().call_every(std::chrono::milliseconds(250), [&] {
        if (ctx.json) {
          std::printf(
              "%s\n",
              nlohmann::json{{"axes", status_json(service.config(), client.axes(), wall_time_us())}}.dump().c_str());
        } else {
          if (tty) std::printf("\033[H\033[J");
          print_status_table(service.config(), client.axes());
          if (tty) {
            std::printf("\nlatest events (%zu shown, newest last):\n", recent.size());
            for (const auto& line : recent) std::printf("  %s\n", line.c_str());
          }
        }
        std::fflush(stdout);
      });
      if (*duration > 0)
        service.loop().call_after(std::chrono::milliseconds(static_cast<long long>(*duration * 1000)),
                                  [&] { service.loop().stop(); });
      service.loop().run();
      return app::kExitOk;
    });
  });

  // Commands on a list of axes (default: every axis).
  struct Simple {
    const char* name;
    const char* help;
    std::int8_t kind;
    bool all_by_default;
  };
  for (const Simple s : {Simple{"enable", "Switch drives on", request_t::ENABLE, true},
                         Simple{"disable", "Switch drives off", request_t::DISABLE, true},
                         Simple{"reset", "Clear faults", request_t::FAULT_RESET, true},
                         Simple{"stop", "Decelerating stop", request_t::STOP, true},
                         Simple{"estop", "Emergency stop", request_t::ESTOP, true},
                         Simple{"home", "Home axes as configured", request_t::HOME, false}}) {
    auto* cmd = cli.add_subcommand(s.name, std::string(s.help) + (s.all_by_default ? " (default: every axis)" : ""));
    auto args = std::make_shared<AxisArgs>();
    cmd->add_option("axes", args->items, "Axis names");
    cmd->add_option("--timeout", args->timeout_s, "Seconds to wait for the outcome")->capture_default_str();
    if (!s.all_by_default) cmd->get_option("axes")->required();
    const auto kind = s.kind;
    const bool all = s.all_by_default;
    cmd->callback([&ctx, args, kind, all] {
      ctx.result = ctx.with_node([&](app::Service& service) -> int {
        auto axes = args->items.empty() && all && kind != request_t::STOP && kind != request_t::ESTOP
                        ? all_axes(service.config())
                        : args->items;
        return run_request(ctx, service, client::Client::make(kind, axes), true, args->timeout_s);
      });
    });
  }

  // move / jog / set-position: AXIS=VALUE assignments.
  struct Assign {
    const char* name;
    const char* help;
    std::int8_t kind;
  };
  for (const Assign s :
       {Assign{"move", "Synchronized move: AXIS=POS ... (user units)", request_t::MOVE_ABSOLUTE},
        Assign{"jog", "Jog: AXIS=VELOCITY ... (units/s, sign = direction)", request_t::JOG},
        Assign{"set-position", "Declare the current position: AXIS=POS ...", request_t::SET_POSITION}}) {
    auto* cmd = cli.add_subcommand(s.name, s.help);
    auto args = std::make_shared<AxisArgs>();
    cmd->add_option("assignments", args->items, "AXIS=VALUE")->required();
    cmd->add_option("--timeout", args->timeout_s, "Seconds to wait for the outcome")->capture_default_str();
    const bool is_move = s.kind == request_t::MOVE_ABSOLUTE;
    if (is_move) {
      cmd->add_flag("--rel", args->relative, "Distances instead of targets");
      cmd->add_option("--speed", args->speed, "Fraction (0..1] of the axes' velocity and acceleration limits");
      cmd->add_flag("--wait", args->wait, "Wait for the end of the move, with a progress bar");
    }
    const auto kind = s.kind;
    cmd->callback([&ctx, args, kind, is_move] {
      std::map<std::string, double> values;
      for (const auto& item : args->items) {
        auto parsed = parse_assignment(item);
        if (!parsed) {
          std::cerr << "motionctl: '" << item << "' is not AXIS=NUMBER\n";
          ctx.result = app::kExitUsage;
          return;
        }
        values[parsed->first] = parsed->second;
      }
      ctx.result = ctx.with_node([&](app::Service& service) -> int {
        auto request =
            client::Client::make(is_move && args->relative ? std::int8_t{request_t::MOVE_RELATIVE} : kind, values);
        request.velocity_scale = args->speed;
        request.acceleration_scale = args->speed;
        return run_request(ctx, service, request, !is_move || args->wait, args->timeout_s);
      });
    });
  }

  // outputs AXIS MASK VALUE
  auto* outputs = cli.add_subcommand("outputs", "Set digital outputs of one axis's drive: AXIS MASK VALUE");
  auto out_args = std::make_shared<std::tuple<std::string, int, int>>();
  outputs->add_option("axis", std::get<0>(*out_args))->required();
  outputs->add_option("mask", std::get<1>(*out_args), "bit n = output n+1")->required();
  outputs->add_option("value", std::get<2>(*out_args))->required();
  outputs->callback([&ctx, out_args] {
    ctx.result = ctx.with_node([&](app::Service& service) -> int {
      auto request = client::Client::make(request_t::SET_OUTPUTS, std::vector<std::string>{std::get<0>(*out_args)});
      request.output_mask = std::get<1>(*out_args);
      request.output_value = std::get<2>(*out_args);
      return run_request(ctx, service, request, true, 10);
    });
  });

  // param get|set AXIS INDEX [SUBINDEX] [--value V] : expert access in the family's own terms.
  auto* param = cli.add_subcommand("param", "Expert parameter access in the drive family's own terms");
  auto p = std::make_shared<std::tuple<std::string, std::string, std::string, int, std::optional<long long>, int>>();
  param->add_option("axis", std::get<0>(*p))->required();
  param
      ->add_option("index", std::get<1>(*p),
                   "UIM342 function code, CANopen index, Modbus register (decimal or 0x...), UIM242 mnemonic")
      ->required();
  param->add_option("--sub", std::get<3>(*p), "Sub-index (-1 = none)")->default_val(-1);
  param->add_option("--set", std::get<4>(*p), "Write this value (otherwise read)");
  param->add_option("--width", std::get<5>(*p), "Bytes (CAN families) or registers (Modbus); 0 = from the dictionary")
      ->default_val(0);
  param->callback([&ctx, p] {
    ctx.result = ctx.with_node([&](app::Service& service) -> int {
      const auto& cfg = service.config();
      const auto* axis = cfg.find_axis(std::get<0>(*p));
      if (axis == nullptr) {
        std::cerr << "motionctl: " << unknown_axis(cfg, std::get<0>(*p)) << "\n";
        return app::kExitUsage;
      }
      const auto family = cfg.drive_of(*axis)->family;
      auto request = client::Client::make(
          std::get<4>(*p) ? std::int8_t{request_t::PARAM_WRITE} : std::int8_t{request_t::PARAM_READ},
          std::vector<std::string>{axis->name});
      auto& prm = request.param;
      prm.space = family == config::Family::kUim342   ? motionlcm::param_t::UIM342_INSTRUCTION
                  : family == config::Family::kUc57   ? motionlcm::param_t::CANOPEN_OBJECT
                  : family == config::Family::kUim242 ? motionlcm::param_t::UIM242_INSTRUCTION
                                                      : motionlcm::param_t::MODBUS_REGISTER;
      const std::string& index = std::get<1>(*p);
      if (family == config::Family::kUim242) {
        prm.mnemonic = index;
      } else {
        try {
          prm.index = static_cast<std::int32_t>(std::stol(index, nullptr, 0));
        } catch (const std::exception&) {
          std::cerr << "motionctl: index '" << index << "' is not a number\n";
          return app::kExitUsage;
        }
      }
      prm.subindex = std::get<3>(*p);
      prm.width = static_cast<std::int8_t>(std::get<5>(*p));
      prm.value = std::get<4>(*p).value_or(0);
      return run_request(ctx, service, request, true, 10);
    });
  });
}

}  // namespace motion::ctl
