// Trajectories as a standalone SVG document: one panel per axis, position (left scale, solid)
// and velocity (right scale, dashed) over time, with labelled vertical marks (a request's start and
// end). Written directly as text: no plotting library. motionctl log --plot uses it.
//
// The document is stable for tests: each panel is <g class="panel" data-axis="NAME">, each curve a
// <polyline class="position"> or <polyline class="velocity"> with one "x,y" point per sample, in
// sample order; each mark a <line class="mark"> and a <text class="mark">.
//
// Thread contract: none (a pure function).
#pragma once

#include <string>
#include <vector>

namespace motion::web {

struct PlotSample {
  double t = 0;  // seconds, any origin
  double position = 0;
  double velocity = 0;
};

struct PlotAxis {
  std::string name;
  std::string unit;  // user unit, e.g. "mm"; empty: none shown
  std::vector<PlotSample> samples;
};

struct PlotMark {
  double t = 0;
  std::string label;
  std::vector<std::string> axes;  // the panels it is drawn in; empty: every panel
};

struct SvgPlotOptions {
  std::string title;
  int width = 960;         // pixels
  int panel_height = 200;  // pixels per axis
};

// The geometry every panel shares (exposed for tests): the plot area of panel i is
// [kLeft, width - kRight] x [top(i) + kPanelTop, top(i) + panel_height - kPanelBottom].
inline constexpr int kSvgPlotLeft = 70;
inline constexpr int kSvgPlotRight = 70;
inline constexpr int kSvgPlotTitle = 30;        // above the first panel
inline constexpr int kSvgPlotPanelTop = 22;     // the panel's heading
inline constexpr int kSvgPlotPanelBottom = 30;  // the time scale

[[nodiscard]] std::string svg_plot(const std::vector<PlotAxis>& axes, const std::vector<PlotMark>& marks,
                                   const SvgPlotOptions& options);

}  // namespace motion::web
