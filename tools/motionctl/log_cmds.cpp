// motionctl log FILE: reads an LCM event log (written by lcm-logger) with LCM's C eventlog API and
// prints what the motion system said in it: the requests, their replies (status, reason, start
// skew) and every axis's trajectory (time, position, velocity, moving), as tables or as CSV; with
// --plot, also an SVG of the trajectories (one panel per axis, each request's start and end marked).
//
// Only this system's channels (<prefix>REQUEST, REPLY, AXIS_STATE; prefix from the configuration,
// or --prefix) are decoded; other channels are counted. Each record's header is checked before
// LCM reads it, so a corrupt or truncated file is reported with its byte offset instead of being
// skipped silently (LCM's reader resynchronizes on the next magic word).
//
// Exit codes: 0 the log was read (a truncated final record, as left by a killed logger, is only a
// warning), 1 the file is missing, unreadable or corrupt (what was decoded before the damage is
// still printed), 2 bad command line, 3 configuration refused.
#include <lcm/eventlog.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>

#include "motion/client/client.hpp"
#include "motion/core/log.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/request_kinds.hpp"
#include "motion/web/svg_plot.hpp"

#include "log_file.hpp"
#include "motionctl.hpp"

namespace motion::ctl {
namespace {

using motionlcm::axis_state_t;
using motionlcm::reply_t;
using motionlcm::request_t;

struct LogArgs {
  std::string file;
  std::string csv;  // empty: tables on stdout; "-": CSV on stdout
  std::vector<std::string> axes;
  std::string prefix;  // empty: the configuration's lcm.channel_prefix
  std::string plot;    // SVG file of the trajectories; empty: none
};

const char* kind_name(std::int8_t kind) { return lcm::request_kind_name(kind); }

// Status names as the reply_t constants spell them (DONE, REJECTED, ...).
std::string status_name(std::int8_t status) {
  std::string name = client::status_name(status);
  for (char& c : name) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return name;
}

bool has_values(std::int8_t kind) {
  return kind == request_t::MOVE_ABSOLUTE || kind == request_t::MOVE_RELATIVE || kind == request_t::JOG ||
         kind == request_t::SET_POSITION;
}

std::string key_of(const std::string& client_id, std::int64_t request_id) {
  return client_id + "#" + std::to_string(request_id);
}

// "x=10 y=5" for requests with values, "x y" otherwise, "(all axes)" for none.
std::string request_axes(const request_t& r, const char* separator) {
  if (r.axes.empty()) return "(all axes)";
  std::string out;
  for (std::size_t i = 0; i < r.axes.size(); ++i) {
    if (i > 0) out += separator;
    out += r.axes[i];
    if (has_values(r.kind) && i < r.values.size()) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "=%g", r.values[i]);
      out += buf;
    }
  }
  return out;
}

std::string joined(const std::vector<std::string>& items, const char* separator) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) out += (i > 0 ? separator : "") + items[i];
  return out;
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

