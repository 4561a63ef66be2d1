// What the web view shows of the lab, as JSON messages for the browser: the passive half of
// motion-web. It takes the lab's LCM messages (decoded) and returns the JSON texts to send to every
// connected browser, and keeps what a browser that connects later needs to catch up (snapshot()):
// the configured axes, the last state of every axis, the last heartbeat of every process (clients
// only while they are heard), the
// last events (newest kept), and the recent moves with the samples of their axes.
//
// Messages (one JSON object each, "type" says which; times are wall-clock microseconds since the
// Unix epoch, as on the wire):
//   lab           the configuration: axes (name, unit, family, bus, node), buses, channel prefix
//   axis          one axis_state_t
//   health        one health_t, with its bus_stats_t
//   event         one event_t (kind and severity also as words)
//   reply         one reply_t (status as a word)
//   active_moves  the coordinator's ACTIVE_MOVES rows
//   move          a motion request (move, relative move, jog, home) from its first ACCEPTED or
//                 STARTED reply to its terminal one: id "client_id/request_id", kind, axes,
//                 targets, status, accepted/started/end times, the planned duration from the
//                 start (predicted_duration_s, 0 when not told); "samples" (per axis
//                 [[sample_utime, position, velocity], ...]) only in the snapshot. Live, the
//                 browser appends the axis messages of a move's axes to the move itself while the
//                 move is open ("open": status not terminal, or a jog that ended DONE whose
//                 axes still move), as this class does; a jog's move message is sent again with
//                 "open" false and its end time when the last of its axes stands.
//
// Every returned message carries a sequence number (1, 2, ...), and snapshot() the number of the
// last one it includes, so a browser that connects while messages are in flight skips those the
// snapshot already holds.
//
// Thread contract: none inside; the caller serializes every call (motion-web calls it from the
// LCM thread and snapshot() from the server thread under one mutex). Never blocks.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include <motionlcm/active_moves_t.hpp>
#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>

#include "motion/config/config.hpp"

namespace motion::web {

struct LabViewLimits {
  std::size_t events = 500;                     // events kept for the snapshot (the oldest go first)
  std::size_t moves = 30;                       // moves kept for the snapshot, open ones included
  std::size_t samples_per_axis = 20000;         // per move and axis; later samples of a longer move are dropped
  std::size_t replies = 100;                    // replies kept for the snapshot
  std::size_t pending_requests = 256;           // requests heard whose first reply has not come
  std::int64_t client_silence_us = 10'000'000;  // a client process (role "client") silent this long is forgotten
};

struct Outgoing {
  std::uint64_t seq = 0;
  std::string text;  // one JSON object
};

struct Snapshot {
  std::uint64_t seq = 0;           // the last message it includes
  std::vector<std::string> texts;  // lab first, then state, events (oldest first), moves
};

class LabView {
 public:
  explicit LabView(const config::Config& config, LabViewLimits limits = {});

  std::vector<Outgoing> on_axis_state(const motionlcm::axis_state_t& msg);
  std::vector<Outgoing> on_health(const motionlcm::health_t& msg);
  std::vector<Outgoing> on_event(const motionlcm::event_t& msg);
  // Requests are not sent on; they say which requests are moves, and give a move its kind and
  // targets.
  void on_request(const motionlcm::request_t& msg);
  std::vector<Outgoing> on_reply(const motionlcm::reply_t& msg);
  std::vector<Outgoing> on_active_moves(const motionlcm::active_moves_t& msg);

  [[nodiscard]] Snapshot snapshot() const;
  [[nodiscard]] std::uint64_t seq() const { return seq_; }

  // The JSON of each message type (pure; exposed for tests and tools).
  [[nodiscard]] static nlohmann::json lab_json(const config::Config& config);
  [[nodiscard]] static nlohmann::json axis_json(const motionlcm::axis_state_t& msg);
  [[nodiscard]] static nlohmann::json health_json(const motionlcm::health_t& msg);
  [[nodiscard]] static nlohmann::json event_json(const motionlcm::event_t& msg);
  [[nodiscard]] static nlohmann::json reply_json(const motionlcm::reply_t& msg);
  [[nodiscard]] static nlohmann::json active_moves_json(const motionlcm::active_moves_t& msg);

 private:
  struct Move {
    std::string id;
    std::int8_t kind = 0;  // 0: the request was not heard
    std::vector<std::string> axes;
    std::vector<double> targets;  // user units; empty when unknown
    std::int8_t status = 0;
    std::string reason;
    std::int64_t accepted_utime = 0;
    std::int64_t started_utime = 0;
    double predicted_duration_s = 0;  // from start to arrival, as the coordinator planned it (0: not told)
    std::int64_t end_utime = 0;
    std::map<std::string, std::vector<std::array<double, 3>>> samples;  // axis -> (utime, position, velocity)
    // A jog is DONE once it runs; its plot follows its axes on until every one of them stands
    // after one was seen moving (or none moved within kJogSettle of the DONE).
    bool following = false;
    bool seen_moving = false;
    std::int64_t done_utime = 0;
    [[nodiscard]] bool open() const;
  };
  struct RequestSeen {
    std::int8_t kind;
    std::vector<std::string> axes;
    std::vector<double> values;
  };

  Outgoing emit(const nlohmann::json& message);
  [[nodiscard]] nlohmann::json move_json(const Move& move, bool with_samples) const;
  Move* find_move(const std::string& id);

  const config::Config& config_;
  LabViewLimits limits_;
  std::uint64_t seq_ = 0;
  std::map<std::string, motionlcm::axis_state_t> axes_;
  std::map<std::string, motionlcm::health_t> health_;
  std::deque<motionlcm::event_t> events_;
  std::deque<motionlcm::reply_t> replies_;
  std::optional<motionlcm::active_moves_t> active_moves_;
  std::map<std::string, RequestSeen> requests_;  // by move id, until its first reply
  std::deque<Move> moves_;                       // oldest first
};

}  // namespace motion::web
