#include "motion/simbus/hub.hpp"

#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <deque>
#include <functional>
#include <variant>

#include <spdlog/spdlog.h>

#include "motion/core/clock.hpp"
#include "motion/core/unix_socket.hpp"
#include "motion/simbus/address.hpp"
#include "motion/simbus/wire.hpp"
#include "unix_socket.hpp"

namespace motion::simbus {

namespace {
// Datagrams read from one connection per wake-up, so one chatty endpoint cannot starve the loop.
constexpr int kReadBudget = 64;
// The oldest a socket frame's send time may be when the hub reads it (older stamps count as this).
constexpr std::chrono::nanoseconds kLongestReadDelay = std::chrono::milliseconds(10);
// Items a LocalEndpoint may have waiting before further deliveries count as overruns.
constexpr std::size_t kLocalQueueLimit = 4096;
// Room for a burst towards a slow reader (the kernel caps it at net.core.wmem_max).
constexpr int kSendBuffer = 1 << 20;
}  // namespace

namespace detail {

// What a LocalEndpoint and its hub share; the hub forgets it (hub = nullptr) when it cuts the
// endpoint off or goes away, so either side may die first. A link is signalled either through
// its eventfd (the default) or, after LocalEndpoint::on_ready(), by the hub calling `on_ready`
// from its loop (one deferred dispatch for all such links, no descriptor to poll).
struct LocalLink : std::enable_shared_from_this<LocalLink> {
  Hub* hub = nullptr;
  EndpointId id = 0;
  int event_fd = -1;
  std::function<void()> on_ready;
  bool ready_queued = false;  // in the hub's ready list
  std::deque<std::variant<can::Frame, can::BusEvent>> inbox;

  LocalLink() = default;
  LocalLink(const LocalLink&) = delete;
  LocalLink& operator=(const LocalLink&) = delete;
  ~LocalLink() {
    if (event_fd >= 0) ::close(event_fd);
  }
  bool post(std::variant<can::Frame, can::BusEvent> item) {
    if (inbox.size() >= kLocalQueueLimit) return false;
    inbox.push_back(std::move(item));
    signal();
    return true;
  }
  void signal() {
    if (!on_ready) {
      const std::uint64_t one = 1;
      [[maybe_unused]] const auto n = ::write(event_fd, &one, sizeof one);  // cannot overflow in practice
    } else if (!ready_queued && hub != nullptr) {
      ready_queued = true;
      hub->queue_ready(shared_from_this());
    }
  }
  void clear_signal() const {
    if (on_ready) return;
    std::uint64_t count = 0;
    [[maybe_unused]] const auto n = ::read(event_fd, &count, sizeof count);
  }
  void cut_off(const std::string& reason) {
    inbox.emplace_back(can::BusEvent{can::BusState::kDisconnected, 0, reason});
    signal();  // while `hub` is still known, so a callback link is told too
    hub = nullptr;
  }
};

}  // namespace detail

// ---- LocalEndpoint --------------------------------------------------------------------------

LocalEndpoint::LocalEndpoint(std::string bus_name, std::shared_ptr<detail::LocalLink> link)
    : EndpointTransport(std::move(bus_name)), link_(std::move(link)) {}

LocalEndpoint::~LocalEndpoint() {
  link_->on_ready = nullptr;
  if (link_->hub != nullptr) {
    link_->hub->bus_.detach(link_->id);
    link_->hub->locals_.erase(link_->id);
  }
}

int LocalEndpoint::fd() const { return link_->hub != nullptr && !link_->on_ready ? link_->event_fd : -1; }

void LocalEndpoint::on_ready(std::function<void()> callback) {
  link_->on_ready = std::move(callback);
  if (link_->on_ready && !link_->inbox.empty()) link_->signal();
}

EndpointId LocalEndpoint::endpoint_id() const { return link_->id; }

std::error_code LocalEndpoint::send(const can::Frame& frame) {
  if (auto invalid = check_sendable(frame)) return count_send(frame, invalid);
  if (link_->hub == nullptr) return count_send(frame, std::make_error_code(std::errc::not_connected));
  return count_send(frame, link_->hub->submit(link_->id, frame));
}

std::optional<can::Frame> LocalEndpoint::receive() {
  while (!link_->inbox.empty()) {
    auto item = std::move(link_->inbox.front());
    link_->inbox.pop_front();
    if (link_->inbox.empty()) link_->clear_signal();
    if (auto* frame = std::get_if<can::Frame>(&item)) {
      if (accept(*frame)) return *frame;
    } else {
      apply(std::get<can::BusEvent>(item), reported_state_);
    }
  }
  link_->clear_signal();
  return std::nullopt;
}

std::error_code LocalEndpoint::set_own_echo(bool enabled) {
  if (link_->hub == nullptr) return std::make_error_code(std::errc::not_connected);
  link_->hub->bus_.set_own_echo(link_->id, enabled);
  return {};
}

can::BusState LocalEndpoint::state() const {
  if (link_->hub == nullptr) return can::BusState::kDisconnected;
  const auto info = link_->hub->bus_.endpoint(link_->id);
  return info ? info->state : can::BusState::kDisconnected;
}

// ---- Hub ------------------------------------------------------------------------------------

// Routes the bus's output to sockets and local inboxes. Failures are recorded, never acted on
// here: the Bus must not be re-entered while it is advancing.
class Hub::Sink final : public BusSink {
 public:
  explicit Sink(Hub& hub) : hub_(hub) {}
  void deliver(EndpointId to, const can::Frame& frame, bool own_echo) override {
    post(to, wire::FrameMessage{frame, own_echo}, frame);
  }
  void notify(EndpointId to, const can::BusEvent& event) override { post(to, wire::BusEventMessage{event}, event); }

