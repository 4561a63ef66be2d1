// Runs a generated case on real processes and checks the reference model after every step
// (shrink.cpp shrinks failing cases and prints them as C++).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>
#include <set>

#include <motionlcm/health_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>
#include <motionlcm/sim_control_t.hpp>

#include "motion/client/client.hpp"
#include "motion/core/clock.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/reply_error.hpp"
#include "motion/lcm/request_kinds.hpp"
#include "motion/security/keys.hpp"
#include "motion/testing/lab_keys.hpp"
#include "motion/testing/lcm_url.hpp"
#include "motion/testing/process_group.hpp"
#include "random_lab.hpp"

namespace motion::random_lab {
namespace {

// A process's arguments, with --log-level $RANDOM_LAB_LOG_LEVEL when that is set.
std::vector<std::string> log_args(std::vector<std::string> args) {
  if (const char* level = std::getenv("RANDOM_LAB_LOG_LEVEL"); level != nullptr && *level != '\0') {
    args.insert(args.end(), {"--log-level", level});
  }
  return args;
}

using motionlcm::reply_t;
using motionlcm::request_t;
using std::chrono::milliseconds;
using std::chrono::seconds;

constexpr int kDefaultTimeoutMs = 20000;       // coordinator.default_timeout_ms of LabSpec::yaml()
constexpr std::int32_t kReplyLatencyUs = 200;  // simulation.reply_latency_us of LabSpec::yaml()

struct Failure {
  std::string what;
};

class Runner {
 public:
  Runner(const LabSpec& lab, const RunOptions& options)
      : lab_(lab), options_(options), group_(testing::unique_lcm_url(options.salt)), model_(lab) {
    for (int i = 0; i < 3; ++i) {
      clients_.push_back(
          std::make_unique<client::Client>(group_.loop(), group_.node(), "rl-client-" + std::to_string(i)));
      // Under security every client signs with a key of its own (admin: the model predicts no
      // role refusals); its client id becomes the key's.
      if (lab_.security)
        clients_.back()->sign_with(keys_.emplace_back(security::KeyPair::generate("rl-client-" + std::to_string(i))));
    }
    group_.node().subscribe<reply_t>(lcm::channels::kReply, [this](const reply_t& r, const std::string&) {
      if (client::is_terminal(r.status)) ++terminals_[{r.client_id, r.request_id}];
    });
  }

  RunResult run(const std::vector<Step>& steps) {
    RunResult result;
    try {
      start();
      for (std::size_t i = 0; i < steps.size(); ++i) {
        step_ = static_cast<int>(i);
        result.log += "step " + std::to_string(i) + ": " + describe(steps[i]) + "\n";
        if (options_.verbose) std::printf("  step %zu: %s\n", i, describe(steps[i]).c_str());
        run_step(steps[i]);
        check_invariants();
        result.steps_run = static_cast<int>(i) + 1;
      }
    } catch (const Failure& f) {
      result.ok = false;
      result.failed_step = step_;
      result.failure = f.what;
      if (options_.print_logs_on_failure) ADD_FAILURE() << f.what;  // the group prints the processes' logs
    }
    result.requests = static_cast<int>(sent_.size());
    result.faults = faults_;
    result.faults_biting = faults_biting_;
    return result;
  }

 private:
  [[noreturn]] void fail(const std::string& what) { throw Failure{what}; }

  void start() {
    const std::string path = group_.work_dir() + "/lab.yaml";
    if (lab_.security) {
      std::vector<std::string> principals;
      for (const auto& key : keys_) principals.push_back(key.authorized_line("admin"));
      if (const auto error = motion::testing::write_lab_keys(group_.work_dir(), principals))
        fail("lab start-up: cannot write the lab's keys: " + *error);
    }
    std::ofstream(path) << lab_.yaml();
    std::set<std::string> buses;
    for (const auto& a : lab_.axes) buses.insert(a.drive.bus);
    pids_["sim"] = group_.start({"sim", "motion-sim", log_args({"--config", path}), {}});
    for (const auto& bus : buses)
      pids_["gateway:" + bus] =
          group_.start({"gateway:" + bus, "motion-gateway", log_args({"--config", path, "--bus", bus}), {}});
    pids_["coordinator"] = group_.start({"coordinator", "motion-coordinator", log_args({"--config", path}), {}});
    for (const auto& [name, pid] : pids_) {
      const bool up = group_.pump_until(
          [&, &process = name] {  // not `name`: clang 14 (clang-tidy) does not capture structured bindings
            const auto h = group_.heartbeat(process);
            return h && (h->state == motionlcm::health_t::OK ||
                         (process != "coordinator" && h->state == motionlcm::health_t::DEGRADED));
          },
          seconds(20));
      if (!up) fail("lab start-up: no OK heartbeat from " + name + " within 20 s");
    }
    const bool online = clients_[0]->wait_until(
        [&] {
          for (const auto& a : lab_.axes) {
            const auto it = clients_[0]->axes().find(a.name);
            if (it == clients_[0]->axes().end() || !it->second.online) return false;
          }
          return true;
        },
        seconds(20));
    if (!online) fail("lab start-up: not every axis online within 20 s");
    for (const auto& a : lab_.axes) {
      const auto& s = state(a.name);
      model_.observe(a.name, s.position_counts);
      model_.axis(a.name).enabled = s.enabled;
    }
  }

