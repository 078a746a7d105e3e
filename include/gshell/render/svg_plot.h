#pragma once
// Small self-contained SVG line plots for the HTML report.
#include <gshell/io/xml_escape.h>

#include <string>
#include <vector>

namespace gshell {

struct PlotOptions {
  std::string title, x_label, y_label;
  bool log_y = false;        ///< logarithmic y axis (only used when every value is > 0)
  int width = 560, height = 280;
  int x_start = 0;           ///< x of the first value (0: iteration 0 = the start state)
};

/// One named line of a plot: points (x_start + i, y[i]); non-finite values are skipped.
struct PlotSeries {
  std::string name;
  std::vector<double> y;
};

/// Lines on shared axes (a legend when there are several). Returns an <svg> element
/// (well-formed XML; all text escaped).
std::string svg_line_plot(const std::vector<PlotSeries>& series, const PlotOptions& options);

/// A single line.
std::string svg_line_plot(const std::vector<double>& y, const PlotOptions& options);

} // namespace gshell