 private:
  void post(EndpointId to, const wire::Message& message, std::variant<can::Frame, can::BusEvent> local) {
    if (const auto it = hub_.locals_.find(to); it != hub_.locals_.end()) {
      if (!it->second->post(std::move(local))) ++hub_.overruns_;
      return;
    }
    const auto it = hub_.connection_of_.find(to);
    if (it == hub_.connection_of_.end()) return;
    const std::error_code error = detail::send_message(it->second, message);
    if (error == std::errc::resource_unavailable_try_again) {
      ++hub_.overruns_;
    } else if (error) {
      hub_.failed_.push_back(it->second);
    }
  }
  Hub& hub_;
};

Hub::Hub(EventLoop& loop, HubOptions options)
    : loop_(loop), options_(std::move(options)), bus_([&] {
        BusConfig config = options_.bus;
        config.epoch_offset_us =
            wall_time_us() -
            std::chrono::duration_cast<std::chrono::microseconds>(loop.now().time_since_epoch()).count();
        return config;
      }()) {}

std::unique_ptr<Hub> Hub::open(EventLoop& loop, HubOptions options, std::error_code& error) {
  if (!valid_bus_name(options.bus_name)) {
    error = std::make_error_code(std::errc::invalid_argument);
    return nullptr;
  }
  std::unique_ptr<Hub> hub(new Hub(loop, std::move(options)));
  error.clear();
  if (hub->options_.listen) error = hub->listen();
  if (error) return nullptr;
  return hub;
}

std::error_code Hub::listen() {
  socket_path_ = simbus::socket_path(options_.bus_name, options_.socket_dir);
  std::error_code error;
  listen_fd_ = unix_socket::listen_seqpacket(socket_path_, options_.access, error);
  if (listen_fd_ < 0) return error;
  loop_.watch(listen_fd_, [this] { accept_connections(); });
  return {};
}

Hub::~Hub() {
  if (timer_) loop_.cancel(*timer_);
  while (!connections_.empty()) close_connection(connections_.begin()->first);
  if (listen_fd_ >= 0) {
    loop_.unwatch(listen_fd_);
    ::close(listen_fd_);
    ::unlink(socket_path_.c_str());
  }
  for (auto& [id, link] : locals_) link->cut_off("simulated bus " + options_.bus_name + " shut down");
  // Callback endpoints are not called for the hub's own end (their owner is going away with
  // it); the disconnect event waits in their inbox.
  if (ready_timer_) loop_.cancel(*ready_timer_);
}

std::unique_ptr<LocalEndpoint> Hub::attach_local(std::string label, bool own_echo) {
  auto link = std::make_shared<detail::LocalLink>();
  link->event_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (link->event_fd < 0) return nullptr;
  link->hub = this;
  link->id = bus_.attach(std::move(label), own_echo);
  locals_.emplace(link->id, link);
  return std::unique_ptr<LocalEndpoint>(new LocalEndpoint(options_.bus_name, std::move(link)));
}

void Hub::accept_connections() {
  while (true) {
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) {
        spdlog::warn("simbus {}: accept failed: {}", options_.bus_name, std::strerror(errno));
      }
      return;
    }
    ::setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &kSendBuffer, sizeof kSendBuffer);
    unix_socket::stamp_receptions(fd);
    connections_.emplace(fd, Connection{fd, 0});
    loop_.watch(fd, [this, fd] { read_connection(fd); });
  }
}

void Hub::read_connection(int fd) {
  std::array<std::uint8_t, wire::kMaxMessageSize> buffer{};
  bool failed = false;
  for (int i = 0; i < kReadBudget; ++i) {
    const auto it = connections_.find(fd);
    if (it == connections_.end()) return;
    std::int64_t sent_wall_ns = 0;
    const ssize_t n = unix_socket::receive_stamped(fd, buffer, sent_wall_ns);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
    if (n <= 0) {
      failed = true;  // peer closed (0) or the connection broke
      break;
    }
    const auto message = wire::decode({buffer.data(), static_cast<std::size_t>(n)});
    if (!message) {
      spdlog::warn("simbus {}: ignoring a malformed message ({} bytes)", options_.bus_name, n);
      continue;
    }
    handle(it->second, *message, sent_at(sent_wall_ns));
  }
  if (failed) failed_.push_back(fd);
  pump();
}

