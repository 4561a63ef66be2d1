#include "motion/web/svg_plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace motion::web {
namespace {

constexpr const char* kPositionColor = "#1f77b4";
constexpr const char* kVelocityColor = "#d62728";

std::string xml(const std::string& text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

std::string tick_label(double v, double step) {
  char buf[32];
  const int decimals = step >= 1 ? 0 : static_cast<int>(std::ceil(-std::log10(step)));
  std::snprintf(buf, sizeof buf, "%.*f", decimals, std::abs(v) < step * 1e-6 ? 0.0 : v);
  return buf;
}

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  // Empty: [0, 1]; one value: one unit around it; else 5 % margins.
  [[nodiscard]] Range padded() const {
    if (lo > hi) return {0, 1};
    if (hi - lo < 1e-12) return {lo - 1, hi + 1};
    const double m = (hi - lo) * 0.05;
    return {lo - m, hi + m};
  }
  [[nodiscard]] double span() const { return hi - lo; }
};

// 1, 2 or 5 times a power of ten, giving about `count` ticks over `span`.
double nice_step(double span, int count) {
  const double raw = span / count;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 5.0}) {
    if (raw <= m * power) return m * power;
  }
  return 10 * power;
}

struct Scale {
  Range domain;
  double from = 0;  // pixel of domain.lo
  double to = 0;    // pixel of domain.hi
  [[nodiscard]] double operator()(double v) const { return from + (v - domain.lo) / domain.span() * (to - from); }
};

}  // namespace

