#include "motion/lcm/node.hpp"

#include <algorithm>
#include <cstdlib>
#include <exception>
#include <fstream>

#include <spdlog/spdlog.h>

namespace motion::lcm {

struct Node::Subscription {
  Node* node;
  std::string pattern;
  const char* type_name;  // nullptr: raw subscription (no decoding here)
  RawHandler raw;
  TypedHandler typed;
  MalformedLimiter limiter;
  EventLoop::TimerId summary_timer = 0;
  // Registered with LCM's C API: its C++ member-function wrapper hands the callback a wrong
  // user-data pointer in sanitizer builds of Debian's 1.3.1, and the C API is all we need (raw
  // bytes; decoding is ours so malformed input is seen).
  static void on_message(const lcm_recv_buf_t* rbuf, const char* channel, void* user_data) noexcept {
    auto* self = static_cast<Subscription*>(user_data);
    try {
      const std::string ch(channel);
      const int size = static_cast<int>(rbuf->data_size);
      if (self->typed) {
        const std::string why = self->typed(rbuf->data, size, ch);
        if (!why.empty()) self->node->report_malformed(*self, ch, size, why);
      } else {
        self->raw(rbuf->data, size, ch);
      }
    } catch (const std::exception& e) {
      ++self->node->handler_errors_;
      spdlog::error("lcm: handler for {} threw: {}", channel, e.what());
    } catch (...) {
      ++self->node->handler_errors_;
      spdlog::error("lcm: handler for {} threw a non-standard exception", channel);
    }
  }
};

Node::Node(EventLoop& loop, NodeOptions options)
    : loop_(loop),
      url_(std::move(options.url)),
      prefix_(std::move(options.prefix)),
      queue_capacity_(std::max(1, options.queue_capacity)) {
  if (url_.empty()) {
    if (const char* env = std::getenv("LCM_DEFAULT_URL")) url_ = env;
  }
  const int recv_buf = options.recv_buf_size != 0 ? options.recv_buf_size : default_receive_buffer();
  effective_url_ = url_with_receive_buffer(url_, recv_buf);
  lcm_ = std::make_unique<::lcm::LCM>(effective_url_);
  ok_ = lcm_->good();
  if (!ok_) {
    spdlog::error(
        "lcm: cannot open '{}' (bad URL, or no multicast route: see docs/recording-and-networks.md, Networking)",
        url_.empty() ? "<default>" : url_);
    return;
  }
  const int fd = lcm_->getFileno();
  loop_.watch(fd, [this] {
    // Everything waiting, not only the one message that made the fd readable: after a stall (a
    // loaded host) the backlog is handled before the loop's timers run, so no deadline is judged
    // on old news while newer messages wait unread (a gateway's heartbeats queued behind one
    // state, taken for a lost gateway). Bounded, so a flood cannot hold the timers off for long.
    constexpr int kMostPerWake = 256;
    for (int i = 0; i < kMostPerWake; ++i) {
      const int handled = lcm_->handleTimeout(0);
      if (handled < 0) spdlog::error("lcm: handle failed on {}", url_);
      if (handled <= 0) break;
    }
  });
}

Node::~Node() {
  end_quiet();
  for (const auto& sub : subscriptions_) {
    if (sub->summary_timer != 0) loop_.cancel(sub->summary_timer);
  }
  if (ok_) loop_.unwatch(lcm_->getFileno());
}

std::string Node::url_with_receive_buffer(const std::string& url, int bytes) {
  const std::string base = url.empty() ? std::string(kLcmDefaultUrl) : url;
  if (bytes <= 0 || base.rfind("udpm://", 0) != 0 || base.find("recv_buf_size=") != std::string::npos) return url;
  return base + (base.find('?') == std::string::npos ? "?" : "&") + "recv_buf_size=" + std::to_string(bytes);
}

int Node::default_receive_buffer() {
  constexpr long kWanted = 8L << 20;
  constexpr long kFallback = 2L << 20;
  std::ifstream in("/proc/sys/net/core/rmem_max");
  long rmem_max = 0;
  if (!(in >> rmem_max) || rmem_max <= 0) return static_cast<int>(kFallback);
  if (rmem_max < (1L << 20)) {
    static bool warned = false;
    if (!warned) {
      warned = true;
      spdlog::warn(
          "lcm: the kernel limits UDP receive buffers to {} bytes (net.core.rmem_max): bursts of messages "
          "may be lost; raise it, e.g. sysctl -w net.core.rmem_max=8388608",
          rmem_max);
    }
  }
  return static_cast<int>(std::min(kWanted, rmem_max));
}

bool Node::publish_raw(const std::string& full_channel, const std::vector<std::uint8_t>& data) {
  if (!ok_) return false;
  const auto at_once = [&] {
    return std::any_of(at_once_.begin(), at_once_.end(),
                       [&](const std::string& prefix) { return full_channel.starts_with(prefix); });
  };
  if (quiet_timer_ != 0 && !at_once()) {
    if (quiet_queue_.size() < kQuietQueueLimit) {
      quiet_queue_.emplace_back(full_channel, data);
      return true;
    }
    spdlog::debug("lcm: {} publications wait in a quiet interval: published now", quiet_queue_.size());
    end_quiet();
  }
  return send(full_channel, data);
}

void Node::quiet_until(TimePoint until) {
  if (!ok_ || until <= loop_.now() || (quiet_timer_ != 0 && until <= quiet_until_)) return;
  if (quiet_timer_ != 0) loop_.cancel(quiet_timer_);
  quiet_until_ = until;
  quiet_timer_ = loop_.call_at(until, [this] {
    quiet_timer_ = 0;
    end_quiet();
  });
}

void Node::end_quiet() {
  if (quiet_timer_ != 0) loop_.cancel(quiet_timer_);
  quiet_timer_ = 0;
  // Sent from a moved-out queue: the interval is over before the first one goes.
  auto queued = std::move(quiet_queue_);
  quiet_queue_.clear();
  for (const auto& [channel, data] : queued) send(channel, data);
}

bool Node::send(const std::string& full_channel, const std::vector<std::uint8_t>& data) {
  const int rc = lcm_->publish(full_channel, data.data(), static_cast<unsigned int>(data.size()));
  if (rc != 0) {
    spdlog::warn("lcm: publish on {} failed", full_channel);
    return false;
  }
  return true;
}

void Node::subscribe_raw(const std::string& full_channel_regex, RawHandler handler) {
  if (!ok_) return;
  auto sub =
      std::make_unique<Subscription>(Subscription{this, full_channel_regex, nullptr, std::move(handler), {}, {}, 0});
  lcm_subscription_t* s =
      lcm_subscribe(lcm_->getUnderlyingLCM(), full_channel_regex.c_str(), &Subscription::on_message, sub.get());
  if (s != nullptr) lcm_subscription_set_queue_capacity(s, queue_capacity_);
  subscriptions_.push_back(std::move(sub));
}

void Node::add_subscription(const std::string& full_channel_regex, const char* type_name, TypedHandler handler) {
  if (!ok_) return;
  auto sub =
      std::make_unique<Subscription>(Subscription{this, full_channel_regex, type_name, {}, std::move(handler), {}, 0});
  lcm_subscription_t* s =
      lcm_subscribe(lcm_->getUnderlyingLCM(), full_channel_regex.c_str(), &Subscription::on_message, sub.get());
  if (s != nullptr) lcm_subscription_set_queue_capacity(s, queue_capacity_);
  subscriptions_.push_back(std::move(sub));
}

std::uint64_t Node::malformed_suppressed() const {
  std::uint64_t n = 0;
  for (const auto& sub : subscriptions_) n += sub->limiter.suppressed_total();
  return n;
}

void Node::report_malformed(Subscription& sub, const std::string& channel, int size, const std::string& why) {
  ++malformed_count_;
  if (sub.limiter.admit(loop_.now())) {
    emit_malformed("malformed message on " + channel + " (" + std::to_string(size) + " bytes, expected " +
                   sub.type_name + "): " + why);
    return;
  }
  if (sub.summary_timer == 0) {
    sub.summary_timer = loop_.call_at(sub.limiter.window_end(), [this, s = &sub] { flush_suppressed(*s); });
  }
}

void Node::flush_suppressed(Subscription& sub) {
  sub.summary_timer = 0;
  const std::uint64_t n = sub.limiter.take_summary(loop_.now());
  if (n > 0) {
    const auto window_ms = std::chrono::duration_cast<std::chrono::milliseconds>(sub.limiter.window()).count();
    emit_malformed(std::to_string(n) + " more malformed messages on " + sub.pattern + " suppressed (at most " +
                   std::to_string(sub.limiter.per_window()) + " reported per " + std::to_string(window_ms) + " ms)");
  }
  if (sub.limiter.summary_pending()) {
    sub.summary_timer = loop_.call_at(sub.limiter.window_end(), [this, s = &sub] { flush_suppressed(*s); });
  }
}

void Node::emit_malformed(const std::string& what) {
  if (malformed_handler_) {
    malformed_handler_(what);
  } else {
    spdlog::warn("lcm: {}", what);
  }
}

}  // namespace motion::lcm