  const motionlcm::axis_state_t& state(const std::string& axis) { return clients_[0]->axes().at(axis); }

  motionlcm::request_t make(std::int8_t kind, const std::vector<std::string>& axes, const std::vector<double>& values,
                            const Step& s) {
    auto r = client::Client::make(kind, axes);
    r.values = values;
    r.values.resize(axes.size(), 0.0);
    r.velocity_scale = s.velocity_scale;
    r.acceleration_scale = s.acceleration_scale;
    r.timeout_ms = s.timeout_ms;
    r.output_mask = s.output_mask;
    r.output_value = s.output_value;
    if (kind == request_t::PARAM_READ && !axes.empty()) r.param = param_for(axes[0]);
    return r;
  }

  // A parameter every family has, with the value the lab's set-up gives it.
  motionlcm::param_t param_for(const std::string& axis) {
    motionlcm::param_t p{};
    const auto& family = lab_.find(axis)->drive.family;
    if (family == "uc57") {
      p.space = motionlcm::param_t::CANOPEN_OBJECT;  // 1000h device type (CiA 301 §7.5.2.1)
      p.index = 0x1000;
    } else if (family == "adam-modbus") {
      p.space = motionlcm::param_t::MODBUS_REGISTER;  // 0x0024 subdivision, pulses/rev (ADAM manual §8.29)
      p.index = 0x0024;
      p.width = 2;
    } else if (family == "uim242") {
      p.space = motionlcm::param_t::UIM242_INSTRUCTION;  // CUR, phase current in tenths of an ampere
      p.mnemonic = "CUR";
      p.subindex = -1;
    } else {
      p.space = motionlcm::param_t::UIM342_INSTRUCTION;  // MT[0] micro-stepping (UIM342 manual §5.9)
      p.index = 0x10;
      p.subindex = 0;
    }
    return p;
  }
  std::optional<std::int64_t> expected_param(const std::string& axis) {
    const auto& family = lab_.find(axis)->drive.family;
    if (family == "adam-modbus") return 3200;  // 200 full steps x subdivision 16
    if (family == "uim242") return 10;         // current_a 1.0
    if (family == "uim342") return 16;
    return std::nullopt;  // uc57: checked as 402 in the low word
  }

  std::chrono::milliseconds wait_for(std::int32_t timeout_ms) const {
    return milliseconds((timeout_ms > 0 ? timeout_ms : kDefaultTimeoutMs) + 3000);
  }

  reply_t call(int client, const motionlcm::request_t& r) {
    auto& c = *clients_[static_cast<std::size_t>(client)];
    bool seen_terminal = false;
    reply_t result{};
    const auto id = c.send(r, [&](const reply_t& reply) {
      if (client::is_terminal(reply.status)) {
        result = reply;
        seen_terminal = true;
      }
    });
    sent_.push_back({c.id(), id});
    if (!c.wait_until([&] { return seen_terminal; }, wait_for(r.timeout_ms))) {
      fail(std::string("no terminal reply to ") + describe_request(r) + " within its timeout + 3 s");
    }
    last_reply_utime_ = wall_time_us();
    return result;
  }

  std::string describe_request(const motionlcm::request_t& r) const {
    Step s;
    s.kind = r.kind;
    s.axes = r.axes;
    s.values = r.values;
    s.velocity_scale = r.velocity_scale;
    s.acceleration_scale = r.acceleration_scale;
    s.timeout_ms = r.timeout_ms;
    return describe(s);
  }