std::string number(double v, const char* format = "%.6f") {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

class View {
 public:
  View(const LogContents& log, const std::vector<std::string>& axes) : log_(log), filter_(axes.begin(), axes.end()) {}

  [[nodiscard]] double t(std::int64_t log_utime) const {
    return static_cast<double>(log_utime - log_.first_utime) / 1e6;
  }
  [[nodiscard]] bool axis_selected(const std::string& axis) const { return filter_.empty() || filter_.contains(axis); }
  [[nodiscard]] bool request_selected(const request_t& r) const {
    if (filter_.empty() || r.axes.empty()) return true;
    return std::any_of(r.axes.begin(), r.axes.end(), [&](const std::string& a) { return filter_.contains(a); });
  }

  [[nodiscard]] bool reply_selected(const reply_t& r) const {
    if (filter_.empty() || r.axes.empty()) return true;
    return std::any_of(r.axes.begin(), r.axes.end(), [&](const std::string& a) { return filter_.contains(a); });
  }

  // Requests with their replies in log order; replies whose request is not in the log come last.
  struct Thread {
    const Logged<request_t>* request = nullptr;
    std::string key;
    std::vector<const Logged<reply_t>*> replies;
  };
  [[nodiscard]] std::vector<Thread> threads() const {
    std::vector<Thread> out;
    std::map<std::string, std::size_t> index;
    for (const auto& r : log_.requests) {
      if (!request_selected(r.msg)) continue;
      const auto key = key_of(r.msg.client_id, r.msg.request_id);
      if (index.contains(key)) continue;  // a duplicate id: the coordinator rejects it; keep the first
      index[key] = out.size();
      out.push_back({&r, key, {}});
    }
    std::set<std::string> recorded;  // requests in the log, selected or not
    for (const auto& r : log_.requests) recorded.insert(key_of(r.msg.client_id, r.msg.request_id));
    for (const auto& r : log_.replies) {
      const auto key = key_of(r.msg.client_id, r.msg.request_id);
      if (auto it = index.find(key); it != index.end()) {
        out[it->second].replies.push_back(&r);
      } else if (!recorded.contains(key) && reply_selected(r.msg)) {  // request not recorded: group its replies anyway
        index[key] = out.size();
        out.push_back({nullptr, key, {&r}});
      }
    }
    return out;
  }

  // Axis -> its states, in log order.
  [[nodiscard]] std::map<std::string, std::vector<const Logged<axis_state_t>*>> trajectories() const {
    std::map<std::string, std::vector<const Logged<axis_state_t>*>> out;
    for (const auto& s : log_.states) {
      if (axis_selected(s.msg.axis)) out[s.msg.axis].push_back(&s);
    }
    return out;
  }

 private:
  const LogContents& log_;
  std::set<std::string> filter_;
};

std::string reply_note(const reply_t& r) {
  std::string note;
  auto add = [&](const std::string& s) {
    if (s.empty()) return;
    if (!note.empty()) note += "; ";
    note += s;
  };
  if (r.error_code != 0) add("error " + std::to_string(r.error_code));
  add(r.reason);
  if (r.status == reply_t::ACCEPTED && r.predicted_duration_s > 0) {
    add("predicted " + number(r.predicted_duration_s, "%.3f") + " s, arrival spread " +
        number(r.predicted_skew_us, "%.0f") + " us");
  }
  if (client::is_terminal(r.status) && !r.axes.empty()) {
    std::string positions;
    for (std::size_t i = 0; i < r.axes.size() && i < r.positions.size(); ++i) {
      positions += (i > 0 ? " " : "") + r.axes[i] + "=" + number(r.positions[i], "%.4f");
    }
    add("positions " + positions);
    if (r.measured_start_skew_us >= 0 &&
        std::any_of(r.start_utime.begin(), r.start_utime.end(), [](std::int64_t t) { return t != 0; })) {
      add("start skew " + number(r.measured_start_skew_us, "%.0f") + " us (predicted arrival spread " +
          number(r.predicted_skew_us, "%.0f") + " us)");
    }
  }
  return note;
}

void print_tables(const std::string& path, const std::string& prefix, const LogContents& log, const View& view) {
  std::printf("log %s: %" PRId64 " events over %.3f s (channel prefix %s)\n", path.c_str(), log.events,
              view.t(log.last_utime), prefix.c_str());
  std::int64_t others = 0;
  std::string other_names;
  int other_channels = 0;
  for (const auto& [channel, count] : log.channel_counts) {
    if (channel.rfind(prefix, 0) == 0) {
      std::printf("  %-28s %8" PRId64 "\n", channel.c_str(), count);
    } else {
      others += count;
      if (++other_channels <= 4) other_names += (other_channels > 1 ? ", " : "") + channel;
    }
  }
  if (others > 0) {
    std::printf("  (%" PRId64 " events on %d channel%s without the prefix, not decoded: %s%s)\n", others,
                other_channels, other_channels == 1 ? "" : "s", other_names.c_str(), other_channels > 4 ? ", ..." : "");
  }

  const auto threads = view.threads();
  std::printf("\nrequests (%zu):\n", threads.size());
  if (threads.empty()) std::printf("  (none)\n");
  for (const auto& th : threads) {
    if (th.request != nullptr) {
      const auto& r = th.request->msg;
      std::printf("  %+9.3f s  %-24s %-14s %s", view.t(th.request->log_utime), th.key.c_str(), kind_name(r.kind),
                  request_axes(r, " ").c_str());
      if (r.velocity_scale > 0 && r.velocity_scale != 1) std::printf("  speed %g", r.velocity_scale);
      std::printf("\n");
    } else {
      std::printf("  %11s  %-24s (request not in the log)\n", "", th.key.c_str());
    }
    int progress = 0;
    for (const auto* rep : th.replies) {
      if (rep->msg.status == reply_t::PROGRESS) {
        ++progress;
        continue;
      }
      if (progress > 0) {
        std::printf("      %+9.3f s  (%d PROGRESS)\n", view.t(rep->log_utime), progress);
        progress = 0;
      }
      std::printf("      %+9.3f s  %-9s %s\n", view.t(rep->log_utime), status_name(rep->msg.status).c_str(),
                  reply_note(rep->msg).c_str());
    }
    if (progress > 0) std::printf("      %11s  (%d PROGRESS)\n", "", progress);
    const bool terminal = std::any_of(th.replies.begin(), th.replies.end(),
                                      [](const Logged<reply_t>* r) { return client::is_terminal(r->msg.status); });
    if (!terminal) std::printf("      (no terminal reply in the log)\n");
  }

  const auto trajectories = view.trajectories();
  std::printf("\naxis trajectories (%zu axes):\n", trajectories.size());
  if (trajectories.empty()) std::printf("  (no axis state)\n");
  for (const auto& [axis, samples] : trajectories) {
    const auto& first = samples.front()->msg;
    std::printf("\n  axis %s (%s on %s, node %d): %zu samples\n", axis.c_str(), first.family.c_str(), first.bus.c_str(),
                first.node_id, samples.size());
    std::printf("  %11s %14s %12s %-6s %-7s %-6s %s\n", "T", "POSITION", "VELOCITY", "MOVING", "ENABLED", "ONLINE",
                "FAULT");
    // Runs of identical samples (an axis at rest) are shown once, with their count.
    for (std::size_t i = 0; i < samples.size();) {
      const auto& s = samples[i]->msg;
      std::size_t j = i + 1;
      while (j < samples.size()) {
        const auto& n = samples[j]->msg;
        if (n.position_counts != s.position_counts || n.velocity != s.velocity || n.moving != s.moving ||
            n.enabled != s.enabled || n.online != s.online || n.fault != s.fault) {
          break;
        }
        ++j;
      }
      std::printf("  %+9.3f s %14.4f %12.4f %-6s %-7s %-6s %s", view.t(samples[i]->log_utime), s.position, s.velocity,
                  s.moving ? "yes" : "no", s.enabled ? "yes" : "no", s.online ? "yes" : "no",
                  s.fault ? (s.fault_text.empty() ? std::to_string(s.fault_code).c_str() : s.fault_text.c_str()) : "-");
      if (j - i > 1) std::printf("  (x%zu until %+.3f s)", j - i, view.t(samples[j - 1]->log_utime));
      std::printf("\n");
      i = j;
    }
  }
}

// The same content as the tables, as one JSON document: channels, requests with every reply
// (PROGRESS included), and each axis's samples (all of them: runs are not folded).
nlohmann::json log_json(const std::string& path, const std::string& prefix, const LogContents& log, const View& view) {
  nlohmann::json out = {
      {"file", path}, {"events", log.events}, {"duration_s", view.t(log.last_utime)}, {"channel_prefix", prefix}};
  out["channels"] = nlohmann::json::object();
  for (const auto& [channel, count] : log.channel_counts) out["channels"][channel] = count;
  out["requests"] = nlohmann::json::array();
  for (const auto& th : view.threads()) {
    nlohmann::json j = {{"key", th.key}};
    if (th.request != nullptr) {
      const auto& r = th.request->msg;
      j.update({{"t", view.t(th.request->log_utime)},
                {"client_id", r.client_id},
                {"request_id", r.request_id},
                {"kind", kind_name(r.kind)},
                {"axes", r.axes},
                {"values", has_values(r.kind) ? nlohmann::json(r.values) : nlohmann::json::array()},
                {"velocity_scale", r.velocity_scale},
                {"acceleration_scale", r.acceleration_scale}});
    } else {
      j["request"] = nullptr;  // the request is not in the log
    }
    j["replies"] = nlohmann::json::array();
    bool terminal = false;
    for (const auto* rep : th.replies) {
      const auto& r = rep->msg;
      terminal = terminal || client::is_terminal(r.status);
      nlohmann::json one = {{"t", view.t(rep->log_utime)},
                            {"status", status_name(r.status)},
                            {"error_code", r.error_code},
                            {"reason", r.reason}};
      if (r.status == reply_t::PROGRESS) one["progress"] = r.progress;
      if (r.status == reply_t::ACCEPTED && r.predicted_duration_s > 0) {
        one.update({{"predicted_duration_s", r.predicted_duration_s}, {"predicted_skew_us", r.predicted_skew_us}});
      }
      if (client::is_terminal(r.status)) {
        one["positions"] = nlohmann::json::object();
        for (std::size_t i = 0; i < r.axes.size() && i < r.positions.size(); ++i)
          one["positions"][r.axes[i]] = r.positions[i];
        if (r.measured_start_skew_us >= 0) one["measured_start_skew_us"] = r.measured_start_skew_us;
      }
      j["replies"].push_back(std::move(one));
    }
    j["terminal"] = terminal;
    out["requests"].push_back(std::move(j));
  }
  out["axes"] = nlohmann::json::object();
  for (const auto& [axis, samples] : view.trajectories()) {
    nlohmann::json list = nlohmann::json::array();
    for (const auto* sample : samples) {
      const auto& m = sample->msg;
      list.push_back({{"t", view.t(sample->log_utime)},
                      {"position", m.position},
                      {"position_counts", m.position_counts},
                      {"velocity", m.velocity},
                      {"moving", m.moving != 0},
                      {"enabled", m.enabled != 0},
                      {"online", m.online != 0},
                      {"fault", m.fault != 0},
                      {"fault_text", m.fault_text}});
    }
    out["axes"][axis] = {{"family", samples.front()->msg.family},
                         {"bus", samples.front()->msg.bus},
                         {"node", samples.front()->msg.node_id},
                         {"samples", std::move(list)}};
  }
  return out;
}

// One long table: `record` says which columns apply (request, reply or state).
void write_csv(std::ostream& out, const LogContents& log, const View& view) {
  out << "record,t_s,utime,axis,position,velocity,moving,enabled,online,fault,client_id,request_id,kind,status,error_"
         "code,"
         "predicted_skew_us,measured_skew_us,detail\n";
  struct Row {
    std::int64_t log_utime;
    std::string text;
  };
  std::vector<Row> rows;
  for (const auto& th : view.threads()) {
    if (th.request != nullptr) {
      const auto& r = th.request->msg;
      std::ostringstream s;
      s << "request," << number(view.t(th.request->log_utime)) << "," << r.utime << ","
        << csv_field(joined(r.axes, ";")) << ",,,,,,," << csv_field(r.client_id) << "," << r.request_id << ","
        << kind_name(r.kind) << ",,,,," << csv_field(request_axes(r, ";"));
      rows.push_back({th.request->log_utime, s.str()});
    }
    for (const auto* rep : th.replies) {
      const auto& r = rep->msg;
      std::ostringstream s;
      s << "reply," << number(view.t(rep->log_utime)) << "," << r.utime << "," << csv_field(joined(r.axes, ";"))
        << ",,,,,,," << csv_field(r.client_id) << "," << r.request_id << ",," << status_name(r.status) << ","
        << r.error_code << "," << number(r.predicted_skew_us, "%.1f") << "," << number(r.measured_start_skew_us, "%.1f")
        << "," << csv_field(r.reason);
      rows.push_back({rep->log_utime, s.str()});
    }
  }
  for (const auto& s : log.states) {
    if (!view.axis_selected(s.msg.axis)) continue;
    const auto& m = s.msg;
    std::ostringstream o;
    o << "state," << number(view.t(s.log_utime)) << "," << m.utime << "," << csv_field(m.axis) << ","
      << number(m.position, "%.6f") << "," << number(m.velocity, "%.6f") << "," << (m.moving ? 1 : 0) << ","
      << (m.enabled ? 1 : 0) << "," << (m.online ? 1 : 0) << "," << (m.fault ? 1 : 0) << ",,,,,,,,"
      << csv_field(m.fault ? m.fault_text : std::string());
    rows.push_back({s.log_utime, o.str()});
  }
  std::stable_sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) { return a.log_utime < b.log_utime; });
  for (const auto& r : rows) out << r.text << "\n";
}

