// Enables two axes, moves them together (one synchronized request) and prints their final positions.
//   example_move [--lcm-url URL] [--prefix MOTION_] [--axes x y] [--targets 10 5] [--timeout 30]
// Exit codes: 0 done, 1 the coordinator refused or the move failed (its reason is printed),
// 2 bad command line, 4 LCM unavailable.
//
// Built against the installed C++ client (motion::client): see CMakeLists.txt beside it, or
//   c++ -std=c++20 example_move.cpp $(pkg-config --cflags --libs motion-client) -o example_move
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>

#include "motion/client/client.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/lcm/node.hpp"

namespace {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;
constexpr int kExitUnavailable = 4;

int fail(const motionlcm::reply_t& r) {
  std::fprintf(stderr, "example_move: %s (error %d): %s\n", motion::client::status_name(r.status), r.error_code,
               r.reason.c_str());
  return kExitFailure;
}

}  // namespace

int main(int argc, char** argv) try {
  CLI::App cli{"Enables two axes, moves them together (one synchronized request) and prints their final positions",
               "example_move"};
  std::string url;
  std::string prefix = "MOTION_";
  std::vector<std::string> axes{"x", "y"};
  std::vector<double> targets{10.0, 5.0};
  double timeout_s = 30.0;
  cli.add_option("--lcm-url", url, "LCM URL (default: $LCM_DEFAULT_URL, then LCM's default)");
  cli.add_option("--prefix", prefix, "Channel prefix (lcm.channel_prefix)")->capture_default_str();
  cli.add_option("--axes", axes, "The two axes")->expected(2)->capture_default_str();
  cli.add_option("--targets", targets, "Absolute targets in user units")->expected(2)->capture_default_str();
  cli.add_option("--timeout", timeout_s, "Seconds to wait for each terminal reply")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? kExitOk : kExitUsage;  // --help is not an error
  }

  motion::EventLoop loop;
  motion::lcm::Node node(loop, {url, prefix});
  if (!node.ok()) {
    std::fprintf(stderr, "example_move: LCM unavailable: cannot open '%s'\n", url.empty() ? "<default>" : url.c_str());
    return kExitUnavailable;
  }
  motion::client::Client client(loop, node, "example_move.cpp");
  const auto timeout = std::chrono::milliseconds(std::llround(timeout_s * 1000));

  auto r = client.call(motion::client::Client::make(motionlcm::request_t::ENABLE, axes), timeout);
  if (r.status != motionlcm::reply_t::DONE) return fail(r);
  std::printf("enabled %s %s\n", axes[0].c_str(), axes[1].c_str());

  const std::map<std::string, double> move{{axes[0], targets[0]}, {axes[1], targets[1]}};
  r = client.call(motion::client::Client::make(motionlcm::request_t::MOVE_ABSOLUTE, move), timeout,
                  [](const motionlcm::reply_t& p) {
                    std::printf("  %s %5.1f%%\n", motion::client::status_name(p.status), p.progress * 100);
                    std::fflush(stdout);
                  });
  if (r.status != motionlcm::reply_t::DONE) return fail(r);
  for (const auto& axis : axes) {
    double position = std::nan("");
    for (std::size_t i = 0; i < r.axes.size() && i < r.positions.size(); ++i) {
      if (r.axes[i] == axis) position = r.positions[i];
    }
    std::printf("%s = %.6g\n", axis.c_str(), position);
  }
  std::printf("measured start skew %.1f us (predicted arrival spread %.1f us)\n", r.measured_start_skew_us,
              r.predicted_skew_us);
  return kExitOk;
} catch (const std::exception& e) {  // LCM, memory: said, not an abort
  std::fprintf(stderr, "example_move: %s\n", e.what());
  return kExitFailure;
}
