// The socket side of bench_simbus (simbus_bench.cpp, part 1): a Hub on its own EventLoop thread,
// the links the client loop drives (two SocketEndpoints on the hub; the bound, a bare relay thread
// over socketpairs), and the client loops (a windowed stream, one-way latency).
#pragma once

#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "motion/can_frame/frame.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/simbus/bus.hpp"
#include "motion/simbus/endpoint.hpp"
#include "motion/simbus/hub.hpp"
#include "motion/simbus/wire.hpp"

namespace motion::simbus::bench {

using Clock = std::chrono::steady_clock;

// ---- the hub in its own thread ----------------------------------------------------------------

class HubThread {
 public:
  HubThread(std::filesystem::path dir, std::string name, BusConfig config) {
    stop_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    std::promise<std::error_code> ready;
    auto started = ready.get_future();
    thread_ = std::thread([this, dir = std::move(dir), name = std::move(name), config, &ready] {
      EventLoop loop;
      HubOptions options;
      options.bus_name = name;
      options.socket_dir = dir;
      options.bus = config;
      std::error_code error;
      auto hub = Hub::open(loop, options, error);
      ready.set_value(error);
      if (!hub) return;
      loop.watch(stop_fd_, [&loop] { loop.stop(); });
      loop.run();
      loop.unwatch(stop_fd_);
    });
    const auto error = started.get();
    if (error) {
      std::fprintf(stderr, "bench_simbus: cannot open hub: %s\n", error.message().c_str());
      std::exit(2);
    }
  }
  ~HubThread() {
    const std::uint64_t one = 1;
    [[maybe_unused]] const auto n = ::write(stop_fd_, &one, sizeof one);
    thread_.join();
    ::close(stop_fd_);
  }
  HubThread(const HubThread&) = delete;
  HubThread& operator=(const HubThread&) = delete;

 private:
  int stop_fd_ = -1;
  std::thread thread_;
};

// ---- links: what the client loop drives --------------------------------------------------------

enum class SendResult { kOk, kFull, kError };

class Link {
 public:
  virtual ~Link() = default;
  [[nodiscard]] virtual int rx_fd() const = 0;
  virtual SendResult send(const can::Frame& frame) = 0;
  virtual std::optional<can::Frame> receive() = 0;
  virtual void drain_tx_side() {}
};

// Two SocketEndpoints on a hub.
class SimLink final : public Link {
 public:
  SimLink(const std::filesystem::path& dir, const std::string& bus) {
    std::error_code error;
    tx_ = SocketEndpoint::connect(bus, EndpointOptions{dir, "bench tx", false}, error);
    if (tx_) rx_ = SocketEndpoint::connect(bus, EndpointOptions{dir, "bench rx", false}, error);
    if (!tx_ || !rx_) {
      std::fprintf(stderr, "bench_simbus: cannot connect: %s\n", error.message().c_str());
      std::exit(2);
    }
    // Both attached (Welcome received) before anything is measured.
    for (auto* e : {tx_.get(), rx_.get()}) {
      const auto deadline = Clock::now() + std::chrono::seconds(5);
      while (e->endpoint_id() == 0 && Clock::now() < deadline) {
        pollfd p{e->fd(), POLLIN, 0};
        ::poll(&p, 1, 50);
        while (e->receive()) {}
      }
      if (e->endpoint_id() == 0) {
        std::fprintf(stderr, "bench_simbus: no Welcome from the hub\n");
        std::exit(2);
      }
    }
  }
  [[nodiscard]] int rx_fd() const override { return rx_->fd(); }
  SendResult send(const can::Frame& frame) override {
    const auto error = tx_->send(frame);
    if (!error) return SendResult::kOk;
    return error == std::errc::no_buffer_space ? SendResult::kFull : SendResult::kError;
  }
  std::optional<can::Frame> receive() override { return rx_->receive(); }
  void drain_tx_side() override {
    while (tx_->receive()) {}
  }

 private:
  std::unique_ptr<SocketEndpoint> tx_;
  std::unique_ptr<SocketEndpoint> rx_;
};

// The bound: the same datagrams through a thread that only recv()s and send()s them on.
class RawRelayLink final : public Link {
 public:
  RawRelayLink() {
    int a[2];
    int b[2];
    if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0, a) != 0 ||
        ::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0, b) != 0) {
      std::perror("socketpair");
      std::exit(2);
    }
    tx_ = a[0];
    rx_ = b[0];
    const int in = a[1];
    const int out = b[1];
    relay_ = std::thread([in, out] {
      std::array<std::uint8_t, wire::kMaxMessageSize> buffer{};
      while (true) {
        pollfd p{in, POLLIN, 0};
        ::poll(&p, 1, -1);
        while (true) {
          const ssize_t n = ::recv(in, buffer.data(), buffer.size(), MSG_DONTWAIT);
          if (n == 0) {
            ::close(in);
            ::close(out);
            return;
          }
          if (n < 0) break;
          // The hub does as much per frame: decode, and encode for the receiver.
          const auto message = wire::decode({buffer.data(), static_cast<std::size_t>(n)});
          if (!message) continue;
          const auto size = wire::encode(*message, buffer);
          while (::send(out, buffer.data(), size, MSG_DONTWAIT) < 0 && errno == EAGAIN) {
            pollfd w{out, POLLOUT, 0};
            ::poll(&w, 1, 10);
          }
        }
      }
    });
  }
  ~RawRelayLink() override {
    ::close(tx_);
    relay_.join();
    ::close(rx_);
  }
  RawRelayLink(const RawRelayLink&) = delete;
  RawRelayLink& operator=(const RawRelayLink&) = delete;

  [[nodiscard]] int rx_fd() const override { return rx_; }
  SendResult send(const can::Frame& frame) override {
    std::array<std::uint8_t, wire::kMaxMessageSize> buffer{};
    const auto size = wire::encode(wire::FrameMessage{frame, false}, buffer);
    if (::send(tx_, buffer.data(), size, MSG_DONTWAIT) == static_cast<ssize_t>(size)) return SendResult::kOk;
    return errno == EAGAIN ? SendResult::kFull : SendResult::kError;
  }
  std::optional<can::Frame> receive() override {
    std::array<std::uint8_t, wire::kMaxMessageSize> buffer{};
    while (true) {
      const ssize_t n = ::recv(rx_, buffer.data(), buffer.size(), MSG_DONTWAIT);
      if (n <= 0) return std::nullopt;
      const auto message = wire::decode({buffer.data(), static_cast<std::size_t>(n)});
      if (message && std::holds_alternative<wire::FrameMessage>(*message))
        return std::get<wire::FrameMessage>(*message).frame;
    }
  }

 private:
  int tx_ = -1;
  int rx_ = -1;
  std::thread relay_;
};

// ---- client loops ------------------------------------------------------------------------------

struct StreamResult {
  std::uint64_t sent = 0;
  std::uint64_t received = 0;
  double wall_s = 0;
  std::int64_t first_ts_us = 0;  // frame timestamps (simulated end of frame), when the link has them
  std::int64_t last_ts_us = 0;
};

// Sends `count` copies of `frame` keeping at most `window` in flight, until all arrived or `timeout`.
StreamResult stream(Link& link, const can::Frame& frame, std::uint64_t count, std::uint64_t window,
                    std::chrono::milliseconds timeout);

struct Percentiles {
  double p50 = 0;
  double p99 = 0;
  std::size_t samples = 0;
};

// One frame at a time: time from send() to receive() on the other side.
Percentiles one_way_latency(Link& link, const can::Frame& frame, int samples);

}  // namespace motion::simbus::bench
