// Test bench for the UIMessage transport: a pty whose slave is the "serial port" the transport
// opens (through a symlink, like /dev/serial/by-id/...) and whose master is the UIROBOT gateway's
// end of the cable. Waits are bounded by a guard (a hang fails the test); nothing asserts on time.
#pragma once

#include <gtest/gtest.h>
#include <poll.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "motion/can/transport.hpp"
#include "motion/serial/pty_link.hpp"

namespace motion::uimessage::test {

inline constexpr int kGuardMs = 3000;  // only ever reached when something hangs

// A private directory for the pty links of one test.
class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    path_ = std::filesystem::temp_directory_path() /
            ("uimessage-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  [[nodiscard]] std::string file(std::string_view name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

inline std::vector<std::uint8_t> hex_bytes(std::string_view text) {
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i < text.size();) {
    if (text[i] == ' ') {
      ++i;
      continue;
    }
    out.push_back(static_cast<std::uint8_t>(std::stoul(std::string(text.substr(i, 2)), nullptr, 16)));
    i += 2;
  }
  return out;
}

inline std::string hex(std::span<const std::uint8_t> bytes) {
  static constexpr char kDigits[] = "0123456789ABCDEF";
  std::string out;
  for (const auto b : bytes) {
    if (!out.empty()) out.push_back(' ');
    out.push_back(kDigits[b >> 4]);
    out.push_back(kDigits[b & 0x0F]);
  }
  return out;
}

// True when `fd` polls readable within the guard time.
inline bool wait_readable(int fd) {
  pollfd p{fd, POLLIN, 0};
  return ::poll(&p, 1, kGuardMs) > 0;
}

// The gateway's end of the cable: a pty master, the slave reachable at `link`.
class PtyPeer {
 public:
  explicit PtyPeer(const std::string& link) {
    std::error_code error;
    pty_ = serial::PtyLink::create(link, serial::SerialSettings{}, error);
    EXPECT_TRUE(pty_ != nullptr) << error.message();
  }
  [[nodiscard]] const std::string& link() const { return pty_->link_path(); }
  [[nodiscard]] int fd() const { return pty_->master_fd(); }

  void write(std::span<const std::uint8_t> bytes) const {
    while (!bytes.empty()) {
      const ssize_t n = ::write(fd(), bytes.data(), bytes.size());
      if (n < 0) {
        pollfd p{fd(), POLLOUT, 0};
        ASSERT_GT(::poll(&p, 1, kGuardMs), 0) << "the pty does not take bytes";
        continue;
      }
      bytes = bytes.subspan(static_cast<std::size_t>(n));
    }
  }
  void write(std::string_view hex_text) const { write(hex_bytes(hex_text)); }

  // Exactly `count` bytes the host wrote (fails the test when they do not come).
  std::vector<std::uint8_t> read(std::size_t count) const {
    std::vector<std::uint8_t> out(count);
    std::size_t have = 0;
    while (have < count) {
      const ssize_t n = ::read(fd(), out.data() + have, count - have);
      if (n > 0) {
        have += static_cast<std::size_t>(n);
        continue;
      }
      if (!wait_readable(fd())) {
        ADD_FAILURE() << "got " << have << " of " << count << " bytes from the host";
        out.resize(have);
        return out;
      }
    }
    return out;
  }

 private:
  std::unique_ptr<serial::PtyLink> pty_;
};

// The next `count` frames of `transport`, waiting on its fd (fails the test when they do not come).
inline std::vector<can::Frame> receive_frames(can::Transport& transport, std::size_t count) {
  std::vector<can::Frame> out;
  while (out.size() < count) {
    if (auto frame = transport.receive()) {
      out.push_back(*frame);
      continue;
    }
    if (!wait_readable(transport.fd())) {
      ADD_FAILURE() << "received " << out.size() << " of " << count << " frames";
      break;
    }
  }
  return out;
}

}  // namespace motion::uimessage::test