// The trajectories as SVG panels, time from the log's first event; the STARTED reply of a request
// that moves axes, its planned arrival (STARTED + predicted duration) and its terminal reply are
// marked in the panels of its axes (a request not in the log counts when it was STARTED). `units`:
// axis -> user unit, when known.
std::string plot_svg(const std::string& path, const View& view, const std::map<std::string, std::string>& units) {
  std::vector<web::PlotAxis> axes;
  for (const auto& [axis, samples] : view.trajectories()) {
    web::PlotAxis plot{axis, units.contains(axis) ? units.at(axis) : std::string(), {}};
    plot.samples.reserve(samples.size());
    for (const auto* s : samples) plot.samples.push_back({view.t(s->log_utime), s->msg.position, s->msg.velocity});
    axes.push_back(std::move(plot));
  }
  std::vector<web::PlotMark> marks;
  for (const auto& th : view.threads()) {
    const bool started = std::any_of(th.replies.begin(), th.replies.end(),
                                     [](const Logged<reply_t>* r) { return r->msg.status == reply_t::STARTED; });
    if (th.request != nullptr ? !lcm::request_kind_moves(th.request->msg.kind) : !started) continue;
    const char* kind = th.request != nullptr ? lcm::request_kind_words(th.request->msg.kind) : "request";
    for (const auto* rep : th.replies) {
      const auto& r = rep->msg;
      if (r.status != reply_t::STARTED && !client::is_terminal(r.status)) continue;
      const auto& names = !r.axes.empty() || th.request == nullptr ? r.axes : th.request->msg.axes;
      marks.push_back({view.t(rep->log_utime), std::string(kind) + " " + client::status_name(r.status), names});
      // Where the coordinator planned the axes to arrive: STARTED + its predicted duration.
      if (r.status == reply_t::STARTED && r.predicted_duration_s > 0) {
        marks.push_back(
            {view.t(rep->log_utime) + r.predicted_duration_s, std::string(kind) + " planned arrival", names});
      }
    }
  }
  return web::svg_plot(axes, marks, {.title = "motionctl log " + path});
}

