#include <gshell/geometry/closest_point.h>

#include <Eigen/Geometry>

#include <algorithm>

namespace gshell {

namespace {

// The nearest of the closest points on the three edges.
Eigen::Vector3d closest_point_on_edges(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c) {
  const Eigen::Vector3d q[3] = {closest_point_on_segment(p, a, b), closest_point_on_segment(p, b, c),
                                closest_point_on_segment(p, c, a)};
  int best = 0;
  for (int i = 1; i < 3; ++i)
    if ((q[i] - p).squaredNorm() < (q[best] - p).squaredNorm()) best = i;
  return q[best];
}

} // namespace

Eigen::Vector3d closest_point_on_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                         const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return a + t * ab;
}

bool triangle_is_flat(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a;
  return ab.cross(ac).squaredNorm() <= 1e-24 * ab.squaredNorm() * ac.squaredNorm();
}

Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  return closest_point_on_triangle(p, a, b, c, triangle_is_flat(a, b, c));
}

// Ericson, Real-Time Collision Detection 5.1.5: region tests on the barycentric parameters.
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c, bool flat) {
  if (flat) return closest_point_on_edges(p, a, b, c);
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = va + vb + vc;
  if (!(denom > 0)) return closest_point_on_edges(p, a, b, c); // rounding on a near-flat face
  return a + (vb / denom) * ab + (vc / denom) * ac;
}

} // namespace gshell
