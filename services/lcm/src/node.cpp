#include "motion/lcm/node.hpp"

#include <cstdlib>
#include <exception>

#include <spdlog/spdlog.h>

namespace motion::lcm {

struct Node::Subscription {
  Node* node;
  RawHandler handler;
  // Registered with LCM's C API: its C++ member-function wrapper hands the callback a wrong
  // user-data pointer in sanitizer builds of Debian's 1.3.1, and the C API is all we need (raw
  // bytes; decoding is ours so malformed input is seen).
  static void on_message(const lcm_recv_buf_t* rbuf, const char* channel, void* user_data) noexcept {
    auto* self = static_cast<Subscription*>(user_data);
    try {
      self->handler(rbuf->data, static_cast<int>(rbuf->data_size), std::string(channel));
    } catch (const std::exception& e) {
      ++self->node->handler_errors_;
      spdlog::error("lcm: handler for {} threw: {}", channel, e.what());
    } catch (...) {
      ++self->node->handler_errors_;
      spdlog::error("lcm: handler for {} threw a non-standard exception", channel);
    }
  }
};

Node::Node(EventLoop& loop, NodeOptions options) : loop_(loop), url_(std::move(options.url)), prefix_(std::move(options.prefix)) {
  if (url_.empty()) {
    if (const char* env = std::getenv("LCM_DEFAULT_URL")) url_ = env;
  }
  lcm_ = std::make_unique<::lcm::LCM>(url_);
  ok_ = lcm_->good();
  if (!ok_) {
    spdlog::error("lcm: cannot open '{}' (bad URL, or no multicast route: see docs/recording-and-networks.md, Networking)",
                  url_.empty() ? "<default>" : url_);
    return;
  }
  const int fd = lcm_->getFileno();
  loop_.watch(fd, [this] {
    // Non-blocking: the fd is readable, so one message is waiting.
    if (lcm_->handleTimeout(0) < 0) spdlog::error("lcm: handle failed on {}", url_);
  });
}

Node::~Node() {
  if (ok_) loop_.unwatch(lcm_->getFileno());
}

bool Node::publish_raw(const std::string& full_channel, const std::vector<std::uint8_t>& data) {
  if (!ok_) return false;
  const int rc = lcm_->publish(full_channel, data.data(), static_cast<unsigned int>(data.size()));
  if (rc != 0) {
    spdlog::warn("lcm: publish on {} failed", full_channel);
    return false;
  }
  return true;
}

void Node::subscribe_raw(const std::string& full_channel_regex, RawHandler handler) {
  if (!ok_) return;
  auto sub = std::make_unique<Subscription>(Subscription{this, std::move(handler)});
  lcm_subscribe(lcm_->getUnderlyingLCM(), full_channel_regex.c_str(), &Subscription::on_message, sub.get());
  subscriptions_.push_back(std::move(sub));
}

void Node::report_malformed(const std::string& channel, int size, const char* type_name) {
  ++malformed_count_;
  const std::string what = "malformed message on " + channel + ": " + std::to_string(size) +
                           " bytes do not decode as " + type_name;
  if (malformed_handler_) {
    malformed_handler_(what);
  } else {
    spdlog::warn("lcm: {}", what);
  }
}

}  // namespace motion::lcm
