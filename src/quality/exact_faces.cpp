#include "quality/exact_faces.h"

#include "quality/filtered_orientation.h"

#include <CGAL/Intersections_3/Point_3_Point_3.h>
#include <CGAL/Intersections_3/Point_3_Segment_3.h>
#include <CGAL/Intersections_3/Point_3_Triangle_3.h>
#include <CGAL/Intersections_3/Segment_3_Segment_3.h>
#include <CGAL/Intersections_3/Segment_3_Triangle_3.h>
#include <CGAL/Intersections_3/Triangle_3_Triangle_3.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace gshell::detail {
namespace {

using Point = ExactPoint;
using Segment = ExactKernel::Segment_3;
using Triangle = ExactKernel::Triangle_3;

// The convex hull of up to three points as the simplest CGAL object covering it: CGAL's
// triangle and segment tests require non-degenerate arguments.
struct Hull {
  int dim = 0; // 2 triangle q[0..2], 1 segment q[0..1], 0 point q[0]
  std::array<Point, 3> q;
};

Hull hull(const Point& a) { return {0, {a, a, a}}; }

Hull hull(const Point& a, const Point& b) { return a == b ? hull(a) : Hull{1, {a, b, b}}; }

// Along a line the lexicographic order is the order on the line, so its extremes span the hull.
std::array<std::uint8_t, 2> collinear_ends(const std::array<Point, 3>& p) {
  std::uint8_t lo = 0, hi = 0;
  for (std::uint8_t k = 1; k < 3; ++k) {
    if (CGAL::compare_xyz(p[k], p[lo]) == CGAL::SMALLER) lo = k;
    if (CGAL::compare_xyz(p[k], p[hi]) == CGAL::LARGER) hi = k;
  }
  return {lo, hi};
}

Hull hull(const Point& a, const Point& b, const Point& c) {
  if (!CGAL::collinear(a, b, c)) return {2, {a, b, c}};
  const std::array<Point, 3> p{a, b, c};
  const auto [lo, hi] = collinear_ends(p);
  return hull(p[lo], p[hi]);
}

Hull hull(const ExactFace& f) {
  if (f.dim == 2) return {2, f.p};
  return f.dim == 1 ? Hull{1, {f.p[f.end[0]], f.p[f.end[1]], f.p[f.end[1]]}} : hull(f.p[f.end[0]]);
}

bool meet(const Hull& a, const Hull& b) {
  if (a.dim < b.dim) return meet(b, a);
  switch (a.dim * 3 + b.dim) {
  case 8: return CGAL::do_intersect(Triangle(a.q[0], a.q[1], a.q[2]), Triangle(b.q[0], b.q[1], b.q[2]));
  case 7: return CGAL::do_intersect(Triangle(a.q[0], a.q[1], a.q[2]), Segment(b.q[0], b.q[1]));
  case 6: return CGAL::do_intersect(Triangle(a.q[0], a.q[1], a.q[2]), b.q[0]);
  case 4: return CGAL::do_intersect(Segment(a.q[0], a.q[1]), Segment(b.q[0], b.q[1]));
  case 3: return CGAL::do_intersect(Segment(a.q[0], a.q[1]), b.q[0]);
  default: return a.q[0] == b.q[0];
  }
}

// Whether ([p, s] meets K) anywhere but at p, for K = conv(p, k1, k2) and s != p. Along the ray
// from p through s, K is an interval [p, y]; if y comes before s it is a point of K with no
// weight on p, i.e. on [k1, k2]. So: s is in K, or [p, s] meets [k1, k2] off p.
bool ray_meets_beyond(const Point& p, const Point& s, const Hull& K, const Point& k1, const Point& k2) {
  if (meet(K, hull(s))) return true;
  const Hull far_side = hull(k1, k2);
  if (!meet(far_side, hull(p))) return meet(hull(p, s), far_side);
  // p lies on [k1, k2], which is then [p, k1] and [p, k2]: segments from p overlap beyond p
  // when one runs along the other in the same direction.
  for (const Point* k : {&k1, &k2})
    if (*k != p && CGAL::collinear(p, s, *k) && !CGAL::collinear_are_ordered_along_line(s, p, *k)) return true;
  return false;
}

// Whether [s1, s2] meets K = conv(p, k1, k2) anywhere but at p.
bool segment_meets_beyond(const Point& p, const Point& s1, const Point& s2, const Hull& K, const Point& k1,
                          const Point& k2) {
  const Hull s = hull(s1, s2);
  if (!meet(s, hull(p))) return meet(s, K);
  // p on [s1, s2]: split it at p into [p, s1] and [p, s2].
  return (s1 != p && ray_meets_beyond(p, s1, K, k1, k2)) || (s2 != p && ray_meets_beyond(p, s2, K, k1, k2));
}

// A = conv(p, a1, a2) and B = conv(p, b1, b2) share the vertex p: do they meet elsewhere?
// If x != p is in both, follow the ray from p through x while it stays in both: where it leaves
// the first of them it is on that one's edge opposite p (no weight on p, or it could go on), and
// still in the other. So they meet off p iff [a1, a2] meets B off p or [b1, b2] meets A off p.
bool meet_beyond_vertex(const Point& p, const Point& a1, const Point& a2, const Point& b1, const Point& b2) {
  const Hull A = hull(p, a1, a2), B = hull(p, b1, b2);
  if (A.dim == 2 && B.dim == 2) {
    // B minus p lies strictly on one side of A's plane when b1 and b2 do (and vice versa): on a
    // surface curved one way, most neighbours around a vertex are settled by these four signs.
    const CGAL::Orientation o1 = CGAL::orientation(p, a1, a2, b1), o2 = CGAL::orientation(p, a1, a2, b2);
    if (o1 == o2 && o1 != CGAL::COPLANAR) return false;
    const CGAL::Orientation o3 = CGAL::orientation(p, b1, b2, a1), o4 = CGAL::orientation(p, b1, b2, a2);
    if (o3 == o4 && o3 != CGAL::COPLANAR) return false;
    // Non-degenerate: p is on neither opposite edge.
    return CGAL::do_intersect(Segment(a1, a2), Triangle(p, b1, b2)) ||
           CGAL::do_intersect(Segment(b1, b2), Triangle(p, a1, a2));
  }
  return segment_meets_beyond(p, a1, a2, B, b1, b2) || segment_meets_beyond(p, b1, b2, A, a1, a2);
}

// A = conv(p, q, a) and B = conv(p, q, b) share the edge pq: do they meet off the segment pq?
bool meet_beyond_edge(const Point& p, const Point& q, const Point& a, const Point& b) {
  if (p == q) return meet_beyond_vertex(p, q, a, q, b); // the shared "edge" is the point p
  const bool a_flat = CGAL::collinear(p, q, a), b_flat = CGAL::collinear(p, q, b);
  if (!a_flat && !b_flat) {
    // In different planes they meet on the line pq only, where both are the segment pq. In one
    // plane they overlap iff a and b are on the same side of pq.
    return CGAL::orientation(p, q, a, b) == CGAL::COPLANAR && CGAL::coplanar_orientation(p, q, a, b) == CGAL::POSITIVE;
  }
  // A flat face lies on the line pq, which meets a non-flat face in the segment pq only.
  if (a_flat != b_flat) return false;
  // Both on the line pq: they overlap off pq iff both reach beyond p, or both beyond q.
  auto beyond = [](const Point& x, const Point& end, const Point& other) {
    return CGAL::collinear_are_strictly_ordered_along_line(x, end, other);
  };
  return (beyond(a, p, q) && beyond(b, p, q)) || (beyond(a, q, p) && beyond(b, q, p));
}

double dot(const double n[3], const Point& p) { return n[0] * p.x() + n[1] * p.y() + n[2] * p.z(); }

// Whether every corner of `f` lies beyond slab s (all above hi + margin or all below lo - margin).
bool beyond_slab(const FaceSlab& s, const ExactFace& f, double margin) {
  const double d0 = dot(s.n, f.p[0]), d1 = dot(s.n, f.p[1]), d2 = dot(s.n, f.p[2]);
  const double up = s.hi + margin, down = s.lo - margin;
  return (d0 > up && d1 > up && d2 > up) || (d0 < down && d1 < down && d2 < down);
}

} // namespace

