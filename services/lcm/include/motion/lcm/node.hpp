// The process's LCM endpoint, driven by its EventLoop (the LCM fd is one of the loop's fds).
//
// Thread contract: owned by the loop's thread; handlers run on it. A handler that throws is
// caught here and counted: no exception crosses LCM's C callback.
//
// Hostile input: a typed subscription checks every message against its byte length before
// anything is allocated (motion/lcm/wire_reader.hpp, checkers generated from the .lcm files):
// a message that is truncated, of another type, or claims more array elements or string bytes
// than it carries costs O(its size), is counted (malformed_count(), shown in the HEALTH
// heartbeat's detail) and never reaches the handler. Reports of malformed messages are rate
// limited per subscription (MalformedLimiter: 5 per second, then one "N more ... suppressed"
// summary per second), both the log lines and the on_malformed() handler calls.
//
// Bursts: the UDP receive buffer defaults to min(8 MiB, net.core.rmem_max) when the URL does
// not set recv_buf_size, and each subscription queues up to NodeOptions::queue_capacity
// messages in LCM (LCM's own default is 30, which dropped bursts of requests).
//
// Channels are named <prefix><NAME> (see channels.hpp), so several independent systems can share
// one multicast group.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "motion/core/event_loop.hpp"
#include "motion/lcm/malformed_limiter.hpp"
#include "motion/lcm/wire_bounds.hpp"

namespace motion::lcm {

struct NodeOptions {
  std::string url;     // empty: $LCM_DEFAULT_URL, else LCM's default
  std::string prefix;  // channel prefix, e.g. "MOTION_"
  // Messages LCM queues per subscription before it drops (lcm_subscription_set_queue_capacity).
  int queue_capacity = 2048;
  // UDP receive buffer for udpm URLs without recv_buf_size; 0: default_receive_buffer();
  // negative: the URL as given (the kernel's default, net.core.rmem_default).
  int recv_buf_size = 0;
};

// LCM's default URL (lcm.h), used when neither the options nor $LCM_DEFAULT_URL name one.
inline constexpr const char* kLcmDefaultUrl = "udpm://239.255.76.67:7667?ttl=0";

class Node {
 public:
  // Opens LCM and registers its fd on `loop`. Check ok() (bad URL, no multicast route).
  Node(EventLoop& loop, NodeOptions options);
  ~Node();
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  [[nodiscard]] bool ok() const { return ok_; }
  [[nodiscard]] const std::string& url() const { return url_; }
  // The URL LCM was opened with: url() plus recv_buf_size for udpm.
  [[nodiscard]] const std::string& effective_url() const { return effective_url_; }
  [[nodiscard]] const std::string& prefix() const { return prefix_; }
  [[nodiscard]] std::string channel(std::string_view name) const { return prefix_ + std::string(name); }

  // Publishes on <prefix><name>. Returns false when LCM refused (logged).
  template <typename Msg>
  bool publish(std::string_view name, const Msg& msg) {
    return publish_encoded(channel(name), msg);
  }
  // Publishes on an exact channel name (no prefix added).
  template <typename Msg>
  bool publish_encoded(const std::string& full_channel, const Msg& msg) {
    const int size = msg.getEncodedSize();
    std::vector<std::uint8_t> buffer(static_cast<std::size_t>(size));
    if (msg.encode(buffer.data(), 0, size) != size) return false;
    return publish_raw(full_channel, buffer);
  }
  bool publish_raw(const std::string& full_channel, const std::vector<std::uint8_t>& data);

  // A quiet interval: publications from now until `until` are queued, in their order, and go out
  // at `until` (from a loop timer). Every LCM publication on a multicast group wakes every process
  // of the group, each on a CPU: around the instants a scheduled start goes out on several buses,
  // those wake-ups delay the other gateways' fires. A later `until` extends the interval, an
  // earlier one does not shorten it; one already past does nothing. publish*() returns true for a
  // queued message. At most kQuietQueueLimit messages wait: the next one publishes them all and
  // ends the interval (nothing is lost, the interval is cut short). The destructor publishes
  // what still waits.
  static constexpr std::size_t kQuietQueueLimit = 1024;
  void quiet_until(TimePoint until);
  [[nodiscard]] bool quiet() const { return quiet_timer_ != 0; }
  // Publishes what waits and ends the quiet interval.
  void end_quiet();
  // Publications on channels beginning with <prefix><name_prefix> are never held by a quiet
  // interval (commands and triggers that must reach their receivers on time); their own order is
  // kept, since none of them ever waits.
  void publish_at_once(std::string_view name_prefix) { at_once_.push_back(channel(name_prefix)); }

