// The process's LCM endpoint, driven by its EventLoop (the LCM fd is one of the loop's fds).
//
// Thread contract: owned by the loop's thread; handlers run on it. A handler that throws is
// caught here and counted: no exception crosses LCM's C callback. A message that fails to decode
// (wrong type on a channel, truncated datagram) is counted and reported with its channel, never
// handed to the handler.
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
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "motion/core/event_loop.hpp"

namespace motion::lcm {

struct NodeOptions {
  std::string url;     // empty: $LCM_DEFAULT_URL, else LCM's default
  std::string prefix;  // channel prefix, e.g. "MOTION_"
};

class Node {
 public:
  // Opens LCM and registers its fd on `loop`. Check ok() (bad URL, no multicast route).
  Node(EventLoop& loop, NodeOptions options);
  ~Node();
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  [[nodiscard]] bool ok() const { return ok_; }
  [[nodiscard]] const std::string& url() const { return url_; }
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

  // Subscribes to <prefix><name> (LCM regex allowed, e.g. "GW_COMMAND_.*").
  template <typename Msg>
  void subscribe(std::string_view name, std::function<void(const Msg&, const std::string& channel)> handler) {
    subscribe_raw(channel(name), [handler = std::move(handler), this](const void* data, int size,
                                                                      const std::string& ch) {
      Msg msg;
      if (msg.decode(data, 0, size) != size) {
        report_malformed(ch, size, Msg::getTypeName());
        return;
      }
      handler(msg, ch);
    });
  }

  using RawHandler = std::function<void(const void* data, int size, const std::string& channel)>;
  void subscribe_raw(const std::string& full_channel_regex, RawHandler handler);

  // Called with a description of every malformed message (default: log a warning).
  void on_malformed(std::function<void(const std::string& what)> handler) { malformed_handler_ = std::move(handler); }
  [[nodiscard]] std::uint64_t malformed_count() const { return malformed_count_; }
  [[nodiscard]] std::uint64_t handler_errors() const { return handler_errors_; }

 private:
  struct Subscription;
  void report_malformed(const std::string& channel, int size, const char* type_name);

  EventLoop& loop_;
  std::string url_;
  std::string prefix_;
  std::unique_ptr<::lcm::LCM> lcm_;
  bool ok_ = false;
  std::vector<std::unique_ptr<Subscription>> subscriptions_;
  std::function<void(const std::string&)> malformed_handler_;
  std::uint64_t malformed_count_ = 0;
  std::uint64_t handler_errors_ = 0;
};

}  // namespace motion::lcm
