#include "motion/web/lab_view.hpp"

#include <algorithm>

#include "motion/lcm/message_names.hpp"
#include "motion/lcm/request_kinds.hpp"

namespace motion::web {
namespace {

using motionlcm::reply_t;
using motionlcm::request_t;

// A DONE jog whose axes were never seen moving closes this long after its DONE.
constexpr std::int64_t kJogSettleUs = 1'000'000;

bool has_targets(std::int8_t kind) { return kind == request_t::MOVE_ABSOLUTE || kind == request_t::MOVE_RELATIVE; }

std::string move_id(const std::string& client_id, std::int64_t request_id) {
  return client_id + "/" + std::to_string(request_id);
}

template <typename T>
void keep_last(std::deque<T>& items, std::size_t limit) {
  while (items.size() > limit) items.pop_front();
}

}  // namespace

bool LabView::Move::open() const { return !lcm::reply_is_terminal(status) || following; }

LabView::LabView(const config::Config& config, LabViewLimits limits) : config_(config), limits_(limits) {}

Outgoing LabView::emit(const nlohmann::json& message) { return {++seq_, message.dump()}; }

nlohmann::json LabView::lab_json(const config::Config& config) {
  nlohmann::json axes = nlohmann::json::array();
  for (const auto& a : config.axes) {
    const auto* d = config.drive_of(a);
    axes.push_back({{"name", a.name},
                    {"unit", a.unit},
                    {"family", d != nullptr ? std::string(config::to_string(d->family)) : std::string()},
                    {"bus", d != nullptr ? d->bus : std::string()},
                    {"node", d != nullptr ? d->node_id : 0}});
  }
  nlohmann::json buses = nlohmann::json::array();
  for (const auto& b : config.buses) buses.push_back({{"name", b.name}, {"transport", b.transport}});
  return {
      {"type", "lab"}, {"file", config.file}, {"prefix", config.lcm.channel_prefix}, {"axes", axes}, {"buses", buses}};
}

nlohmann::json LabView::axis_json(const motionlcm::axis_state_t& s) {
  return {{"type", "axis"},
          {"axis", s.axis},
          {"utime", s.utime},
          {"sample_utime", s.sample_utime},
          {"family", s.family},
          {"bus", s.bus},
          {"node", s.node_id},
          {"group", s.group_id},
          {"position", s.position},
          {"position_counts", s.position_counts},
          {"velocity", s.velocity},
          {"target_counts", s.target_counts},
          {"online", s.online != 0},
          {"enabled", s.enabled != 0},
          {"moving", s.moving != 0},
          {"in_position", s.in_position != 0},
          {"homed", s.homed != 0},
          {"fault", s.fault != 0},
          {"fault_code", s.fault_code},
          {"fault_text", s.fault_text},
          {"inputs", s.inputs},
          {"outputs", s.outputs}};
}

nlohmann::json LabView::health_json(const motionlcm::health_t& h) {
  nlohmann::json buses = nlohmann::json::array();
  for (const auto& b : h.buses) {
    buses.push_back({{"name", b.name},
                     {"transport", b.transport},
                     {"state", b.state},
                     {"tx_frames", b.tx_frames},
                     {"rx_frames", b.rx_frames},
                     {"tx_bytes", b.tx_bytes},
                     {"rx_bytes", b.rx_bytes},
                     {"errors", b.errors},
                     {"timeouts", b.timeouts},
                     {"retries", b.retries},
                     {"bus_load", b.bus_load},
                     {"drives_online", b.drives_online},
                     {"drives_total", b.drives_total}});
  }
  return {{"type", "health"},         {"utime", h.utime},
          {"process", h.process},     {"role", h.role},
          {"host", h.host},           {"pid", h.pid},
          {"version", h.version},     {"state", lcm::health_state_name(h.state)},
          {"detail", h.detail},       {"uptime_s", h.uptime_s},
          {"period_ms", h.period_ms}, {"buses", buses}};
}

nlohmann::json LabView::event_json(const motionlcm::event_t& e) {
  return {{"type", "event"},
          {"utime", e.utime},
          {"source", e.source},
          {"axis", e.axis},
          {"bus", e.bus},
          {"node", e.node_id},
          {"severity", lcm::event_severity_name(e.severity)},
          {"kind", lcm::event_kind_name(e.kind)},
          {"kind_code", e.kind},
          {"code", e.code},
          {"text", e.text}};
}

nlohmann::json LabView::reply_json(const motionlcm::reply_t& r) {
  return {{"type", "reply"},
          {"utime", r.utime},
          {"id", move_id(r.client_id, r.request_id)},
          {"client_id", r.client_id},
          {"request_id", r.request_id},
          {"status", lcm::reply_status_name(r.status)},
          {"reason", r.reason},
          {"error_code", r.error_code},
          {"progress", r.progress},
          {"axes", r.axes},
          {"targets", r.targets},
          {"positions", r.positions},
          {"start_utime", r.start_utime},
          {"predicted_duration_s", r.predicted_duration_s},
          {"measured_start_skew_us", r.measured_start_skew_us}};
}

nlohmann::json LabView::active_moves_json(const motionlcm::active_moves_t& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (std::size_t i = 0; i < m.axes.size(); ++i) {
    rows.push_back({{"axis", m.axes[i]},
                    {"bus", m.buses[i]},
                    {"id", move_id(m.client_ids[i], m.request_ids[i])},
                    {"kind", lcm::request_kind_words(m.kinds[i])},
                    {"phase", m.phases[i] == motionlcm::active_moves_t::MOVING ? "moving" : "arming"},
                    {"target", m.targets[i]},
                    {"fire_utime", m.fire_utime[i]}});
  }
  return {{"type", "active_moves"}, {"utime", m.utime}, {"rows", rows}};
}

nlohmann::json LabView::move_json(const Move& m, bool with_samples) const {
  nlohmann::json out = {{"type", "move"},
                        {"id", m.id},
                        {"kind", m.kind != 0 ? lcm::request_kind_words(m.kind) : "motion"},
                        {"axes", m.axes},
                        {"targets", m.targets},
                        {"status", lcm::reply_status_name(m.status)},
                        {"open", m.open()},
                        {"reason", m.reason},
                        {"accepted_utime", m.accepted_utime},
                        {"started_utime", m.started_utime},
                        {"predicted_duration_s", m.predicted_duration_s},
                        {"end_utime", m.end_utime}};
  if (with_samples) {
    nlohmann::json samples = nlohmann::json::object();
    for (const auto& [axis, points] : m.samples) samples[axis] = points;
    out["samples"] = std::move(samples);
  }
  return out;
}

LabView::Move* LabView::find_move(const std::string& id) {
  const auto it = std::find_if(moves_.begin(), moves_.end(), [&](const Move& m) { return m.id == id; });
  return it == moves_.end() ? nullptr : &*it;
}

std::vector<Outgoing> LabView::on_axis_state(const motionlcm::axis_state_t& msg) {
  axes_[msg.axis] = msg;
  std::vector<Outgoing> out{emit(axis_json(msg))};
  for (auto& move : moves_) {
    if (!move.open() || std::find(move.axes.begin(), move.axes.end(), msg.axis) == move.axes.end()) continue;
    auto& points = move.samples[msg.axis];
    if (points.size() < limits_.samples_per_axis) {
      points.push_back(
          {static_cast<double>(msg.sample_utime != 0 ? msg.sample_utime : msg.utime), msg.position, msg.velocity});
    }
    if (msg.moving != 0) move.seen_moving = true;
    const bool all_stand = std::all_of(move.axes.begin(), move.axes.end(), [&](const std::string& axis) {
      const auto it = axes_.find(axis);
      return it != axes_.end() && it->second.moving == 0;
    });
    if (move.following && all_stand && (move.seen_moving || msg.utime - move.done_utime > kJogSettleUs)) {
      move.following = false;
      move.end_utime = msg.utime;
      out.push_back(emit(move_json(move, false)));
    }
  }
  return out;
}

std::vector<Outgoing> LabView::on_health(const motionlcm::health_t& msg) {
  health_[msg.process] = msg;
  // Clients (each motionctl run is one) come and go: one silent for a while, or stopped, is gone.
  std::erase_if(health_, [&](const auto& entry) {
    const auto& h = entry.second;
    return h.role == "client" &&
           (h.state == motionlcm::health_t::STOPPING || h.utime < msg.utime - limits_.client_silence_us);
  });
  return {emit(health_json(msg))};
}

std::vector<Outgoing> LabView::on_event(const motionlcm::event_t& msg) {
  events_.push_back(msg);
  keep_last(events_, limits_.events);
  return {emit(event_json(msg))};
}

void LabView::on_request(const motionlcm::request_t& msg) {
  if (requests_.size() >= limits_.pending_requests) requests_.erase(requests_.begin());
  requests_[move_id(msg.client_id, msg.request_id)] = RequestSeen{msg.kind, msg.axes, msg.values};
}

std::vector<Outgoing> LabView::on_reply(const motionlcm::reply_t& msg) {
  replies_.push_back(msg);
  keep_last(replies_, limits_.replies);
  std::vector<Outgoing> out{emit(reply_json(msg))};

  const std::string id = move_id(msg.client_id, msg.request_id);
  Move* move = find_move(id);
  if (move == nullptr) {
    // A move begins with its first ACCEPTED or STARTED reply; a request not heard counts as a
    // move when the reply names axes (the web view may have started after the request).
    const auto request = requests_.find(id);
    if (msg.status != reply_t::ACCEPTED && msg.status != reply_t::STARTED) {
      if (request != requests_.end() && lcm::reply_is_terminal(msg.status)) requests_.erase(request);  // e.g. rejected
      return out;
    }
    if (request == requests_.end() ? msg.axes.empty() : !lcm::request_kind_moves(request->second.kind)) {
      if (request != requests_.end()) requests_.erase(request);
      return out;
    }
    Move fresh;
    fresh.id = id;
    fresh.accepted_utime = msg.utime;
    if (request != requests_.end()) {
      fresh.kind = request->second.kind;
      fresh.axes = request->second.axes;
      if (fresh.kind == request_t::MOVE_ABSOLUTE) fresh.targets = request->second.values;
      requests_.erase(request);
    }
    if (fresh.axes.empty()) fresh.axes = msg.axes;
    moves_.push_back(std::move(fresh));
    // Closed moves go first when over the limit; an open one only when all are open.
    while (moves_.size() > limits_.moves) {
      const auto closed = std::find_if(moves_.begin(), moves_.end(), [](const Move& m) { return !m.open(); });
      moves_.erase(closed != moves_.end() ? closed : moves_.begin());
    }
    move = &moves_.back();
  } else if (msg.status == reply_t::PROGRESS) {
    return out;  // nothing the move shows changes with progress
  }

  // The coordinator's targets (absolute, in user units) replace what the request said.
  if ((move->kind == 0 || has_targets(move->kind)) && msg.axes == move->axes && msg.targets.size() == msg.axes.size() &&
      !msg.targets.empty()) {
    move->targets = msg.targets;
  }
  move->status = msg.status;
  if (msg.status == reply_t::STARTED && move->started_utime == 0) {
    const auto first = std::min_element(msg.start_utime.begin(), msg.start_utime.end(),
                                        [](std::int64_t a, std::int64_t b) { return a != 0 && (b == 0 || a < b); });
    move->started_utime = first != msg.start_utime.end() && *first != 0 ? *first : msg.utime;
  }
  if (msg.predicted_duration_s > 0) move->predicted_duration_s = msg.predicted_duration_s;
  if (lcm::reply_is_terminal(msg.status)) {
    move->end_utime = msg.utime;
    move->reason = msg.reason;
    // A jog is DONE when it runs (its axes may not report moving yet): its plot goes on until
    // they stand again.
    move->following = msg.status == reply_t::DONE && move->kind == request_t::JOG;
    if (move->following) {
      move->done_utime = msg.utime;
      move->end_utime = 0;
    }
  }
  out.push_back(emit(move_json(*move, false)));
  return out;
}

std::vector<Outgoing> LabView::on_active_moves(const motionlcm::active_moves_t& msg) {
  active_moves_ = msg;
  return {emit(active_moves_json(msg))};
}

Snapshot LabView::snapshot() const {
  Snapshot snap;
  snap.seq = seq_;
  snap.texts.push_back(lab_json(config_).dump());
  for (const auto& [name, state] : axes_) snap.texts.push_back(axis_json(state).dump());
  for (const auto& [name, health] : health_) snap.texts.push_back(health_json(health).dump());
  for (const auto& e : events_) snap.texts.push_back(event_json(e).dump());
  for (const auto& r : replies_) snap.texts.push_back(reply_json(r).dump());
  if (active_moves_) snap.texts.push_back(active_moves_json(*active_moves_).dump());
  for (const auto& m : moves_) snap.texts.push_back(move_json(m, true).dump());
  return snap;
}

}  // namespace motion::web