TimePoint Hub::sent_at(std::int64_t sent_wall_ns) const {
  // The stamp's age is real time: it dates a frame on a loop that runs on the steady clock only.
  if (dynamic_cast<const SystemSteadyClock*>(&loop_.clock()) == nullptr) return loop_.now();
  return unix_socket::sent_time(loop_.now(), sent_wall_ns, kLongestReadDelay);
}

void Hub::handle(Connection& connection, const wire::Message& message, TimePoint sent) {
  if (const auto* hello = std::get_if<wire::Hello>(&message)) {
    if (connection.id != 0) return;
    if (hello->version != wire::kProtocolVersion) {
      spdlog::warn("simbus {}: endpoint '{}' speaks protocol {}, not {}", options_.bus_name, hello->label,
                   hello->version, wire::kProtocolVersion);
      failed_.push_back(connection.fd);
      return;
    }
    connection.id = bus_.attach(hello->label, hello->own_echo);
    connection_of_[connection.id] = connection.fd;
    const std::uint32_t bitrate = options_.bus.timing ? bus_.config().bitrate : 0;
    if (detail::send_message(connection.fd,
                             wire::Welcome{wire::kProtocolVersion, connection.id, bitrate, options_.bus_name})) {
      failed_.push_back(connection.fd);
    }
    return;
  }
  if (connection.id == 0) return;  // nothing but Hello before Hello
  const auto submit_from_connection = [&](const can::Frame& frame) {
    if (bus_.submit(connection.id, frame, sent)) {
      (void)detail::send_message(connection.fd, wire::TxRejected{frame.id, frame.extended});
    }
  };
  if (const auto* fm = std::get_if<wire::FrameMessage>(&message)) {
    submit_from_connection(fm->frame);
  } else if (const auto* batch = std::get_if<wire::FrameBatch>(&message)) {
    for (const can::Frame& frame : batch->view()) submit_from_connection(frame);
  } else if (const auto* echo = std::get_if<wire::SetOwnEcho>(&message)) {
    bus_.set_own_echo(connection.id, echo->enabled);
  }
}

void Hub::close_connection(int fd) {
  const auto it = connections_.find(fd);
  if (it == connections_.end()) return;
  loop_.unwatch(fd);
  ::close(fd);
  if (it->second.id != 0) {
    bus_.detach(it->second.id);
    connection_of_.erase(it->second.id);
  }
  connections_.erase(it);
}

std::error_code Hub::submit(EndpointId from, const can::Frame& frame) {
  const std::error_code error = bus_.submit(from, frame, loop_.now());
  pump();
  return error;
}

void Hub::pump() {
  Sink sink(*this);
  bus_.advance(loop_.now(), sink);
  std::vector<int> failed;
  failed.swap(failed_);
  for (const int fd : failed) close_connection(fd);
  reschedule();
}

void Hub::reschedule() {
  const TimePoint next = bus_.next_deadline();
  if (timer_ && next == timer_deadline_) return;
  if (timer_) loop_.cancel(*timer_);
  timer_.reset();
  timer_deadline_ = next;
  if (next == kNever) return;
  timer_ = loop_.call_at(next, [this] {
    timer_.reset();
    pump();
  });
}

void Hub::queue_ready(std::shared_ptr<detail::LocalLink> link) {
  ready_.push_back(std::move(link));
  if (ready_timer_) return;
  // Called while the bus advances: the receivers run from the loop afterwards, never inside it.
  ready_timer_ = loop_.call_at(loop_.now(), [this] {
    ready_timer_.reset();
    std::vector<std::shared_ptr<detail::LocalLink>> ready;
    ready.swap(ready_);
    for (const auto& waiting : ready) {
      waiting->ready_queued = false;
      if (!waiting->on_ready) continue;
      const auto callback = waiting->on_ready;  // the callback may destroy its endpoint
      callback();
    }
  });
}

BusStatistics Hub::statistics() const {
  BusStatistics s = bus_.statistics(loop_.now());
  s.overruns = overruns_;
  return s;
}

bool Hub::disconnect(EndpointId id) {
  if (const auto it = locals_.find(id); it != locals_.end()) {
    it->second->cut_off("disconnected from simulated bus " + options_.bus_name);
    bus_.detach(id);
    locals_.erase(it);
    return true;
  }
  if (const auto it = connection_of_.find(id); it != connection_of_.end()) {
    close_connection(it->second);
    return true;
  }
  return false;
}

bool Hub::set_bus_off(EndpointId id, std::optional<Duration> recover_after) {
  const bool known = bus_.set_bus_off(id, loop_.now(), recover_after);
  pump();
  return known;
}

bool Hub::recover(EndpointId id) {
  const bool known = bus_.recover(id, loop_.now());
  pump();
  return known;
}

}  // namespace motion::simbus
