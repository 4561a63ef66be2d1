#include "motion/core/cpu_latency.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace motion {
namespace {

using std::chrono::microseconds;

std::string temp_device() {
  return (std::filesystem::temp_directory_path() / ("cpu-latency-test-" + std::to_string(::getpid()))).string();
}

// The request is the limit as a binary 32-bit integer, written once and held while the file is
// open (the kernel's PM QoS file reads it so): a stand-in file shows what was written.
TEST(CpuLatencyRequest, WritesTheLimitAsA32BitIntegerAndHoldsTheFileOpen) {
  const std::string path = temp_device();
  std::ofstream(path).close();
  {
    CpuLatencyRequest request(microseconds(75), path.c_str());
    EXPECT_TRUE(request.held());
    EXPECT_FALSE(request.error());
    std::ifstream in(path, std::ios::binary);
    std::int32_t value = -1;
    in.read(reinterpret_cast<char*>(&value), sizeof value);
    EXPECT_EQ(in.gcount(), static_cast<std::streamsize>(sizeof value));
    EXPECT_EQ(value, 75);
  }
  std::filesystem::remove(path);
}

TEST(CpuLatencyRequest, ARefusedRequestSaysWhyAndHoldsNothing) {
  CpuLatencyRequest missing(microseconds(0), "/nonexistent-dir/cpu_dma_latency");
  EXPECT_FALSE(missing.held());
  EXPECT_EQ(missing.error(), std::errc::no_such_file_or_directory);
  const std::string path = temp_device();
  std::ofstream(path).close();
  CpuLatencyRequest negative(microseconds(-1), path.c_str());
  EXPECT_FALSE(negative.held());
  EXPECT_EQ(negative.error(), std::errc::invalid_argument);
  EXPECT_EQ(std::filesystem::file_size(path), 0U) << "nothing written for a refused limit";
  std::filesystem::remove(path);
}

// On the kernel's own file (where this process may open it): reading it gives the limit in force,
// the lowest any process holds, so while ours is held it is at most ours.
TEST(CpuLatencyRequest, OnTheKernelsFileTheLimitInForceIsAtMostOurs) {
  CpuLatencyRequest request(microseconds(42));
  if (!request.held()) GTEST_SKIP() << "no /dev/cpu_dma_latency to write here: " << request.error().message();
  const int fd = ::open("/dev/cpu_dma_latency", O_RDONLY | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  std::int32_t in_force = -1;
  EXPECT_EQ(::read(fd, &in_force, sizeof in_force), static_cast<ssize_t>(sizeof in_force));
  ::close(fd);
  EXPECT_GE(in_force, 0);
  EXPECT_LE(in_force, 42);
}

}  // namespace
}  // namespace motion
