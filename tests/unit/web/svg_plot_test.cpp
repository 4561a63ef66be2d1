// svg_plot: one panel per axis with every sample plotted, inside its panel, in time order; marks
// only in the panels of their axes; text escaped.
#include "motion/web/svg_plot.hpp"

#include <gtest/gtest.h>

#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace motion::web {
namespace {

struct Point {
  double x, y;
};

std::vector<std::string> all(const std::string& text, const std::string& pattern) {
  std::vector<std::string> out;
  const std::regex re(pattern);
  for (auto it = std::sregex_iterator(text.begin(), text.end(), re); it != std::sregex_iterator(); ++it)
    out.push_back((*it)[1].str());
  return out;
}

// The panel of `axis` (its <g> element's text).
std::string panel(const std::string& svg, const std::string& axis) {
  const auto start = svg.find("<g class=\"panel\" data-axis=\"" + axis + "\"");
  if (start == std::string::npos) return {};
  return svg.substr(start, svg.find("</g>", start) - start);
}

std::vector<Point> points(const std::string& panel_text, const std::string& curve) {
  const auto found = all(panel_text, "<polyline class=\"" + curve + "\"[^>]* points=\"([^\"]*)\"");
  std::vector<Point> out;
  if (found.size() != 1) return out;
  std::istringstream in(found[0]);
  for (std::string pair; in >> pair;) {
    const auto comma = pair.find(',');
    out.push_back({std::stod(pair.substr(0, comma)), std::stod(pair.substr(comma + 1))});
  }
  return out;
}

PlotAxis ramp(const std::string& name, int n, double slope) {
  PlotAxis a{name, "mm", {}};
  for (int i = 0; i < n; ++i) a.samples.push_back({0.1 * i, slope * i, slope * 10});
  return a;
}

TEST(SvgPlot, OnePanelPerAxisWithEverySampleInsideIt) {
  const SvgPlotOptions options{.title = "test", .width = 800, .panel_height = 150};
  const std::vector<PlotAxis> axes{ramp("x", 11, 1.0), ramp("y", 5, -2.0), ramp("z", 0, 0)};
  const auto svg = svg_plot(axes, {}, options);
  ASSERT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_EQ(all(svg, "<g class=\"panel\" data-axis=\"([^\"]*)\"").size(), 3u);

  for (std::size_t i = 0; i < axes.size(); ++i) {
    const auto& axis = axes[i];
    const auto text = panel(svg, axis.name);
    ASSERT_FALSE(text.empty()) << axis.name;
    const auto pos = points(text, "position");
    const auto vel = points(text, "velocity");
    ASSERT_EQ(pos.size(), axis.samples.size()) << axis.name;
    ASSERT_EQ(vel.size(), axis.samples.size()) << axis.name;
    const double top = kSvgPlotTitle + static_cast<double>(i) * options.panel_height + kSvgPlotPanelTop;
    const double bottom = kSvgPlotTitle + static_cast<double>(i + 1) * options.panel_height - kSvgPlotPanelBottom;
    for (std::size_t k = 0; k < pos.size(); ++k) {
      EXPECT_GE(pos[k].x, kSvgPlotLeft);
      EXPECT_LE(pos[k].x, options.width - kSvgPlotRight);
      EXPECT_GE(pos[k].y, top);
      EXPECT_LE(pos[k].y, bottom);
      EXPECT_DOUBLE_EQ(vel[k].x, pos[k].x);
      if (k > 0) {
        EXPECT_GT(pos[k].x, pos[k - 1].x);  // time goes right
        // SVG's y grows downwards: a rising position goes up, a falling one down.
        if (axis.samples[k].position > axis.samples[k - 1].position) { EXPECT_LT(pos[k].y, pos[k - 1].y); }
        if (axis.samples[k].position < axis.samples[k - 1].position) { EXPECT_GT(pos[k].y, pos[k - 1].y); }
      }
    }
  }
  // The panels share the time scale: x's first and last samples span the plot's width.
  const auto x = points(panel(svg, "x"), "position");
  EXPECT_NEAR(x.front().x, kSvgPlotLeft, 0.01);
  EXPECT_NEAR(x.back().x, options.width - kSvgPlotRight, 0.01);
}

TEST(SvgPlot, MarksAreDrawnInTheirAxesPanelsOnly) {
  const std::vector<PlotAxis> axes{ramp("x", 4, 1.0), ramp("y", 4, 1.0)};
  const std::vector<PlotMark> marks{{0.1, "move started", {"x"}}, {0.3, "move done", {"x"}}, {0.2, "stop <all>", {}}};
  const auto svg = svg_plot(axes, marks, {});
  EXPECT_EQ(all(panel(svg, "x"), "<line class=\"(mark)\"").size(), 3u);
  EXPECT_EQ(all(panel(svg, "y"), "<line class=\"(mark)\"").size(), 1u);
  EXPECT_NE(panel(svg, "x").find(">move started<"), std::string::npos);
  EXPECT_NE(svg.find("stop &lt;all&gt;"), std::string::npos);
  EXPECT_EQ(svg.find("stop <all>"), std::string::npos);
}

TEST(SvgPlot, NoAxisIsAValidDocumentSayingSo) {
  const auto svg = svg_plot({}, {}, {.title = "empty"});
  EXPECT_EQ(all(svg, "<g class=\"panel\"( )").size(), 0u);
  EXPECT_NE(svg.find("no axis state"), std::string::npos);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
}

}  // namespace
}  // namespace motion::web
