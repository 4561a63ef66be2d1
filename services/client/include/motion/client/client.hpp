// The C++ client of the motion system: send requests to the coordinator and follow their replies,
// watch axis state and events.
//
// Thread contract: owned by one thread with its EventLoop. `call()` pumps that loop until the
// terminal reply (or the timeout), so callbacks keep running while it waits.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <string>

#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>

#include "motion/core/event_loop.hpp"
#include "motion/lcm/node.hpp"

namespace motion::client {

[[nodiscard]] bool is_terminal(std::int8_t status);
[[nodiscard]] const char* status_name(std::int8_t status);

class Client {
 public:
  using ReplyHandler = std::function<void(const motionlcm::reply_t&)>;

  Client(EventLoop& loop, lcm::Node& node, std::string client_id);

  // Fills utime/client_id/request_id/num_axes and publishes; replies go to `on_reply`.
  std::int64_t send(motionlcm::request_t request, ReplyHandler on_reply = {});
  // Sends and waits for the terminal reply. Returns a local FAILED reply (error code 13,
  // timeout) naming the LCM URL and channel when no reply at all comes within kAcceptTimeout (no
  // coordinator listening) or no terminal one within `timeout`.
  static constexpr std::chrono::milliseconds kAcceptTimeout{2000};
  motionlcm::reply_t call(motionlcm::request_t request, std::chrono::milliseconds timeout, ReplyHandler on_progress = {});

  // Latest state of every axis heard so far.
  [[nodiscard]] const std::map<std::string, motionlcm::axis_state_t>& axes() const { return axes_; }
  void on_axis_state(std::function<void(const motionlcm::axis_state_t&)> handler) { state_handler_ = std::move(handler); }
  void on_event(std::function<void(const motionlcm::event_t&)> handler) { event_handler_ = std::move(handler); }
  // Pumps the loop until `done()` or the timeout; false on timeout.
  bool wait_until(const std::function<bool()>& done, std::chrono::milliseconds timeout);

  [[nodiscard]] const std::string& id() const { return id_; }

  // Request builders.
  static motionlcm::request_t make(std::int8_t kind, const std::map<std::string, double>& axis_values);
  static motionlcm::request_t make(std::int8_t kind, const std::vector<std::string>& axes);

 private:
  EventLoop& loop_;
  lcm::Node& node_;
  std::string id_;
  std::int64_t next_request_id_;
  std::map<std::int64_t, ReplyHandler> pending_;
  std::map<std::string, motionlcm::axis_state_t> axes_;
  std::function<void(const motionlcm::axis_state_t&)> state_handler_;
  std::function<void(const motionlcm::event_t&)> event_handler_;
};

}  // namespace motion::client