FaceSlab face_slab(const ExactFace& f) {
  FaceSlab s;
  const Point &a = f.p[0], &b = f.p[1], &c = f.p[2];
  const double u[3] = {b.x() - a.x(), b.y() - a.y(), b.z() - a.z()};
  const double v[3] = {c.x() - a.x(), c.y() - a.y(), c.z() - a.z()};
  double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  const double big = std::max({std::abs(n[0]), std::abs(n[1]), std::abs(n[2])});
  if (!(big > 0) || !std::isfinite(big)) return s; // n = 0: the slab separates nothing
  for (int d = 0; d < 3; ++d) s.n[d] = n[d] / big;
  const double d0 = dot(s.n, a), d1 = dot(s.n, b), d2 = dot(s.n, c);
  s.lo = std::min({d0, d1, d2});
  s.hi = std::max({d0, d1, d2});
  return s;
}

double slab_margin(double max_abs) {
  // With |n_i| <= 1 and |p_i| <= M a rounded n.p is within gamma_3 * 3M < 1.0e-15 M of n.p
  // (Higham, "Accuracy and Stability of Numerical Algorithms", 3.1); a comparison of one such
  // product with a slab end adds two of these errors and the rounding of hi + margin. 1e-14 M
  // covers them with room; the absolute floor covers products that round to denormals.
  if (!(max_abs < 1e150)) return std::numeric_limits<double>::infinity();
  return 1e-14 * max_abs + 1e-290;
}