  void check_reply(const reply_t& got, const Outcome& want, const motionlcm::request_t& r) {
    const bool status_ok = std::find(want.statuses.begin(), want.statuses.end(), got.status) != want.statuses.end();
    const bool code_ok = got.status == reply_t::DONE || want.codes.empty() ||
                         std::find(want.codes.begin(), want.codes.end(), got.error_code) != want.codes.end();
    if (!status_ok || !code_ok) {
      fail(describe_request(r) + ": model predicts " + want.text() + ", got " + client::status_name(got.status) +
           " code " + std::to_string(got.error_code) + " (\"" + got.reason + "\")");
    }
  }

  // One request, predicted, sent, checked and applied to the model.
  reply_t request(int client, std::int8_t kind, const std::vector<std::string>& axes, const std::vector<double>& values,
                  const Step& s) {
    auto want = model_.request(kind, axes, values, s.velocity_scale, s.acceleration_scale, s.timeout_ms, false);
    if (kind == request_t::SET_OUTPUTS && want.done()) {
      // A family without digital outputs says so (unsupported) and changes nothing.
      want = Outcome{{reply_t::DONE, reply_t::REJECTED, reply_t::FAILED}, {error_code(ReplyError::kUnsupported)}};
    }
    if (kind == request_t::JOG && want.done()) {
      // A gateway stops a jog before the axis limit (LIMIT event): the request, if still running,
      // ends ABORTED 15 with the axis stopped short of the limit, or FAILED 15 when the jog was
      // stopped before the gateway had confirmed it (it starts inside its braking distance).
      want = Outcome{{reply_t::DONE, reply_t::ABORTED, reply_t::FAILED}, {error_code(ReplyError::kAxisFault)}};
    }
    const auto r = make(kind, axes, values, s);
    auto got = call(client, r);  // not const: returned below, moved
    check_reply(got, want, r);
    if (got.status == reply_t::DONE ||
        (kind == request_t::JOG && (got.status == reply_t::ABORTED || got.status == reply_t::FAILED))) {
      model_.request(kind, axes, values, s.velocity_scale, s.acceleration_scale, s.timeout_ms, true);
      if (kind == request_t::PARAM_READ) {
        const auto expected = expected_param(axes[0]);
        const bool ok = expected ? got.param.value == *expected : (got.param.value & 0xFFFF) == 402;
        if (!ok)
          fail(describe_request(r) + ": read " + std::to_string(got.param.value) + ", the lab's set-up gives " +
               (expected ? std::to_string(*expected) : std::string("402 in the low word")));
      }
      if (kind == request_t::SET_OUTPUTS) {
        const std::string& axis = axes[0];
        const bool ok = clients_[0]->wait_until(
            [&] { return (state(axis).outputs & s.output_mask) == (s.output_value & s.output_mask); }, seconds(5));
        if (!ok)
          fail(describe_request(r) + ": outputs of " + axis + " read " + std::to_string(state(axis).outputs) +
               " after DONE");
      }
    }
    return got;
  }

  // Publishes one fault (or its end) to motion-sim for the drive of `axis` (its bus for line and
  // bus faults).
  void inject(std::int8_t action, std::int32_t value, const std::string& axis) {
    const AxisSpec& spec = *lab_.find(axis);
    motionlcm::sim_control_t c{};
    c.utime = wall_time_us();
    c.action = action;
    c.value = value;
    const bool bus_fault =
        action == motionlcm::sim_control_t::BUS_DROP || action == motionlcm::sim_control_t::LINE_NOISE;
    c.drive = bus_fault ? "" : spec.name + "-drive";
    c.bus = spec.drive.bus;
    c.level = action == motionlcm::sim_control_t::LINE_NOISE ? 1 : 0;
    group_.node().publish(lcm::channels::kSimControl, c);
  }