  // Subscribes to <prefix><name> (LCM regex allowed, e.g. "GW_COMMAND_.*"). Only messages that
  // pass the bounded check and decode exactly reach `handler`.
  // `on_rejected`, when given, also sees every malformed message (its bytes and why), unlimited:
  // for a receiver that can still answer its sender (it must stay O(size)).
  using RejectedHandler = std::function<void(const void* data, int size, const std::string& why)>;
  template <typename Msg>
  void subscribe(std::string_view name, std::function<void(const Msg&, const std::string& channel)> handler,
                 RejectedHandler on_rejected = {}) {
    add_subscription(channel(name), Msg::getTypeName(),
                     [handler = std::move(handler), on_rejected = std::move(on_rejected)](
                         const void* data, int size, const std::string& ch) -> std::string {
                       Msg msg;
                       std::string why = wire::decode_bounded(data, static_cast<std::size_t>(size), msg);
                       if (why.empty()) {
                         handler(msg, ch);
                       } else if (on_rejected) {
                         on_rejected(data, size, why);
                       }
                       return why;
                     });
  }

  using RawHandler = std::function<void(const void* data, int size, const std::string& channel)>;
  void subscribe_raw(const std::string& full_channel_regex, RawHandler handler);

  // Called with a description of malformed messages, at the limited rate (default: log a
  // warning): at most 5 per second per subscription, then "N more ... suppressed" once a second.
  void on_malformed(std::function<void(const std::string& what)> handler) { malformed_handler_ = std::move(handler); }
  [[nodiscard]] std::uint64_t malformed_count() const { return malformed_count_; }
  [[nodiscard]] std::uint64_t handler_errors() const { return handler_errors_; }
  // Malformed messages counted but not reported (rate limit).
  [[nodiscard]] std::uint64_t malformed_suppressed() const;

  // `url` with recv_buf_size=bytes added when it is a udpm URL (or empty: LCM's default) without
  // one; other URLs unchanged.
  [[nodiscard]] static std::string url_with_receive_buffer(const std::string& url, int bytes);
  // min(8 MiB, net.core.rmem_max) (Linux doubles what is asked up to twice rmem_max, so LCM
  // does not warn); 2 MiB when rmem_max cannot be read.
  [[nodiscard]] static int default_receive_buffer();

 private:
  struct Subscription;
  // Decodes and delivers; returns "" or why the message is malformed.
  using TypedHandler = std::function<std::string(const void* data, int size, const std::string& channel)>;
  void add_subscription(const std::string& full_channel_regex, const char* type_name, TypedHandler handler);
  void report_malformed(Subscription& sub, const std::string& channel, int size, const std::string& why);
  void flush_suppressed(Subscription& sub);
  void emit_malformed(const std::string& what);

  EventLoop& loop_;
  std::string url_;
  std::string effective_url_;
  std::string prefix_;
  int queue_capacity_;
  std::unique_ptr<::lcm::LCM> lcm_;
  bool ok_ = false;
  std::vector<std::unique_ptr<Subscription>> subscriptions_;
  std::function<void(const std::string&)> malformed_handler_;
  std::uint64_t malformed_count_ = 0;
  std::uint64_t handler_errors_ = 0;
  bool send(const std::string& full_channel, const std::vector<std::uint8_t>& data);
  TimePoint quiet_until_{};
  EventLoop::TimerId quiet_timer_ = 0;
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> quiet_queue_;
  std::vector<std::string> at_once_;  // full channel prefixes never held (publish_at_once)
};

}  // namespace motion::lcm
