// A multicast URL of this test process's own (port from the pid), so tests that ctest runs in
// parallel never hear each other.
#pragma once

#include <unistd.h>

#include <string>

namespace motion::testing {

inline std::string unique_lcm_url(int salt = 0) {
  const int port = 20000 + (static_cast<int>(::getpid()) * 7 + salt) % 40000;
  return "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0";
}

}  // namespace motion::testing