  // Chaos: a move with a fault on one drive (or bus) during it. What the move ends with depends on
  // timing, so only the invariants are checked: exactly one terminal reply within its timeout,
  // no axis beyond its limits, every process alive; then the lab must recover by itself once the
  // fault ends (every axis online; a reset and an enable, retried while an axis is still being
  // stopped or set up, end DONE) and the model reads the positions back.
  void run_fault(const Step& s) {
    using motionlcm::sim_control_t;
    ++faults_;
    auto& c = *clients_[static_cast<std::size_t>(s.client)];
    const auto want = model_.request(request_t::MOVE_ABSOLUTE, s.axes, s.values, s.velocity_scale, s.acceleration_scale,
                                     s.timeout_ms, false);
    const auto r = make(request_t::MOVE_ABSOLUTE, s.axes, s.values, s);
    std::optional<reply_t> got;
    const auto id = c.send(r, [&](const reply_t& reply) {
      if (client::is_terminal(reply.status)) got = reply;
    });
    sent_.push_back({c.id(), id});
    c.wait_until([] { return false; }, milliseconds(200));
    const std::string& target = s.second_axes.at(0);
    inject(s.fault, s.fault_value, target);
    c.wait_until([&] { return got.has_value(); }, seconds(1));
    // The fault lasts 1 s: a bus that drops "the next N frames" may carry fewer than N in that
    // time (a bus whose drives went offline carries only the gateway's backed-off probes).
    if (s.fault == sim_control_t::SILENCE || s.fault == sim_control_t::CRC_ERRORS ||
        s.fault == sim_control_t::BUS_DROP) {
      inject(s.fault, 0, target);
    }
    if (s.fault == sim_control_t::REPLY_LATENCY) inject(s.fault, kReplyLatencyUs, target);
    if (!c.wait_until([&] { return got.has_value(); }, wait_for(r.timeout_ms))) {
      fail("no terminal reply to " + describe_request(r) + " within its timeout + 3 s (" + fault_name(s.fault) +
           " on " + target + ")");
    }
    last_reply_utime_ = wall_time_us();
    if (!want.done()) check_reply(*got, want, r);  // refused before anything moved, whatever the fault
    if (got->status != reply_t::DONE && want.done()) ++faults_biting_;
    if (got->status == reply_t::DONE) {
      model_.request(request_t::MOVE_ABSOLUTE, s.axes, s.values, s.velocity_scale, s.acceleration_scale, s.timeout_ms,
                     true);
    } else if (got->status != reply_t::REJECTED) {
      // It may have moved part-way: the next relative move counts from where it stands. A refused
      // move left nothing behind, the base of a relative move included.
      for (const auto& a : s.axes) model_.axis(a).at_target = false;
    }
    recover(std::string(fault_name(s.fault)) + " on " + target);
  }

  void recover(const std::string& after) {
    const bool online = clients_[0]->wait_until(
        [&] {
          for (const auto& a : lab_.axes) {
            const auto it = clients_[0]->axes().find(a.name);
            if (it == clients_[0]->axes().end() || !it->second.online || it->second.moving) return false;
          }
          return true;
        },
        seconds(30));
    if (!online) fail("after " + after + ": not every axis online and at rest within 30 s");
    std::vector<std::string> all;
    for (const auto& a : lab_.axes) all.push_back(a.name);
    for (const std::int8_t kind : {request_t::FAULT_RESET, request_t::ENABLE}) {
      reply_t got{};
      const auto deadline = std::chrono::steady_clock::now() + seconds(30);
      do {
        got = call(0, make(kind, all, {}, Step{}));
        if (got.status == reply_t::DONE) break;
        clients_[0]->wait_until([] { return false; }, milliseconds(500));
      } while (std::chrono::steady_clock::now() < deadline);
      if (got.status != reply_t::DONE) {
        fail("after " + after + ": " + std::string(lcm::request_kind_name(kind)) + " of every axis ends " +
             client::status_name(got.status) + " code " + std::to_string(got.error_code) + " (\"" + got.reason +
             "\") for 30 s");
      }
    }
    // A drive that lost power says so (README "Safety and faults"): its moves are refused until
    // its position is set again, here to where it says it stands (what the model reads back).
    for (const auto& a : lab_.axes) {
      const auto it = clients_[0]->axes().find(a.name);
      if (it == clients_[0]->axes().end() || it->second.fault_code != motionlcm::axis_state_t::POSITION_LOST) continue;
      const auto set = call(0, make(request_t::SET_POSITION, {a.name}, {it->second.position}, Step{}));
      if (set.status != reply_t::DONE) {
        fail("after " + after + ": " + a.name + " lost its position, and SET_POSITION " +
             std::to_string(it->second.position) + " ends " + client::status_name(set.status) + " code " +
             std::to_string(set.error_code) + " (\"" + set.reason + "\")");
      }
    }
    for (const auto& a : lab_.axes) {
      model_.axis(a.name).counts.reset();
      model_.axis(a.name).enabled = true;
    }
    settle(true);
  }

