#pragma once
// Simple scientific x-y plots for the command line (`collide fit`): points with
// error bars and lines, autoscaled axes with ticks, a legend. One layout is
// drawn onto two canvases, SVG text and a PNG image, so both files always show
// the same plot. (The GUI draws its own with Qt Charts.)
#include <optional>
#include <string>
#include <vector>

#include "analysis/result.hpp"

namespace collide::app {

struct Series {
  enum class Style { Points, Line };
  std::string label;
  Style style = Style::Points;
  std::vector<double> x, y;
  std::vector<double> y_err;  ///< optional: one-sigma error bars (same length as y) or empty
  int colour = 0;             ///< index into the palette
};

struct PlotSpec {
  std::string title;
  std::string x_label;  ///< include the unit, e.g. "|v_n| (m/s)"
  std::string y_label;
  std::vector<Series> series;
  std::optional<double> x_min, x_max, y_min, y_max;  ///< fixed range; autoscaled otherwise
};

/// The plot as an SVG document (width x height in px).
std::string renderSvg(const PlotSpec& plot, int width = 800, int height = 560);

/// Writes `<path_stem>.svg` and `<path_stem>.png`. Errors name the file.
Status savePlot(const PlotSpec& plot, const std::string& path_stem, int width = 800,
                int height = 560);

/// Round axis limits and tick positions covering [lo, hi] with about `target` ticks.
std::vector<double> niceTicks(double lo, double hi, int target = 6);

}  // namespace collide::app
