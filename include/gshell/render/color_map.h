#pragma once
// Value -> color maps for the renders and their color bars.
#include <gshell/format_number.h> // the color bars' labels
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <string>
#include <vector>

namespace gshell {

/// A linear color scale from `min` to `max`; values outside are clamped to the end colors.
/// Stretch: green (0) -> yellow (max/2) -> red (max), as in the paper's Fig. 4.
/// Thickness (relative to eta): blue (below 1) -> green (1) -> red (above 1).
struct ColorScale {
  enum class Ramp { GreenYellowRed, BlueGreenRed };
  Ramp ramp = Ramp::GreenYellowRed;
  double min = 0, max = 0.1;
  std::string label = "stretch"; ///< shown next to the color bar

  /// RGB in [0,1] of `value` (NaN maps to grey).
  Eigen::Vector3f color(double value) const;
  /// RGB of the ramp at t in [0,1] (t = (value - min) / (max - min)).
  Eigen::Vector3f ramp_color(double t) const;
};

/// Colors of many values (one RGB row each).
Eigen::MatrixXf map_colors(const ColorScale& scale, const Eigen::VectorXd& values);

/// The smallest "round" number (1, 2, 2.5 or 5 times a power of ten) >= x; x <= 0 gives 0.
double round_up_nice(double x);

/// The q-quantile (q in [0,1], linear interpolation) of the finite values; 0 when there are none.
double quantile(std::vector<double> values, double q);

} // namespace gshell