int run_log(const Context& ctx, const LogArgs& args) {
  if (!log::init("motionctl", ctx.options.log_level)) return app::kExitUsage;
  std::string prefix = args.prefix;
  std::map<std::string, std::string> units;
  if (prefix.empty()) {
    auto config = app::load_config(ctx.options);
    if (!config) return app::kExitConfig;
    prefix = config->lcm.channel_prefix;
    for (const auto& axis : config->axes) units[axis.name] = axis.unit;
  }
  const auto log = read_log(args.file, prefix);
  if (!log) return app::kExitFailure;
  const View view(*log, args.axes);

  if (log->events == 0 && log->corruption) {  // nothing readable: no empty tables, only the error
    std::cerr << "motionctl: '" << args.file << "' is not an LCM event log: " << *log->corruption << "\n";
    return app::kExitFailure;
  }
  if (ctx.json && !args.csv.empty()) {
    std::cerr << "motionctl: log: --json and --csv both choose the output; give one of them\n";
    return app::kExitUsage;
  }
  if (ctx.json) {
    std::cout << log_json(args.file, prefix, *log, view).dump(2) << "\n";
  } else if (args.csv.empty()) {
    print_tables(args.file, prefix, *log, view);
  } else if (args.csv == "-") {
    write_csv(std::cout, *log, view);
  } else {
    std::ofstream out(args.csv, std::ios::trunc);
    if (!out) {
      std::cerr << "motionctl: cannot write '" << args.csv << "': " << std::strerror(errno) << "\n";
      return app::kExitFailure;
    }
    write_csv(out, *log, view);
    out.close();
    if (!out) {
      std::cerr << "motionctl: writing '" << args.csv << "' failed\n";
      return app::kExitFailure;
    }
    std::size_t states = 0;
    for (const auto& [axis, samples] : view.trajectories()) states += samples.size();
    std::printf("%s: %" PRId64 " events over %.3f s; wrote %zu requests, %zu replies, %zu axis states to %s\n",
                args.file.c_str(), log->events, view.t(log->last_utime), log->requests.size(), log->replies.size(),
                states, args.csv.c_str());
  }

  if (!args.plot.empty()) {
    std::ofstream out(args.plot, std::ios::trunc);
    if (out) out << plot_svg(args.file, view, units);
    out.close();
    if (!out) {
      std::cerr << "motionctl: cannot write the plot '" << args.plot << "': " << std::strerror(errno) << "\n";
      return app::kExitFailure;
    }
    std::fprintf(args.csv == "-" || ctx.json ? stderr : stdout, "plot of %zu axes written to %s\n",
                 view.trajectories().size(), args.plot.c_str());
  }

  const auto trajectories = view.trajectories();
  for (const auto& axis : args.axes) {
    if (!trajectories.contains(axis)) std::cerr << "motionctl: warning: no state of axis '" << axis << "' in the log\n";
  }
  if (log->undecodable > 0) {
    std::cerr << "motionctl: warning: " << log->undecodable
              << " messages could not be decoded (another version of the types?) on";
    for (const auto& c : log->undecodable_channels) std::cerr << " " << c;
    std::cerr << "\n";
  }
  if (log->events == 0 && !log->corruption && !log->truncated)
    std::cerr << "motionctl: warning: the log '" << args.file << "' holds no events\n";
  if (log->truncated) std::cerr << "motionctl: warning: ignored a truncated final record (" << *log->truncated << ")\n";
  if (log->corruption) {
    std::cerr << "motionctl: log '" << args.file << "' is corrupt: " << *log->corruption << "; " << log->events
              << " events read before it\n";
    return app::kExitFailure;
  }
  return app::kExitOk;
}

}  // namespace

void add_log_command(CLI::App& cli, Context& ctx) {
  auto* cmd = cli.add_subcommand("log", "Requests, replies and axis trajectories of an LCM event log (lcm-logger)");
  auto args = std::make_shared<LogArgs>();
  cmd->add_option("file", args->file, "LCM event log written by lcm-logger")->required();
  cmd->add_option("--csv", args->csv, "Write CSV to this file ('-' = stdout) instead of the tables");
  cmd->add_option("--axis", args->axes, "Only these axes (trajectories, and the requests naming them)");
  cmd->add_option("--prefix", args->prefix, "Channel prefix (default: the configuration's lcm.channel_prefix)");
  cmd->add_option(
      "--plot", args->plot,
      "Also write the trajectories as SVG to this file: one panel per axis, position and velocity over time");
  cmd->callback([&ctx, args] { ctx.result = run_log(ctx, *args); });
}

}  // namespace motion::ctl
