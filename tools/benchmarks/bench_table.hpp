// The figure table the benchmarks print: one row per figure with what was measured, the bound
// measured in the same run and their ratio. Header-only, for the bench_* programs.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace motion::bench {

struct Row {
  std::string what;
  std::string measured;
  std::string bound;
  double ratio = 0;
  std::string note;
};

// The q-quantile (q from 0 to 1) of `v` by nearest rank: the sorted sample at q x (n - 1), rounded;
// NAN when there is none. (bench_process.hpp's percentile interpolates, p in percent.)
inline double nearest_rank(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::lround(q * static_cast<double>(v.size() - 1)));
  return v[std::min(i, v.size() - 1)];
}

// printf-style formatting of one or two numbers into a short cell.
inline std::string fmt(const char* format, double a) {
  char text[128];
  std::snprintf(text, sizeof text, format, a);
  return text;
}
inline std::string fmt2(const char* format, double a, double b) {
  char text[128];
  std::snprintf(text, sizeof text, format, a, b);
  return text;
}

// Prints `rows` under a header naming the first and the bound column; columns fit their contents.
inline void print_rows(const std::vector<Row>& rows, const std::string& what_header, const std::string& bound_header) {
  std::size_t what_w = what_header.size(), measured_w = 8, bound_w = bound_header.size();
  for (const auto& r : rows) {
    what_w = std::max(what_w, r.what.size());
    measured_w = std::max(measured_w, r.measured.size());
    bound_w = std::max(bound_w, r.bound.size());
  }
  const auto w = [](std::size_t n) { return static_cast<int>(n); };
  std::printf("\n%-*s %-*s %-*s %8s  %s\n", w(what_w), what_header.c_str(), w(measured_w), "measured", w(bound_w),
              bound_header.c_str(), "ratio", "note");
  std::printf("%s\n", std::string(what_w + measured_w + bound_w + 24, '-').c_str());
  for (const auto& r : rows) {
    // A row without a bound (NAN or no bound text) has no ratio either.
    const std::string ratio = std::isnan(r.ratio) || r.bound.empty() ? "" : fmt("%.2fx", r.ratio);
    std::printf("%-*s %-*s %-*s %8s  %s\n", w(what_w), r.what.c_str(), w(measured_w), r.measured.c_str(), w(bound_w),
                r.bound.c_str(), ratio.c_str(), r.note.c_str());
  }
}

}  // namespace motion::bench
