// Line and scatter plots as SVG files (for generated study documents): axes linear or logarithmic,
// one colour per series, a legend. No dependency beyond the standard library.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/util/status.h"

namespace kgd::study {

struct PlotSeries {
  std::string name;
  std::vector<std::pair<double, double>> points;  // (x, y); points a log axis cannot show are left out
  bool lines = true;                              // joined in the given order; false: markers only
};

struct Plot {
  std::string title, x_label, y_label;
  bool log_x = false, log_y = false;
  std::vector<PlotSeries> series;
};

// Writes `plot` as an SVG of 720 x 440 px. Errors: the file cannot be written.
Status WriteSvgPlot(const std::string& path, const Plot& plot);

}  // namespace kgd::study
