// Internals shared by SocketCanTransport and SocketCanCyclic (not installed, not public API).
#pragma once

#include <linux/can.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <system_error>

#include "motion/can_frame/frame.hpp"

namespace motion::can::detail {

// Frame <-> kernel can_frame. to_kernel_frame() rejects ids/dlc out of range (nullopt-like: false).
[[nodiscard]] bool to_kernel_frame(const Frame& frame, can_frame& out);
[[nodiscard]] Frame from_kernel_frame(const can_frame& in);
// The kernel identifier (with CAN_EFF_FLAG) for an id in our notation; also the BCM job key.
[[nodiscard]] canid_t kernel_id(std::uint32_t id, bool extended);

// Owns one file descriptor (close on destruction / reset).
class UniqueFd {
 public:
  UniqueFd() = default;
  explicit UniqueFd(int fd) : fd_(fd) {}
  ~UniqueFd() { reset(); }
  UniqueFd(UniqueFd&& other) noexcept : fd_(other.release()) {}
  UniqueFd& operator=(UniqueFd&& other) noexcept {
    if (this != &other) reset(other.release());
    return *this;
  }
  UniqueFd(const UniqueFd&) = delete;
  UniqueFd& operator=(const UniqueFd&) = delete;

  [[nodiscard]] int get() const { return fd_; }
  [[nodiscard]] bool valid() const { return fd_ >= 0; }
  int release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }
  void reset(int fd = -1);

 private:
  int fd_ = -1;
};

// Interface index of `interface`, or the error (ENODEV, ENAMETOOLONG) naming it.
[[nodiscard]] std::error_code interface_index(std::string_view interface, int& index);

// A non-blocking AF_CAN socket of `protocol` (CAN_RAW: bound, CAN_BCM: connected) on `interface`.
[[nodiscard]] std::error_code open_can_socket(std::string_view interface, int protocol, UniqueFd& out, int& ifindex);

// errno as an error naming the interface.
[[nodiscard]] std::error_code last_error(std::string_view interface);

}  // namespace motion::can::detail
