// Shrinking a failing case of the randomized whole-lab test (delta debugging over its steps, values
// and drives) and printing it as ready-to-paste C++ for a regression test.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <set>
#include <sstream>

#include "random_lab.hpp"

namespace motion::random_lab {
namespace {

// The lab without the axes no step names (stops of every axis name none: then all stay).
LabSpec used_axes_only(const LabSpec& lab, const std::vector<Step>& steps) {
  std::set<std::string> used;
  for (const auto& s : steps) {
    if (s.axes.empty()) return lab;
    used.insert(s.axes.begin(), s.axes.end());
    used.insert(s.second_axes.begin(), s.second_axes.end());
  }
  LabSpec out = lab;
  out.axes.clear();
  for (const auto& a : lab.axes)
    if (used.contains(a.name)) out.axes.push_back(a);
  return out.axes.empty() ? lab : out;
}

}  // namespace

Shrunk shrink(const LabSpec& lab, const std::vector<Step>& steps, const RunResult& first, std::chrono::seconds budget) {
  Shrunk best{lab, steps, first, 0};
  const auto deadline = std::chrono::steady_clock::now() + budget;
  int salt = 1;
  const auto try_case = [&](const LabSpec& l, const std::vector<Step>& s) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    ++best.runs;
    RunOptions o;
    o.salt = salt++;
    auto r = run_case(l, s, o);
    std::printf("  shrink run %d: %zu steps, %zu drives: %s\n", best.runs, s.size(), l.axes.size(),
                r.ok ? "passes" : "fails");
    std::fflush(stdout);
    if (r.ok) return false;
    best = Shrunk{l, s, r, best.runs};
    return true;
  };
  // Steps after the failing one never matter.
  if (first.failed_step >= 0 && static_cast<std::size_t>(first.failed_step) + 1 < best.steps.size()) {
    best.steps.resize(static_cast<std::size_t>(first.failed_step) + 1);
  }
  // Delta debugging: drop chunks of n steps, halving n (the last step, the failing one, stays).
  for (std::size_t chunk = std::max<std::size_t>(1, best.steps.size() / 2); chunk >= 1; chunk /= 2) {
    for (std::size_t start = 0; start + 1 < best.steps.size();) {
      std::vector<Step> candidate = best.steps;
      const std::size_t end = std::min(start + chunk, candidate.size() - 1);
      candidate.erase(candidate.begin() + static_cast<std::ptrdiff_t>(start),
                      candidate.begin() + static_cast<std::ptrdiff_t>(end));
      if (!try_case(best.lab, candidate)) start += chunk;
      if (std::chrono::steady_clock::now() >= deadline) break;
    }
    if (chunk == 1 || std::chrono::steady_clock::now() >= deadline) break;
  }
  // Simpler values: scales back to the default, timeouts to 0.
  for (std::size_t i = 0; i < best.steps.size(); ++i) {
    Step s = best.steps[i];
    if (s.velocity_scale == 0 && s.acceleration_scale == 0 && s.timeout_ms == 0) continue;
    if (s.op == Op::kConflict) continue;  // its slowness is the point
    s.velocity_scale = s.acceleration_scale = 0;
    s.timeout_ms = 0;
    auto candidate = best.steps;
    candidate[i] = s;
    try_case(best.lab, candidate);
  }
  // Fewer drives: those no step names, then each one on its own.
  const LabSpec fewer = used_axes_only(best.lab, best.steps);
  if (fewer.axes.size() < best.lab.axes.size()) try_case(fewer, best.steps);
  return best;
}

std::string reproduction(const LabSpec& lab, const std::vector<Step>& steps, const RunResult& result,
                         std::uint64_t seed) {
  std::ostringstream out;
  out << "// random_lab seed " << seed << ": fails at step " << result.failed_step << ": " << result.failure << "\n";
  out << "TEST(RandomLabRegression, Seed" << seed << ") {\n";
  out << "  LabSpec spec;\n  spec.can_bitrate = " << lab.can_bitrate << ";\n  spec.rs485_baud = " << lab.rs485_baud
      << ";\n  spec.rs232_baud = " << lab.rs232_baud << ";\n  spec.rs485_parity = \"" << lab.rs485_parity << "\";\n";
  if (lab.security) out << "  spec.security = true;\n";
  if (lab.serial_link != "pty") out << "  spec.serial_link = \"" << lab.serial_link << "\";\n";
  for (const auto& a : lab.axes) {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "  spec.axes.push_back(AxisSpec{\"%s\", DriveSpec{\"%s\", \"%s\", %d, %d}, %.17g, %.17g, %.17g, "
                  "%.17g, %.17g, %s, %.17g, %d, %.17g});\n",
                  a.name.c_str(), a.drive.family.c_str(), a.drive.bus.c_str(), a.drive.node_id, a.drive.group_id,
                  a.steps_per_unit, a.min, a.max, a.velocity, a.acceleration, a.homing ? "true" : "false",
                  a.home_offset, a.home_input, a.home_velocity);
    out << buf;
  }
  out << "  const std::vector<Step> steps = {\n";
  for (const auto& s : steps) out << "      " << s.cpp() << ",\n";
  out << "  };\n  const auto result = run_case(spec, steps);\n  EXPECT_TRUE(result.ok) << result.failure << \"\\n\" << "
         "result.log;\n}\n";
  out << "// the lab as YAML:\n";
  std::istringstream yaml(lab.yaml());
  for (std::string line; std::getline(yaml, line);) out << "//   " << line << "\n";
  return out.str();
}

}  // namespace motion::random_lab
