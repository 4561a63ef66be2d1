// libFuzzer entry point of one target (MOTION_FUZZ_TARGET, set per executable by CMake).
#include "fuzz_targets.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return motion::fuzz::MOTION_FUZZ_TARGET(data, size);
}
