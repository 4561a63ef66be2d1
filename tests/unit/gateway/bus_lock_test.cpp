// The one-gateway-per-bus lock file gets its mode explicitly, not from the umask (0600, or 0640
// and the group with simulation.group), and a symbolic link in its place is refused, not followed.
#include "bus_lock.hpp"

#include <grp.h>
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <variant>

#include "motion/testing/temp_dir.hpp"

namespace motion::gateway {
namespace {

namespace fs = std::filesystem;

struct BusLockTest : ::testing::Test {
  BusLockTest() {
    old_umask = ::umask(0);  // the most permissive umask: nothing may come from it
    config.simulation.runtime_dir = (root / "lab").string();
    sim_bus.name = "can0";
    sim_bus.transport = "simcan:can0";
    serial_bus.name = "rs232";
    serial_bus.transport = "serial:/dev/ttyUSB7";
  }
  ~BusLockTest() override {
    ::umask(old_umask);
    ::unsetenv("MOTION_LOCK_DIR");
  }
  static mode_t mode_of(const fs::path& p) {
    struct stat st {};
    return ::lstat(p.c_str(), &st) == 0 ? st.st_mode & 07777 : 0;
  }
  testing::TempDir tmp{"motion-buslock"};
  fs::path root = tmp.path();
  mode_t old_umask = 0;
  config::Config config;
  config::Bus sim_bus;
  config::Bus serial_bus;
};

TEST_F(BusLockTest, TheLockAndTheFolderItMadeAreTheOwnersAloneUnderAnyUmask) {
  auto lock = lock_bus(config, sim_bus);
  ASSERT_TRUE(std::holds_alternative<BusLock>(lock)) << std::get<std::string>(lock);
  const fs::path path = std::get<BusLock>(lock).path();
  EXPECT_EQ(path.parent_path(), root / "lab");
  EXPECT_EQ(mode_of(path), 0600U);
  EXPECT_EQ(mode_of(root / "lab"), 0700U);  // made before motion-sim: as motion-sim makes it

  // A hardware bus's lock in MOTION_LOCK_DIR, left 0666 by an earlier version: closed again.
  const fs::path lock_dir = root / "locks";
  fs::create_directory(lock_dir);
  ::setenv("MOTION_LOCK_DIR", lock_dir.c_str(), 1);
  const fs::path serial_path = bus_lock_path(config, serial_bus);
  std::ofstream(serial_path) << "4242\n";
  ASSERT_EQ(::chmod(serial_path.c_str(), 0666), 0);
  auto serial_lock = lock_bus(config, serial_bus);
  ASSERT_TRUE(std::holds_alternative<BusLock>(serial_lock)) << std::get<std::string>(serial_lock);
  EXPECT_EQ(mode_of(serial_path), 0600U);
}

TEST_F(BusLockTest, WithSimulationGroupItsMembersMayReadTheLock) {
  const group* own = ::getgrgid(::getgid());
  ASSERT_NE(own, nullptr);
  config.simulation.group = own->gr_name;
  auto lock = lock_bus(config, sim_bus);
  ASSERT_TRUE(std::holds_alternative<BusLock>(lock)) << std::get<std::string>(lock);
  const fs::path path = std::get<BusLock>(lock).path();
  EXPECT_EQ(mode_of(path), 0640U);
  EXPECT_EQ(mode_of(root / "lab"), 0710U);
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_gid, ::getgid());

  config.simulation.group = "no-such-group-here";
  config::Bus other = sim_bus;
  other.name = "can1";
  other.transport = "simcan:can1";
  auto unknown = lock_bus(config, other);
  ASSERT_TRUE(std::holds_alternative<std::string>(unknown));
  EXPECT_EQ(std::get<std::string>(unknown),
            "cannot lock bus can1 (simcan:can1): simulation.group: no group 'no-such-group-here' on this machine");
}

TEST_F(BusLockTest, ASymbolicLinkInTheLocksPlaceIsRefusedAndNotFollowed) {
  fs::create_directory(root / "lab");
  const fs::path victim = root / "victim";
  std::ofstream(victim) << "precious";
  ASSERT_EQ(::chmod(victim.c_str(), 0644), 0);
  const fs::path path = bus_lock_path(config, sim_bus);
  fs::create_symlink(victim, path);
  auto lock = lock_bus(config, sim_bus);
  ASSERT_TRUE(std::holds_alternative<std::string>(lock));
  EXPECT_EQ(std::get<std::string>(lock),
            "refusing the lock of bus can0 (simcan:can0) at " + path.string() + ": it is a symbolic link");
  std::ifstream in(victim);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), "precious");  // not truncated to a pid
  EXPECT_EQ(mode_of(victim), 0644U);                                           // nor chmod-ed

  // A dangling link (to where a file would be created) is refused as well.
  fs::remove(path);
  fs::create_symlink(root / "not-there", path);
  EXPECT_TRUE(std::holds_alternative<std::string>(lock_bus(config, sim_bus)));
  EXPECT_FALSE(fs::exists(root / "not-there"));
}

TEST_F(BusLockTest, ASecondLockOfTheBusNamesTheHolder) {
  auto first = lock_bus(config, sim_bus);
  ASSERT_TRUE(std::holds_alternative<BusLock>(first)) << std::get<std::string>(first);
  auto second = lock_bus(config, sim_bus);  // a new open file description: flock conflicts
  ASSERT_TRUE(std::holds_alternative<std::string>(second));
  EXPECT_NE(std::get<std::string>(second).find("is already served by process " + std::to_string(::getpid())),
            std::string::npos)
      << std::get<std::string>(second);
}

}  // namespace
}  // namespace motion::gateway
