// One gateway per bus: an advisory lock (flock(2), exclusive, non-blocking) on a file named after
// the bus's transport, held for the life of the process and released by the kernel when it ends,
// however it ends. Two gateways on one bus would both answer for its drives, both poll them and
// execute each other's commands; the second one refuses to start instead and names the process
// that holds the bus.
//
// Where the lock lives: simulated transports (simcan:, simserial:) in the lab's runtime directory
// (config::sim_runtime_dir, one per simulated lab); hardware transports in MOTION_LOCK_DIR when
// set, else /run/lock (the system's lock directory, as serial tools use), else the temporary
// directory. The file holds the owner's pid for the message.
//
// Its mode is set explicitly, not left to the umask: 0600, or 0640 and simulation.group for a
// simulated bus when that group is configured (other gateway users of the group take the lock
// through a read-only descriptor). A symbolic link or anything but a regular file in its place
// is refused, never followed. A simulated lab's runtime folder that does not exist yet is made
// 0700 (0710 with the group), as motion-sim makes it.
//
// Thread contract: none (called once at start-up, before the event loop runs).
#pragma once

#include <string>
#include <variant>

#include "motion/config/config.hpp"

namespace motion::gateway {

class BusLock {
 public:
  BusLock() = default;
  BusLock(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  BusLock(BusLock&& other) noexcept;
  BusLock& operator=(BusLock&& other) noexcept;
  BusLock(const BusLock&) = delete;
  BusLock& operator=(const BusLock&) = delete;
  ~BusLock();

  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  int fd_ = -1;
  std::string path_;
};

// The lock file of `bus` (see above).
[[nodiscard]] std::string bus_lock_path(const config::Config& config, const config::Bus& bus);

// The position record of `bus` (motion/gateway/position_record.hpp), kept across the gateway's
// restarts and the machine's: simulated transports in the lab's runtime directory (the simulated
// drives live as long as motion-sim does); hardware transports in MOTION_STATE_DIR when set (the
// systemd unit: /var/lib/motionbus, its StateDirectory), else /var/lib/motionbus when it is a
// writable folder, else where the lock lives.
[[nodiscard]] std::string position_record_path(const config::Config& config, const config::Bus& bus);

// Takes the bus, or says who holds it: "bus can0 (simcan:can0) is already served by process 4242
// (lock /tmp/motion-sim-1000/gateway-simcan_can0.lock)", or why it could not: "refusing the lock of
// bus can0 (simcan:can0) at PATH: it is a symbolic link".
[[nodiscard]] std::variant<BusLock, std::string> lock_bus(const config::Config& config, const config::Bus& bus);

}  // namespace motion::gateway
