#include <gshell/render/color_map.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace gshell {
namespace {

Eigen::Vector3f lerp(const Eigen::Vector3f& a, const Eigen::Vector3f& b, double t) {
  return a + static_cast<float>(t) * (b - a);
}

} // namespace

Eigen::Vector3f ColorScale::ramp_color(double t) const {
  t = std::clamp(std::isfinite(t) ? t : 0.0, 0.0, 1.0);
  // Saturated but not neon, so shading stays readable on all three.
  const Eigen::Vector3f green(0.15f, 0.70f, 0.25f), yellow(0.97f, 0.85f, 0.15f), red(0.85f, 0.12f, 0.10f);
  const Eigen::Vector3f blue(0.15f, 0.35f, 0.85f);
  const Eigen::Vector3f& low = ramp == Ramp::GreenYellowRed ? green : blue;
  const Eigen::Vector3f& mid = ramp == Ramp::GreenYellowRed ? yellow : green;
  return t < 0.5 ? lerp(low, mid, 2 * t) : lerp(mid, red, 2 * t - 1);
}

Eigen::Vector3f ColorScale::color(double value) const {
  if (!std::isfinite(value)) return Eigen::Vector3f(0.6f, 0.6f, 0.6f);
  const double span = max - min;
  return ramp_color(span > 0 ? (value - min) / span : (value > min ? 1.0 : 0.0));
}

Eigen::MatrixXf map_colors(const ColorScale& scale, const Eigen::VectorXd& values) {
  Eigen::MatrixXf colors(values.size(), 3);
  for (Eigen::Index i = 0; i < values.size(); ++i) colors.row(i) = scale.color(values[i]).transpose();
  return colors;
}

double round_up_nice(double x) {
  if (!(x > 0) || !std::isfinite(x)) return 0;
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * p >= x * (1 - 1e-12)) return m * p;
  return 10 * p;
}

double quantile(std::vector<double> values, double q) {
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return !std::isfinite(v); }), values.end());
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const double pos = std::clamp(q, 0.0, 1.0) * (values.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  if (i + 1 >= values.size()) return values.back();
  return values[i] + (pos - i) * (values[i + 1] - values[i]);
}

} // namespace gshell