  void run_step(const Step& s) {
    if (s.op == Op::kFault) return run_fault(s);
    if (s.op == Op::kRequest) {
      request(s.client, s.kind, s.axes, s.values, s);
      settle(s.kind == request_t::STOP || s.kind == request_t::ESTOP);
      return;
    }
    if (s.op == Op::kJogStop) {
      const auto jog = request(s.client, request_t::JOG, s.axes, s.values, s);
      if (jog.status == reply_t::DONE) clients_[0]->wait_until([] { return false; }, milliseconds(300));
      request(s.other_client, s.stop_kind, s.axes, {}, Step{});
      settle(true);
      return;
    }
    // Conflict: a slow move runs while another client asks for its axes (or others).
    const auto want = model_.request(request_t::MOVE_ABSOLUTE, s.axes, s.values, s.velocity_scale, s.acceleration_scale,
                                     s.timeout_ms, false);
    // The generator aimed at the farther limit from where its own model put the axes. A step
    // before may have ended otherwise here (a relative move from a read-back position refused as
    // beyond a limit: seed 30082), leaving the axes at that target already: then the move has
    // nothing to do and is DONE at once, as any move of axes at their targets.
    bool nothing_to_do = want.done();
    for (std::size_t i = 0; i < s.axes.size() && nothing_to_do; ++i) {
      const auto& counts = model_.axis(s.axes[i]).counts;
      nothing_to_do = counts && *counts == model_.counts_of(s.axes[i], s.values[i]);
    }
    const bool slow = want.done() && !nothing_to_do;
    auto& first_client = *clients_[static_cast<std::size_t>(s.client)];
    std::vector<reply_t> replies;
    const auto first_request = make(request_t::MOVE_ABSOLUTE, s.axes, s.values, s);
    const auto id = first_client.send(first_request, [&](const reply_t& r) { replies.push_back(r); });
    sent_.push_back({first_client.id(), id});
    const auto terminal = [&]() -> const reply_t* {
      for (const auto& r : replies)
        if (client::is_terminal(r.status)) return &r;
      return nullptr;
    };
    const bool started = first_client.wait_until(
        [&] {
          return terminal() != nullptr || std::any_of(replies.begin(), replies.end(),
                                                      [](const reply_t& r) { return r.status == reply_t::STARTED; });
        },
        seconds(10));
    if (slow) {
      if (!started || terminal() != nullptr) {
        fail(describe_request(first_request) + ": the model predicts a move of ~10 s; " +
             (terminal() ? std::string("it ended at once: ") + client::status_name(terminal()->status) + " code " +
                               std::to_string(terminal()->error_code) + " (\"" + terminal()->reason + "\")"
                         : "no STARTED within 10 s"));
      }
      model_.set_busy(s.axes, true);
    } else {
      if (!first_client.wait_until([&] { return terminal() != nullptr; }, wait_for(0)))
        fail(describe_request(first_request) + ": no terminal reply");
      check_reply(*terminal(), want, first_request);
      if (nothing_to_do) {
        model_.request(request_t::MOVE_ABSOLUTE, s.axes, s.values, s.velocity_scale, s.acceleration_scale, s.timeout_ms,
                       true);
      }
    }
    Step second;
    second.kind = s.second_kind;
    request(s.other_client, s.second_kind, s.second_axes, s.second_values, second);
    model_.set_busy(s.axes, false);
    if (slow) {
      // The slow move's target is not reached: its axes' positions are read back, and relative
      // moves count from there.
      for (const auto& a : s.axes) {
        model_.axis(a).counts.reset();
        model_.axis(a).at_target = false;
      }
    }
    // A jog the second request started on a free axis would run on: the stop covers its axes too.
    std::vector<std::string> stop_axes = s.axes;
    if (s.second_kind == request_t::JOG)
      for (const auto& a : s.second_axes)
        if (std::find(stop_axes.begin(), stop_axes.end(), a) == stop_axes.end()) stop_axes.push_back(a);
    request(s.other_client, s.stop_kind, stop_axes, {}, Step{});
    if (slow) {
      if (!first_client.wait_until([&] { return terminal() != nullptr; }, seconds(5))) {
        fail(describe_request(first_request) + ": no terminal reply within 5 s of the stop of its axes");
      }
      const auto* t = terminal();
      const bool ok = (t->status == reply_t::ABORTED && t->error_code == error_code(ReplyError::kStopped)) ||
                      t->status == reply_t::DONE;
      if (!ok) {
        fail(describe_request(first_request) + ": stopped by another client; expected ABORTED code 14, got " +
             client::status_name(t->status) + " code " + std::to_string(t->error_code) + " (\"" + t->reason + "\")");
      }
    }
    settle(true);
  }