std::string svg_plot(const std::vector<PlotAxis>& axes, const std::vector<PlotMark>& marks,
                     const SvgPlotOptions& options) {
  const int panels = static_cast<int>(axes.size());
  const int height = kSvgPlotTitle + std::max(panels, 1) * options.panel_height;
  const double left = kSvgPlotLeft;
  const double right = options.width - kSvgPlotRight;

  Range time;
  for (const auto& a : axes) {
    for (const auto& s : a.samples) time.add(s.t);
  }
  for (const auto& m : marks) time.add(m.t);
  if (time.lo > time.hi) time = {0, 1};
  if (time.span() < 1e-9) time = {time.lo, time.lo + 1};
  const Scale x{time, left, right};
  const double time_step = nice_step(time.span(), 8);

  std::string out;
  out += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  out += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(options.width) + "\" height=\"" +
         std::to_string(height) + "\" viewBox=\"0 0 " + std::to_string(options.width) + " " + std::to_string(height) +
         "\" font-family=\"sans-serif\" font-size=\"11\">\n";
  out += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  out += "<text x=\"" + num(left) + "\" y=\"20\" font-size=\"14\" font-weight=\"bold\">" + xml(options.title) +
         "</text>\n";
  out += "<text x=\"" + num(right) + "\" y=\"20\" text-anchor=\"end\"><tspan fill=\"" + kPositionColor +
         "\">— position (left scale)</tspan>  <tspan fill=\"" + kVelocityColor +
         "\">- - velocity (right scale)</tspan></text>\n";
  if (axes.empty()) {
    out += "<text x=\"" + num(left) + "\" y=\"" + num(kSvgPlotTitle + 40) + "\">no axis state</text>\n";
  }

  for (int i = 0; i < panels; ++i) {
    const auto& axis = axes[static_cast<std::size_t>(i)];
    const double top = kSvgPlotTitle + i * options.panel_height + kSvgPlotPanelTop;
    const double bottom = kSvgPlotTitle + (i + 1) * options.panel_height - kSvgPlotPanelBottom;
    Range position, velocity;
    for (const auto& s : axis.samples) {
      position.add(s.position);
      velocity.add(s.velocity);
    }
    velocity.add(0);
    const Scale y{position.padded(), bottom, top};
    const Scale v{velocity.padded(), bottom, top};
    const std::string unit = axis.unit.empty() ? "" : " (" + xml(axis.unit) + ")";
    const std::string vunit = axis.unit.empty() ? "" : " (" + xml(axis.unit) + "/s)";

    out += "<g class=\"panel\" data-axis=\"" + xml(axis.name) + "\" data-samples=\"" +
           std::to_string(axis.samples.size()) + "\">\n";
    out += "<text x=\"" + num(left) + "\" y=\"" + num(top - 6) + "\" font-weight=\"bold\">axis " + xml(axis.name) +
           ": " + std::to_string(axis.samples.size()) + " samples</text>\n";
    out += "<rect class=\"frame\" x=\"" + num(left) + "\" y=\"" + num(top) + "\" width=\"" + num(right - left) +
           "\" height=\"" + num(bottom - top) + "\" fill=\"none\" stroke=\"#888\"/>\n";
    // Time grid and scale.
    for (double t = std::ceil(time.lo / time_step) * time_step; t <= time.hi + time_step * 1e-9; t += time_step) {
      out += "<line x1=\"" + num(x(t)) + "\" y1=\"" + num(top) + "\" x2=\"" + num(x(t)) + "\" y2=\"" + num(bottom) +
             "\" stroke=\"#eee\"/>";
      out += "<text x=\"" + num(x(t)) + "\" y=\"" + num(bottom + 13) + "\" text-anchor=\"middle\">" +
             tick_label(t, time_step) + "</text>\n";
    }
    out += "<text x=\"" + num(right) + "\" y=\"" + num(bottom + 26) + "\" text-anchor=\"end\">t (s)</text>\n";
    // Position scale (left) and velocity scale (right).
    const Range pr = y.domain;
    const double pstep = nice_step(pr.span(), 4);
    for (double p = std::ceil(pr.lo / pstep) * pstep; p <= pr.hi; p += pstep) {
      out += "<text x=\"" + num(left - 4) + "\" y=\"" + num(y(p) + 4) + "\" text-anchor=\"end\" fill=\"" +
             kPositionColor + "\">" + tick_label(p, pstep) + "</text>";
    }
    const Range vr = v.domain;
    const double vstep = nice_step(vr.span(), 4);
    for (double w = std::ceil(vr.lo / vstep) * vstep; w <= vr.hi; w += vstep) {
      out += "<text x=\"" + num(right + 4) + "\" y=\"" + num(v(w) + 4) + "\" fill=\"" + kVelocityColor + "\">" +
             tick_label(w, vstep) + "</text>";
    }
    out += "\n<text transform=\"translate(12," + num((top + bottom) / 2) +
           ") rotate(-90)\" text-anchor=\"middle\" fill=\"" + kPositionColor + "\">position" + unit + "</text>\n";
    out += "<text transform=\"translate(" + num(options.width - 8) + "," + num((top + bottom) / 2) +
           ") rotate(90)\" text-anchor=\"middle\" fill=\"" + kVelocityColor + "\">velocity" + vunit + "</text>\n";
    // Curves.
    std::string ppoints, vpoints;
    for (const auto& s : axis.samples) {
      ppoints += (ppoints.empty() ? "" : " ") + num(x(s.t)) + "," + num(y(s.position));
      vpoints += (vpoints.empty() ? "" : " ") + num(x(s.t)) + "," + num(v(s.velocity));
    }
    out += "<polyline class=\"velocity\" fill=\"none\" stroke=\"" + std::string(kVelocityColor) +
           "\" stroke-width=\"1.2\" stroke-dasharray=\"5,3\" points=\"" + vpoints + "\"/>\n";
    out += "<polyline class=\"position\" fill=\"none\" stroke=\"" + std::string(kPositionColor) +
           "\" stroke-width=\"1.5\" points=\"" + ppoints + "\"/>\n";
    // Marks; their labels on three rows, so that marks close in time stay readable.
    int drawn = 0;
    for (const auto& m : marks) {
      if (!m.axes.empty() && std::find(m.axes.begin(), m.axes.end(), axis.name) == m.axes.end()) continue;
      const double label_y = top + 11 + 11 * (drawn++ % 3);
      out += "<line class=\"mark\" x1=\"" + num(x(m.t)) + "\" y1=\"" + num(top) + "\" x2=\"" + num(x(m.t)) +
             "\" y2=\"" + num(bottom) + "\" stroke=\"#444\" stroke-dasharray=\"2,2\"/>";
      out += "<text class=\"mark\" x=\"" + num(x(m.t) + 3) + "\" y=\"" + num(label_y) + "\" fill=\"#444\">" +
             xml(m.label) + "</text>\n";
    }
    out += "</g>\n";
  }
  out += "</svg>\n";
  return out;
}

}  // namespace motion::web
