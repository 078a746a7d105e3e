#include <gshell/guard/primitive_distance.h>

#include <Eigen/Dense>

#include <algorithm>
#include <limits>

namespace gshell {
namespace {

// sin^2 of the angle below which a triangle counts as flat and two segments as parallel. The
// closed forms of the interior cases divide by |n|^2 = sin^2 * (product of squared lengths), so
// their rounding error in d^2 grows like eps^2 L^2 / sin^2; measuring by the edges or ends
// instead overestimates d^2 by at most sin^2 L^2. 1e-15 keeps both near 1e-15 L^2.
constexpr double kFlatSin2 = 1e-15;

using Vec3 = Eigen::Vector3d;

// The closest features as found by the distance core: point x[i] against segment x[j] x[k] at
// parameter beta (0 or 1: against that end), or an interior case with two parameters.
struct Closest {
  double squared = std::numeric_limits<double>::infinity();
  bool interior = false;
  int i = 0, j = 0, k = 0;
  double beta0 = 0, beta1 = 0;
};

// Point x[i] against the closed segment x[j] x[k]; keeps the nearer of this and `best`.
void point_segment(const PairPoints& x, int i, int j, int k, Closest& best) {
  const Vec3 e = x[k] - x[j], w = x[i] - x[j];
  const double len2 = e.squaredNorm();
  double beta = len2 > 0 ? w.dot(e) / len2 : 0;
  double d2;
  if (beta <= 0) {
    beta = 0;
    d2 = w.squaredNorm();
  } else if (beta >= 1) {
    beta = 1;
    d2 = (x[i] - x[k]).squaredNorm();
  } else {
    d2 = (w - beta * e).squaredNorm();
  }
  if (d2 < best.squared) best = {d2, false, i, j, k, beta, 0};
}

// The minimiser (u, v) of |w + u g0 + v g1|^2 over the whole plane. False when g0 and g1 are
// parallel to kFlatSin2 (sin^2 of their angle), where the formula loses its accuracy.
bool plane_minimiser(const Vec3& w, const Vec3& g0, const Vec3& g1, double& u, double& v) {
  const double a00 = g0.squaredNorm(), a11 = g1.squaredNorm(), a01 = g0.dot(g1);
  const double det = g0.cross(g1).squaredNorm(); // a00 a11 - a01^2 without cancellation
  if (!(det > kFlatSin2 * a00 * a11)) return false;
  const double b0 = g0.dot(w), b1 = g1.dot(w);
  u = (a01 * b1 - a11 * b0) / det;
  v = (a01 * b0 - a00 * b1) / det;
  return true;
}

// Convex quadratic over a triangle or a square: when its unconstrained minimiser lies outside,
// the constrained one lies on a side whose constraint the minimiser violates (the segment from
// any inner point to the minimiser, along which the quadratic falls, leaves through such a side).
Closest point_triangle_core(const PairPoints& x) {
  // x0 - (x1 + u (x2 - x1) + v (x3 - x1)) = w + u g0 + v g1
  const Vec3 g0 = x[1] - x[2], g1 = x[1] - x[3], w = x[0] - x[1];
  Closest c;
  double u, v;
  if (!plane_minimiser(w, g0, g1, u, v)) { // flat: its edges
    point_segment(x, 0, 1, 2, c);
    point_segment(x, 0, 2, 3, c);
    point_segment(x, 0, 3, 1, c);
    return c;
  }
  const double rest = 1 - u - v; // barycentric coordinate of x1
  if (rest >= 0 && u >= 0 && v >= 0) return {(w + u * g0 + v * g1).squaredNorm(), true, 0, 0, 0, u, v};
  if (v < 0) point_segment(x, 0, 1, 2, c); // side x1 x2 (barycentric of x3 = 0)
  if (rest < 0) point_segment(x, 0, 2, 3, c);
  if (u < 0) point_segment(x, 0, 3, 1, c);
  return c;
}

Closest edge_edge_core(const PairPoints& x) {
  // (1 - s) x0 + s x1 - (1 - t) x2 - t x3 = w + s g0 + t g1
  const Vec3 g0 = x[1] - x[0], g1 = x[2] - x[3], w = x[0] - x[2];
  Closest c;
  double s, t;
  if (!plane_minimiser(w, g0, g1, s, t)) { // parallel: every end against the other segment
    point_segment(x, 0, 2, 3, c);
    point_segment(x, 1, 2, 3, c);
    point_segment(x, 2, 0, 1, c);
    point_segment(x, 3, 0, 1, c);
    return c;
  }
  if (s >= 0 && s <= 1 && t >= 0 && t <= 1) return {(w + s * g0 + t * g1).squaredNorm(), true, 0, 0, 0, s, t};
  if (s < 0) point_segment(x, 0, 2, 3, c); // side s = 0: x0 against the second segment
  if (s > 1) point_segment(x, 1, 2, 3, c);
  if (t < 0) point_segment(x, 2, 0, 1, c);
  if (t > 1) point_segment(x, 3, 0, 1, c);
  return c;
}

// Non-finite input (no side compared) must not read as "infinitely far".
Closest checked(Closest c) {
  if (!(c.squared < std::numeric_limits<double>::infinity())) c.squared = std::numeric_limits<double>::quiet_NaN();
  return c;
}

PairDistance stencil(PairKind kind, const Closest& c) {
  PairDistance d;
  d.squared = c.squared;
  if (c.interior) {
    d.parameters = 2;
    const double u = c.beta0, v = c.beta1;
    if (kind == PairKind::PointTriangle) { // r = x0 - (1 - u - v) x1 - u x2 - v x3
      d.features = ClosestFeatures::PointFace;
      d.a = {1, -(1 - u - v), -u, -v};
      d.da[0] = {0, 1, -1, 0};
      d.da[1] = {0, 1, 0, -1};
    } else { // r = (1 - s) x0 + s x1 - (1 - t) x2 - t x3
      d.features = ClosestFeatures::EdgeEdge;
      d.a = {1 - u, u, -(1 - v), -v};
      d.da[0] = {-1, 1, 0, 0};
      d.da[1] = {0, 0, 1, -1};
    }
    return d;
  }
  d.a[c.i] = 1;
  if (c.beta0 == 0 || c.beta0 == 1) { // r = x_i - x_end
    d.features = ClosestFeatures::PointPoint;
    d.a[c.beta0 == 0 ? c.j : c.k] = -1;
    return d;
  }
  d.features = ClosestFeatures::PointEdge; // r = x_i - (1 - beta) x_j - beta x_k
  d.parameters = 1;
  d.a[c.j] = -(1 - c.beta0);
  d.a[c.k] = -c.beta0;
  d.da[0][c.j] = 1;
  d.da[0][c.k] = -1;
  return d;
}

} // namespace

PairDistance point_triangle_distance(const PairPoints& x) {
  return stencil(PairKind::PointTriangle, checked(point_triangle_core(x)));
}

PairDistance edge_edge_distance(const PairPoints& x) { return stencil(PairKind::EdgeEdge, checked(edge_edge_core(x))); }

PairDistance pair_distance(PairKind kind, const PairPoints& x) {
  return kind == PairKind::PointTriangle ? point_triangle_distance(x) : edge_edge_distance(x);
}

double pair_squared_distance(PairKind kind, const PairPoints& x) {
  return checked(kind == PairKind::PointTriangle ? point_triangle_core(x) : edge_edge_core(x)).squared;
}

Vector12d squared_distance_gradient(const PairPoints& x, const PairDistance& d) {
  Vec3 r = Vec3::Zero();
  for (int k = 0; k < 4; ++k) r += d.a[k] * x[k];
  Vector12d g;
  for (int k = 0; k < 4; ++k) g.segment<3>(3 * k) = 2 * d.a[k] * r;
  return g;
}

Matrix12d squared_distance_hessian(const PairPoints& x, const PairDistance& d) {
  // f(x, beta) = |r|^2, r = sum_k a_k(beta) x_k: f_xx = 2 (a a^T) (x) I3.
  Matrix12d h = Matrix12d::Zero();
  for (int k = 0; k < 4; ++k)
    for (int l = 0; l < 4; ++l) h.block<3, 3>(3 * k, 3 * l).diagonal().setConstant(2 * d.a[k] * d.a[l]);
  const int m = d.parameters;
  if (m == 0) return h;
  Vec3 r = Vec3::Zero();
  Eigen::Matrix<double, 3, 2> g = Eigen::Matrix<double, 3, 2>::Zero(); // g_j = dr / dbeta_j
  for (int k = 0; k < 4; ++k) {
    r += d.a[k] * x[k];
    for (int j = 0; j < m; ++j) g.col(j) += d.da[j][k] * x[k];
  }
  // f_xb: block (k, j) = 2 (a_k g_j + da_jk r); f_bb = 2 G^T G.
  Eigen::Matrix<double, 12, 2> c = Eigen::Matrix<double, 12, 2>::Zero();
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < m; ++j) c.block<3, 1>(3 * k, j) = 2 * (d.a[k] * g.col(j) + d.da[j][k] * r);
  if (m == 1) {
    const double fbb = 2 * g.col(0).squaredNorm();
    if (fbb > 0) h.noalias() -= c.col(0) * c.col(0).transpose() / fbb;
    return h;
  }
  // The 2x2 inverse by its adjugate; det(G^T G) = |g_0 x g_1|^2, accurate for thin shapes.
  const double g00 = g.col(0).squaredNorm(), g11 = g.col(1).squaredNorm(), g01 = g.col(0).dot(g.col(1));
  const double det = 2 * g.col(0).cross(g.col(1)).squaredNorm(); // det(f_bb) / 2
  if (!(det > 0)) return h;
  Eigen::Matrix2d inv;
  inv << g11, -g01, -g01, g00;
  inv /= det;
  h.noalias() -= c * inv * c.transpose();
  return h;
}

} // namespace gshell
