#pragma once
// Exact orientation signs, fast: the determinant is evaluated in doubles and trusted when it
// exceeds Shewchuk's forward error bound for that very expression ("Adaptive precision
// floating-point arithmetic and fast robust geometric predicates", 1997: (3 + 16 eps) eps in 2D,
// (7 + 56 eps) eps in 3D, times the permanent, eps = 2^-53); only the rare close calls go to
// CGAL's exact predicates. The bounds assume no underflow, hence the floor on the permanent
// (below it, rounding to denormals could exceed the bound). Same signs as CGAL::orientation.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <cmath>

namespace gshell::detail {

/// Sign of the 2D orientation of (a, b, c): +1 when they turn counter-clockwise, 0 collinear.
inline int orientation_sign(double ax, double ay, double bx, double by, double cx, double cy) {
  const double left = (ax - cx) * (by - cy), right = (ay - cy) * (bx - cx);
  const double det = left - right, permanent = std::abs(left) + std::abs(right);
  if (permanent > 1e-280 && std::abs(det) > 3.4e-16 * permanent) return det > 0 ? 1 : -1;
  using Point = CGAL::Exact_predicates_inexact_constructions_kernel::Point_2;
  return static_cast<int>(CGAL::orientation(Point(ax, ay), Point(bx, by), Point(cx, cy)));
}

/// Sign of det[q - p, r - p, s - p] (CGAL::orientation(p, q, r, s)): +1 when s lies on the side
/// of the plane (p, q, r) towards which (q - p) x (r - p) points, 0 coplanar.
inline int orientation_sign(const double* p, const double* q, const double* r, const double* s) {
  const double ux = q[0] - p[0], uy = q[1] - p[1], uz = q[2] - p[2];
  const double vx = r[0] - p[0], vy = r[1] - p[1], vz = r[2] - p[2];
  const double wx = s[0] - p[0], wy = s[1] - p[1], wz = s[2] - p[2];
  const double a = vy * wz, b = vz * wy, c = vz * wx, d = vx * wz, e = vx * wy, f = vy * wx;
  const double det = ux * (a - b) + uy * (c - d) + uz * (e - f);
  const double permanent = std::abs(ux) * (std::abs(a) + std::abs(b)) + std::abs(uy) * (std::abs(c) + std::abs(d)) +
                           std::abs(uz) * (std::abs(e) + std::abs(f));
  if (permanent > 1e-270 && std::abs(det) > 7.8e-16 * permanent) return det > 0 ? 1 : -1;
  using Point = CGAL::Exact_predicates_inexact_constructions_kernel::Point_3;
  return static_cast<int>(CGAL::orientation(Point(p[0], p[1], p[2]), Point(q[0], q[1], q[2]),
                                            Point(r[0], r[1], r[2]), Point(s[0], s[1], s[2])));
}

} // namespace gshell::detail
