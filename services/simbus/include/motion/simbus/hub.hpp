// The hub of one simulated CAN bus, living on a process's EventLoop (motion-sim hosts them).
//
// It owns the Bus (bus.hpp), listens on the bus's Unix socket (address.hpp) for SocketEndpoints
// of other processes and hands out LocalEndpoints for same-process users. A socket endpoint's frame
// is submitted at the time its sender sent it (the kernel's stamp of the datagram, SO_TIMESTAMPNS),
// not when the hub got to read it: a hub whose loop was busy with the frames before would otherwise
// put it on the wire late, later than a CAN controller would (Bus::submit takes such a time in its
// past). The frames of a socket endpoint's batch (one message) are submitted together, at its
// stamp. Local endpoints submit at the loop's now(). Deliveries are scheduled with
// one EventLoop timer at the bus's next deadline (never a busy wait). A frame reaches its
// receivers within the loop's timer slack (tens of microseconds) after its simulated end of
// frame; its timestamp is the exact simulated time.
//
// A receiver that does not read fast enough loses frames (counted as overruns), like a full
// SocketCAN receive queue; the bus and the other receivers are not held up.
//
// Threading/blocking: the EventLoop contract. Everything runs on the loop's thread; nothing
// blocks. The loop must outlive the hub; endpoints may outlive it (they become disconnected).
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include "motion/core/event_loop.hpp"
#include "motion/core/file_access.hpp"
#include "motion/simbus/bus.hpp"
#include "motion/simbus/endpoint.hpp"
#include "motion/simbus/wire.hpp"

namespace motion::simbus {

struct HubOptions {
  std::string bus_name;              // valid_bus_name()
  std::filesystem::path socket_dir;  // empty: default_socket_dir()
  bool listen = true;                // false: LocalEndpoints only, no socket
  BusConfig bus;                     // epoch_offset_us is set by the hub from the wall clock
  FileAccess access;  // the socket's mode: 0600, or 0660 with a group (frames can be injected through it)
};

namespace detail {
struct LocalLink;
}

// A same-process endpoint: frames and events are queued in memory, fd() is an eventfd that
// polls readable while something is waiting. Sends are submitted to the bus at once, so send()
// reports bus-off synchronously. After on_ready(callback), fd() is -1 and the hub calls the
// callback from its loop instead (after the bus has advanced, never inside it) whenever
// something is waiting: a simulator with a hundred drives then polls no descriptor per drive and
// pays no write(2) per delivered frame. The callback must call receive() until it is empty.
class LocalEndpoint final : public EndpointTransport {
 public:
  ~LocalEndpoint() override;
  LocalEndpoint(const LocalEndpoint&) = delete;
  LocalEndpoint& operator=(const LocalEndpoint&) = delete;

  [[nodiscard]] int fd() const override;
  std::error_code send(const can::Frame& frame) override;
  std::optional<can::Frame> receive() override;
  std::error_code set_own_echo(bool enabled) override;
  [[nodiscard]] can::BusState state() const override;
  [[nodiscard]] EndpointId endpoint_id() const;
  void on_ready(std::function<void()> callback);

 private:
  friend class Hub;
  LocalEndpoint(std::string bus_name, std::shared_ptr<detail::LocalLink> link);
  std::shared_ptr<detail::LocalLink> link_;
  can::BusState reported_state_ = can::BusState::kErrorActive;  // as told by the events so far
};

class Hub {
 public:
  // nullptr with `error` set: invalid_argument (bus name), filename_too_long, address_in_use
  // (another hub serves this bus), or the socket call's errno. A stale socket file left by a
  // dead hub is replaced.
  static std::unique_ptr<Hub> open(EventLoop& loop, HubOptions options, std::error_code& error);
  ~Hub();
  Hub(const Hub&) = delete;
  Hub& operator=(const Hub&) = delete;

  [[nodiscard]] const std::string& bus_name() const { return options_.bus_name; }
  [[nodiscard]] const std::filesystem::path& socket_path() const { return socket_path_; }

  std::unique_ptr<LocalEndpoint> attach_local(std::string label, bool own_echo = false);

  [[nodiscard]] BusStatistics statistics() const;
  [[nodiscard]] std::vector<EndpointInfo> endpoints() const { return bus_.endpoints(); }
  [[nodiscard]] std::optional<EndpointId> find_endpoint(std::string_view label) const { return bus_.find(label); }

  // Fault injection (tests, later the control channel). See Fault in bus.hpp.
  FaultId inject(Fault fault) { return bus_.inject(std::move(fault)); }
  bool clear_fault(FaultId id) { return bus_.clear_fault(id); }
  void clear_faults() { bus_.clear_faults(); }
  // Cuts the endpoint off: a socket endpoint's connection is closed (it sees the hub go away),
  // a local one becomes kDisconnected. False for an unknown id.
  bool disconnect(EndpointId id);
  // Bus-off now; recovery by recover() or automatically after `recover_after`.
  bool set_bus_off(EndpointId id, std::optional<Duration> recover_after = std::nullopt);
  bool recover(EndpointId id);

 private:
  struct Connection {
    int fd = -1;
    EndpointId id = 0;  // 0 until its Hello
  };
  class Sink;
  friend class LocalEndpoint;
  friend struct detail::LocalLink;

  Hub(EventLoop& loop, HubOptions options);
  std::error_code listen();
  void accept_connections();
  void read_connection(int fd);
  // The time a message stamped `sent_wall_ns` (0: not stamped: now) was sent, on the loop's clock.
  [[nodiscard]] TimePoint sent_at(std::int64_t sent_wall_ns) const;
  void handle(Connection& connection, const wire::Message& message, TimePoint sent);
  void close_connection(int fd);
  std::error_code submit(EndpointId from, const can::Frame& frame);
  // Runs the bus up to now, delivers, closes connections that failed, re-arms the timer.
  void pump();
  void reschedule();
  // A callback link has something waiting: call it from the loop once the bus is left.
  void queue_ready(std::shared_ptr<detail::LocalLink> link);

  EventLoop& loop_;
  HubOptions options_;
  std::filesystem::path socket_path_;
  int listen_fd_ = -1;
  Bus bus_;
  std::map<int, Connection> connections_;                            // by fd
  std::map<EndpointId, int> connection_of_;                          // socket endpoints
  std::map<EndpointId, std::shared_ptr<detail::LocalLink>> locals_;  // local endpoints
  std::vector<int> failed_;                                          // connections to close after pump
  std::uint64_t overruns_ = 0;
  std::optional<EventLoop::TimerId> timer_;
  TimePoint timer_deadline_ = kNever;
  std::vector<std::shared_ptr<detail::LocalLink>> ready_;
  std::optional<EventLoop::TimerId> ready_timer_;
};

}  // namespace motion::simbus
