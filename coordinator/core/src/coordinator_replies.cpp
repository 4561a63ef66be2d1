// The coordinator core: what goes out (replies, gateway commands, events, ACTIVE_MOVES) and the
// end of a request.
#include "motion/coordinator/coordinator.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <vector>

#include "coordinator_kinds.hpp"

namespace motion::coordinator {

using namespace detail;

void Coordinator::reply_unknown(const request_t& msg, std::int8_t status, ReplyError error, const std::string& reason) {
  reply_t out{};
  out.utime = wall_clock_();
  out.client_id = msg.client_id;
  out.request_id = msg.request_id;
  out.status = status;
  out.reason = reason;
  out.error_code = static_cast<std::int32_t>(error);
  out_.reply(out);
  // A refusal for the moment (its ids taken, the coordinator full) is decided anew when sent again.
  if (error != ReplyError::kDuplicateRequest && error != ReplyError::kBusy) remember(msg, out);
  const char* ended = status == reply_t::REJECTED ? "rejected" : status == reply_t::ABORTED ? "aborted" : "failed";
  spdlog::info("request {}/{} ({}) {}: {}", msg.client_id, msg.request_id, kind_name(msg.kind), ended, reason);
}

void Coordinator::publish_event(const std::string& axis, std::int8_t severity, std::int16_t kind,
                                const std::string& text) {
  motionlcm::event_t e{};
  e.utime = wall_clock_();
  e.source = "coordinator";
  e.bus = axes_.contains(axis) ? axes_.at(axis).drive->bus : std::string();
  e.axis = axis;
  e.severity = severity;
  e.kind = kind;
  e.text = text;
  out_.event(e);
}

std::int64_t Coordinator::send_command(Request& r, const std::string& bus, std::int8_t kind,
                                       std::vector<motionlcm::axis_command_t> axes) {
  gateway_command_t c{};
  c.utime = wall_clock_();
  c.bus = bus;
  c.command_id = next_command_id_++;
  c.request_id = r.msg.request_id;
  c.kind = kind;
  c.trigger_id = kind == gateway_command_t::ARM_MOVE || kind == gateway_command_t::DISARM ? r.trigger_id : 0;
  c.axes = std::move(axes);
  c.num_axes = static_cast<std::int32_t>(c.axes.size());
  c.param = r.msg.param;
  auto c2 = to_grid(c, &r.grid);
  out_.gateway_command(bus, c2, c);
  r.pending[c.command_id] = PendingCommand{bus, false, c, std::move(c2), false, now_ + kCommandResend};
  return c.command_id;
}

void Coordinator::reply(Request& r, std::int8_t status, ReplyError error, const std::string& reason) {
  reply_t out{};
  out.utime = wall_clock_();
  out.client_id = r.msg.client_id;
  out.request_id = r.msg.request_id;
  out.status = status;
  out.reason = reason;
  out.error_code = static_cast<std::int32_t>(error);
  out.predicted_duration_s = r.plan.duration_s;
  out.predicted_skew_us = r.plan.predicted_skew_us;
  // Start times are the gateways' stamps of their start frames on the wire, per start mechanism
  // (one ARM_MOVE each: a UIM342 group's BG, a UC57 SYNC, an ADAM broadcast, ...). The measured
  // skew spans the earliest start frame to the latest, a sequential start's own spread included.
  std::int64_t first = 0;
  double last = 0;
  for (const auto& [command, start] : r.started_utime) {
    if (start == 0) continue;
    const auto spread = r.start_spread_us.find(command);
    first = first == 0 ? start : std::min(first, start);
    last = std::max(last, static_cast<double>(start) + (spread != r.start_spread_us.end() ? spread->second : 0.0));
  }
  double progress_sum = 0;
  for (const auto& name : r.axes) {
    const AxisLive& a = axes_.at(name);
    out.axes.push_back(name);
    const double pos = a.state ? a.state->position : 0.0;
    out.positions.push_back(pos);
    const double counts_per_unit = a.axis->steps_per_unit * (a.axis->invert ? -1.0 : 1.0);
    auto t = r.targets.find(name);
    out.targets.push_back(t != r.targets.end() ? static_cast<double>(t->second) / counts_per_unit : 0.0);
    const auto command = r.axis_command.find(name);
    const auto started =
        command != r.axis_command.end() ? r.started_utime.find(command->second) : r.started_utime.end();
    const std::int64_t start = started != r.started_utime.end() ? started->second : 0;
    out.start_utime.push_back(start);
    if (t != r.targets.end() && a.state) {
      const double span = static_cast<double>(t->second - r.starts[name]);
      progress_sum +=
          span == 0 ? 1.0 : std::clamp(static_cast<double>(a.state->position_counts - r.starts[name]) / span, 0.0, 1.0);
    }
  }
  out.num_axes = static_cast<std::int32_t>(out.axes.size());
  out.measured_start_skew_us = first == 0 ? 0.0 : last - static_cast<double>(first);
  out.progress =
      status == reply_t::DONE ? 1.0 : (r.axes.empty() ? 0.0 : progress_sum / static_cast<double>(r.axes.size()));
  out.param = r.param_result;
  out_.reply(out);
  r.last_reply = out;
  if (terminal(status)) {
    remember(r.msg, out);
    r.phase = Phase::kDone;
    if (is_motion(r.msg.kind)) publish_active_moves();
  }
  if (status == reply_t::DONE) {
    spdlog::info("request {}/{} ({}) done", r.msg.client_id, r.msg.request_id, kind_name(r.msg.kind));
  }
}

void Coordinator::finish(std::uint64_t serial) {
  auto it = requests_.find(serial);
  if (it == requests_.end()) return;
  Request& r = *it->second;
  for (const auto& a : r.axes) {
    auto& live = axes_.at(a);
    if (live.busy_with == serial) live.busy_with = 0;
  }
  active_ids_.erase({r.msg.client_id, r.msg.request_id});
  requests_.erase(it);
}

namespace {

// The same request apart from its send time: every field of its encoding.
bool same_request(motionlcm::request_t a, motionlcm::request_t b) {
  a.utime = b.utime = 0;
  const int size = a.getEncodedSize();
  if (size != b.getEncodedSize()) return false;
  std::vector<std::uint8_t> x(static_cast<std::size_t>(size)), y(static_cast<std::size_t>(size));
  return a.encode(x.data(), 0, size) == size && b.encode(y.data(), 0, size) == size && x == y;
}

}  // namespace

bool Coordinator::answer_again(const request_t& msg) {
  const std::pair key{msg.client_id, msg.request_id};
  if (active_ids_.contains(key)) {
    for (const auto& [serial, r] : requests_) {
      if (r->msg.client_id != msg.client_id || r->msg.request_id != msg.request_id) continue;
      if (!same_request(r->msg, msg)) return false;  // REJECTED 9 by validate()
      if (r->last_reply) out_.reply(*r->last_reply);
      spdlog::debug("request {}/{} sent again: its latest reply repeated", msg.client_id, msg.request_id);
      return true;
    }
    return false;
  }
  const auto it = remembered_.find(key);
  if (it == remembered_.end() || !same_request(it->second.msg, msg)) return false;
  out_.reply(it->second.reply);
  spdlog::info("request {}/{} sent again after it ended: its terminal reply repeated", msg.client_id, msg.request_id);
  return true;
}

void Coordinator::remember(const request_t& msg, const reply_t& terminal) {
  std::pair key{msg.client_id, msg.request_id};
  if (remembered_.insert_or_assign(key, Answered{msg, terminal}).second) remembered_order_.push_back(std::move(key));
  while (remembered_order_.size() > kRememberedReplies) {
    remembered_.erase(remembered_order_.front());
    remembered_order_.pop_front();
  }
}

void Coordinator::publish_active_moves() {
  motionlcm::active_moves_t out{};
  out.utime = wall_clock_();
  for (const auto& [serial, rp] : requests_) {
    const Request& r = *rp;
    if (!is_motion(r.msg.kind) || r.phase == Phase::kDone) continue;
    for (const auto& name : r.axes) {
      const AxisLive& a = axes_.at(name);
      const std::string& bus = a.drive->bus;
      std::int64_t command = 0;
      if (const auto c = r.axis_command.find(name); c != r.axis_command.end()) {
        command = c->second;
      } else {
        // An axis without a command of its own (a still axis of a move, a jog, a homing run): a
        // command of its request on its bus not yet armed.
        for (const auto& [id, pending] : r.pending) {
          if (!pending.armed && pending.bus == bus) command = id;
        }
      }
      const auto target = r.targets.find(name);
      const std::int64_t counts = target != r.targets.end() ? target->second : 0;
      const double counts_per_unit = a.axis->steps_per_unit * (a.axis->invert ? -1.0 : 1.0);
      const bool moving = r.phase == Phase::kTriggered || (!is_move(r.msg.kind) && r.fire_utime != 0);
      out.axes.push_back(name);
      out.buses.push_back(bus);
      out.client_ids.push_back(r.msg.client_id);
      out.request_ids.push_back(r.msg.request_id);
      out.kinds.push_back(r.msg.kind);
      out.phases.push_back(moving ? std::int8_t{motionlcm::active_moves_t::MOVING}
                                  : std::int8_t{motionlcm::active_moves_t::ARMING});
      out.command_ids.push_back(command);
      out.target_counts.push_back(counts);
      out.targets.push_back(counts_per_unit != 0 ? static_cast<double>(counts) / counts_per_unit : 0.0);
      out.fire_utime.push_back(moving ? r.fire_utime : 0);
    }
  }
  out.num_axes = static_cast<std::int32_t>(out.axes.size());
  active_moves_published_ = out.num_axes > 0;
  out_.active_moves(out);
}

}  // namespace motion::coordinator