bool slabs_separate(const ExactFace& a, const FaceSlab& sa, const ExactFace& b, const FaceSlab& sb, double margin) {
  return beyond_slab(sa, b, margin) || beyond_slab(sb, a, margin);
}

namespace {

// CGAL::collinear(a, b, c), sooner: three points are collinear iff their projections onto the
// three coordinate planes all are, and the first filtered 2D orientation of a proper triangle
// (every face of every frame goes through here) is almost always decided in doubles.
bool collinear(const Point& a, const Point& b, const Point& c) {
  for (int d = 0; d < 3; ++d) {
    const int e = (d + 1) % 3;
    if (orientation_sign(a[d], a[e], b[d], b[e], c[d], c[e]) != 0) return false;
  }
  return true;
}

} // namespace

ExactFace exact_face(const std::array<int, 3>& id, const std::array<Point, 3>& p) {
  ExactFace face;
  face.id = id;
  face.p = p;
  if (collinear(face.p[0], face.p[1], face.p[2])) {
    face.end = collinear_ends(face.p);
    face.dim = face.p[face.end[0]] == face.p[face.end[1]] ? 0 : 1;
  }
  return face;
}

ExactFace exact_face(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, int f) {
  std::array<int, 3> id;
  std::array<Point, 3> p;
  for (int k = 0; k < 3; ++k) {
    id[k] = F(f, k);
    p[k] = Point(V(F(f, k), 0), V(F(f, k), 1), V(F(f, k), 2));
  }
  return exact_face(id, p);
}

bool faces_intersect(const ExactFace& a, const ExactFace& b) { return meet(hull(a), hull(b)); }

bool faces_intersect_beyond_shared(const ExactFace& a, const ExactFace& b, const SharedCorners& shared_corners) {
  const auto& in_a = shared_corners.in_a;
  const auto& in_b = shared_corners.in_b;
  const int shared = shared_corners.count;
  switch (shared) {
  case 0: return faces_intersect(a, b);
  case 1: {
    const int i = in_a[0], j = in_b[0];
    return meet_beyond_vertex(a.p[i], a.p[(i + 1) % 3], a.p[(i + 2) % 3], b.p[(j + 1) % 3], b.p[(j + 2) % 3]);
  }
  case 2:
    return meet_beyond_edge(a.p[in_a[0]], a.p[in_a[1]], a.p[3 - in_a[0] - in_a[1]], b.p[3 - in_b[0] - in_b[1]]);
  default: // the same three corners: the same point set, more than its edges unless flat
    return a.dim == 2;
  }
}

} // namespace gshell::detail
