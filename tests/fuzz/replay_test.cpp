// Replays every fuzz target over its seed corpus (corpus/<target>/) and the inputs that once
// crashed it (regressions/<target>/), in the ordinary and the sanitizer builds: a fixed bug stays
// fixed without a fuzzing run.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "fuzz_targets.hpp"

namespace motion::fuzz {
namespace {

std::vector<std::uint8_t> read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::size_t replay(const Target& target, const std::filesystem::path& dir) {
  std::size_t n = 0;
  if (!std::filesystem::is_directory(dir)) return n;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    const auto bytes = read_file(entry.path());
    SCOPED_TRACE(entry.path().string());
    EXPECT_EQ(target.run(bytes.data(), bytes.size()), 0);
    ++n;
  }
  return n;
}

TEST(FuzzReplay, EveryTargetHasSeedsAndRunsThemAndItsRegressions) {
  const std::filesystem::path root = MOTION_FUZZ_DIR;
  for (const auto& target : kTargets) {
    SCOPED_TRACE(target.name);
    EXPECT_GT(replay(target, root / "corpus" / target.name), 0u) << "no seeds for " << target.name;
    replay(target, root / "regressions" / target.name);
  }
}

}  // namespace
}  // namespace motion::fuzz
