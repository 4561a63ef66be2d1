#include "bus_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>

#include "motion/core/file_access.hpp"

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

std::error_code restrict_lock(int fd, const std::optional<gid_t>& group, mode_t mode) {
  if (group && ::fchown(fd, static_cast<uid_t>(-1), *group) != 0) return {errno, std::generic_category()};
  if (::fchmod(fd, mode) != 0) return {errno, std::generic_category()};
  return {};
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
  const bool simulated = bus.transport.rfind("sim", 0) == 0;
  // A simulated bus's lock is shared with the other users of simulation.group (0640: they take it
  // read-only); a hardware bus's is its gateway user's alone (0600). Never the umask's.
  FileAccess access;
  if (simulated) {
    std::string why;
    const auto sim_access = config::sim_file_access(config, &why);
    if (!sim_access) return "cannot lock " + what + ": " + why;
    access = *sim_access;
  }
  const mode_t mode = access.group ? 0640 : 0600;
  const std::string dir = std::filesystem::path(path).parent_path().string();
  std::error_code ec;
  if (simulated && !std::filesystem::exists(dir, ec)) {
    // The lab's runtime folder, made here when the gateway starts before motion-sim: with the
    // same explicit mode motion-sim gives it (0700, 0710 with simulation.group).
    if (const auto error = make_private_dir(dir, access)) {
      return "cannot create the folder of the lock of " + what + " at " + dir + ": " + error.message();
    }
  } else {
    std::filesystem::create_directories(dir, ec);
  }
  // O_NOFOLLOW: a symbolic link planted in the lock's place (e.g. towards a file of the gateway's
  // user elsewhere) is refused, never followed, truncated or written.
  int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, mode);
  // A lock made by another gateway user of the group: readable, enough for flock(2).
  if (fd < 0 && errno == EACCES) fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0 && errno == ELOOP) return "refusing the lock of " + what + " at " + path + ": it is a symbolic link";
  if (fd < 0) return "cannot create the lock of " + what + " at " + path + ": " + std::strerror(errno);
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return "refusing the lock of " + what + " at " + path + ": not a regular file";
  }
  // Our own (made now or by an earlier run): its mode set explicitly, whatever the umask was.
  if (st.st_uid == ::geteuid()) {
    if (const auto error = restrict_lock(fd, access.group, mode)) {
      ::close(fd);
      return "cannot set the mode of the lock of " + what + " at " + path + ": " + error.message();
    }
  }
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