  // Waits for every axis to stand still at the model's position with the model's enabled flag,
  // in a state sampled after the step's last reply; reads back the positions the model cannot know.
  void settle(bool after_stop) {
    const std::int64_t since = last_reply_utime_;
    std::string why;
    const bool ok = clients_[0]->wait_until(
        [&] {
          why.clear();
          for (const auto& [name, m] : model_.axes()) {
            const auto it = clients_[0]->axes().find(name);
            if (it == clients_[0]->axes().end()) {
              why += name + ": no state; ";
              continue;
            }
            const auto& st = it->second;
            if (st.utime <= since) {
              why += name + ": no state since the reply; ";
              continue;
            }
            if (st.moving) why += name + ": still moving" + std::string(after_stop ? " after a stop" : "") + "; ";
            if (m.counts && st.position_counts != *m.counts) {
              why += name + ": at " + std::to_string(st.position_counts) + " counts, the model says " +
                     std::to_string(*m.counts) + "; ";
            }
            if (st.enabled != m.enabled)
              why += name + ": enabled=" + (st.enabled ? "true" : "false") + ", the model says " +
                     (m.enabled ? "true" : "false") + "; ";
            if (st.fault) why += name + ": faulted (" + st.fault_text + "); ";
          }
          return why.empty();
        },
        seconds(10));
    if (!ok) fail("after the step, within 10 s: " + why);
    for (const auto& [name, m] : model_.axes()) {
      if (!m.counts) model_.observe(name, state(name).position_counts);
      // No request (a jog running into a limit included) leaves an axis beyond its limits.
      const AxisSpec& spec = *lab_.find(name);
      const auto at = static_cast<double>(state(name).position_counts);
      if (at < spec.min * spec.steps_per_unit - 1 || at > spec.max * spec.steps_per_unit + 1) {
        fail(name + ": at " + std::to_string(state(name).position_counts) + " counts (" +
             std::to_string(at / spec.steps_per_unit) + " u), beyond its limits [" + std::to_string(spec.min) + ", " +
             std::to_string(spec.max) + "] u");
      }
    }
  }

  void check_invariants() {
    for (const auto& [client, id] : sent_) {
      const int n = terminals_[{client, id}];
      if (n != 1)
        fail("request " + client + "/" + std::to_string(id) + " got " + std::to_string(n) + " terminal replies");
    }
    const auto now = wall_time_us();
    for (const auto& [name, pid] : pids_) {
      if (auto status = group_.exit_status(pid)) fail(name + " exited with status " + std::to_string(*status));
      const auto h = group_.heartbeat(name);
      if (!h || now - h->utime > 3LL * h->period_ms * 1000 + 500000) fail(name + " stopped heartbeating");
    }
  }

  LabSpec lab_;
  RunOptions options_;
  testing::ProcessGroup group_;
  Model model_;
  std::vector<security::KeyPair> keys_;  // the clients' keys under security (lab_.security)
  std::vector<std::unique_ptr<client::Client>> clients_;
  std::map<std::string, pid_t> pids_;
  std::map<std::pair<std::string, std::int64_t>, int> terminals_;
  std::vector<std::pair<std::string, std::int64_t>> sent_;
  std::int64_t last_reply_utime_ = 0;
  int step_ = -1;
  int faults_ = 0;
  int faults_biting_ = 0;
};

}  // namespace

RunResult run_case(const LabSpec& lab, const std::vector<Step>& steps, const RunOptions& options) {
  RunOptions chosen = options;
  // RANDOM_LAB_LOGS=1: a failing case prints the logs of the lab's processes (run them at a
  // finer level with RANDOM_LAB_LOG_LEVEL=debug|trace).
  if (const char* logs = std::getenv("RANDOM_LAB_LOGS"); logs != nullptr && std::string(logs) == "1")
    chosen.print_logs_on_failure = true;
  Runner runner(lab, chosen);
  return runner.run(steps);
}

}  // namespace motion::random_lab
