#include "bus_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <utility>

namespace motion::gateway {

BusLock::BusLock(BusLock&& other) noexcept : fd_(std::exchange(other.fd_, -1)), path_(std::move(other.path_)) {}

BusLock& BusLock::operator=(BusLock&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    path_ = std::move(other.path_);
  }
  return *this;
}

BusLock::~BusLock() {
  if (fd_ >= 0) ::close(fd_);  // closing the last descriptor releases the flock
}

namespace {

bool writable_dir(const std::string& dir) {
  return std::filesystem::is_directory(dir) && ::access(dir.c_str(), W_OK) == 0;
}

std::string lock_dir(const config::Config& config, const config::Bus& bus) {
  if (bus.transport.rfind("sim", 0) == 0) return config::sim_runtime_dir(config);
  if (const char* env = std::getenv("MOTION_LOCK_DIR"); env != nullptr && *env != '\0') return env;
  if (writable_dir("/run/lock")) return "/run/lock";
  return std::filesystem::temp_directory_path().string();
}

std::string sanitized(const std::string& text) {
  std::string out;
  for (char c : text) out += (std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '-' || c == '.') ? c : '_';
  return out;
}

}  // namespace

std::string bus_lock_path(const config::Config& config, const config::Bus& bus) {
  return lock_dir(config, bus) + "/motionbus-gateway-" + sanitized(bus.transport) + ".lock";
}

std::string position_record_path(const config::Config& config, const config::Bus& bus) {
  std::string dir = lock_dir(config, bus);
  if (bus.transport.rfind("sim", 0) != 0) {
    if (const char* env = std::getenv("MOTION_STATE_DIR"); env != nullptr && *env != '\0') {
      dir = env;
    } else if (writable_dir("/var/lib/motionbus")) {
      dir = "/var/lib/motionbus";
    }
  }
  return dir + "/motionbus-gateway-" + sanitized(bus.transport) + ".positions";
}

std::variant<BusLock, std::string> lock_bus(const config::Config& config, const config::Bus& bus) {
  const std::string path = bus_lock_path(config, bus);
  const std::string what = "bus " + bus.name + " (" + bus.transport + ")";
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return "cannot create the lock of " + what + " at " + path + ": " + std::strerror(errno);
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    std::string holder;
    char buf[32] = {};
    const auto n = ::pread(fd, buf, sizeof buf - 1, 0);
    if (n > 0) holder = std::string(buf, static_cast<std::size_t>(n));
    while (!holder.empty() && (holder.back() == '\n' || holder.back() == ' ')) holder.pop_back();
    ::close(fd);
    if (err == EWOULDBLOCK) {
      return what + " is already served by " + (holder.empty() ? std::string("another gateway") : "process " + holder) +
             " (lock " + path + "); stop it first, or give this gateway another bus";
    }
    return "cannot lock " + what + " at " + path + ": " + std::strerror(err);
  }
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
    // The lock holds without the pid; the message of a second gateway is only less precise.
  }
  return BusLock(fd, path);
}

}  // namespace motion::gateway
