#include "motion/core/cpu_latency.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>

namespace motion {

CpuLatencyRequest::CpuLatencyRequest(std::chrono::microseconds limit, const char* device) {
  if (limit.count() < 0 || limit.count() > INT32_MAX) {
    error_ = std::make_error_code(std::errc::invalid_argument);
    return;
  }
  const int fd = ::open(device, O_WRONLY | O_CLOEXEC);
  if (fd < 0) {
    error_ = std::error_code(errno, std::generic_category());
    return;
  }
  // The kernel reads a binary s32 (or a hex string); the request lasts while the file is open.
  const auto value = static_cast<std::int32_t>(limit.count());
  if (::write(fd, &value, sizeof value) != static_cast<ssize_t>(sizeof value)) {
    error_ = std::error_code(errno != 0 ? errno : EIO, std::generic_category());
    ::close(fd);
    return;
  }
  fd_ = fd;
}

CpuLatencyRequest::~CpuLatencyRequest() {
  if (fd_ >= 0) ::close(fd_);
}

}  // namespace motion
