#include <gshell/guard/pair_ccd.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

namespace gshell {

namespace {

// Rounding allowance of a measured distance of a pair whose points lie in `box` and move at most
// `reach` (per coordinate): the flat/parallel switch of pair_distance overestimates d^2 by at most
// 1e-15 L^2 (L: the pair's extent over the motion), and forming coordinate differences costs a
// few ulps of the largest coordinate M. A measured d is lowered to sqrt(d^2 - squared) - absolute.
struct Allowance {
  double squared = 0, absolute = 0;
};

Allowance rounding_allowance(const Eigen::AlignedBox3d& box, double reach) {
  const double extent = box.diagonal().norm() + 2 * std::sqrt(3.0) * reach;
  const double coordinate = std::max(box.min().lpNorm<Eigen::Infinity>(), box.max().lpNorm<Eigen::Infinity>()) + reach;
  return {2e-15 * extent * extent, 32 * std::numeric_limits<double>::epsilon() * coordinate};
}

Eigen::AlignedBox3d box_of(const PairPoints& x) {
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& p : x) box.extend(p);
  return box;
}

} // namespace

bool pair_touches_to_rounding(PairKind kind, const PairPoints& x) {
  const Allowance allowance = rounding_allowance(box_of(x), 0);
  // Ten times the allowance: a motion widens it (its reach), and a pair this close would cut every
  // step to a sliver of itself long before that.
  const double limit = 10 * (std::sqrt(allowance.squared) + allowance.absolute);
  return !(pair_squared_distance(kind, x) > limit * limit);
}

double pair_step_bound(PairKind kind, const PairPoints& x, const PairPoints& dx, double t_max,
                       const PairCcdOptions& options) {
  if (!(t_max > 0)) return 0;
  // Speed bound l of the distance (per unit t): the pair's displacements less their mean.
  const Eigen::Vector3d mean = (dx[0] + dx[1] + dx[2] + dx[3]) / 4;
  double speed[4];
  for (int k = 0; k < 4; ++k) speed[k] = (dx[k] - mean).norm();
  const double l = kind == PairKind::PointTriangle
                       ? speed[0] + std::max({speed[1], speed[2], speed[3]})
                       : std::max(speed[0], speed[1]) + std::max(speed[2], speed[3]);
  if (l == 0) return t_max; // a rigid translation keeps every distance

  // Measured distances are lowered by their rounding allowance over the whole motion.
  double move = 0;
  for (int k = 0; k < 4; ++k) move = std::max(move, dx[k].lpNorm<Eigen::Infinity>());
  const Allowance allowance = rounding_allowance(box_of(x), t_max * move);
  auto lowered = [&](double squared) {
    return std::sqrt(std::max(squared - allowance.squared, 0.0)) - allowance.absolute;
  };

  const double d0_squared = pair_squared_distance(kind, x);
  const double floor = options.keep_fraction * std::min(std::sqrt(d0_squared), options.max_floor_distance);
  double d = lowered(d0_squared);
  if (!(d > floor)) return 0; // touching (or within rounding of it), or not finite
  const double stop = 1e-4 * (d - floor);
  double t = 0;
  PairPoints xt;
  for (int it = 0; it < options.max_iterations; ++it) {
    const double tau = (d - floor) / l; // d(s) >= d - l (s - t) >= floor on [t, t + tau]
    if (!(tau > 0)) return t;
    if (t + tau >= t_max) return t_max;
    t += tau;
    for (int k = 0; k < 4; ++k) xt[k] = x[k] + t * dx[k];
    d = lowered(pair_squared_distance(kind, xt));
    if (!(d - floor > stop)) return t;
  }
  return t;
}

} // namespace gshell
