#include <gshell/guard/primitive_distance.h>

#include <Eigen/Dense>

#include <algorithm>

namespace gshell {
namespace {

// sin^2 of the angle below which a triangle counts as flat and two segments as parallel. The
// closed forms of the interior cases divide by |n|^2 = sin^2 * (product of squared lengths), so
// their rounding error in d^2 grows like eps^2 L^2 / sin^2; measuring by the edges or ends
// instead overestimates d^2 by at most sin^2 L^2. 1e-15 keeps both near 1e-15 L^2.
constexpr double kFlatSin2 = 1e-15;

using Vec3 = Eigen::Vector3d;

PairDistance point_point(const PairPoints& x, int i, int j) {
  PairDistance d;
  d.features = ClosestFeatures::PointPoint;
  d.a[i] = 1;
  d.a[j] = -1;
  d.squared = (x[i] - x[j]).squaredNorm();
  return d;
}

// Point x[i] against the closed segment x[j] x[k].
PairDistance point_segment(const PairPoints& x, int i, int j, int k) {
  const Vec3 e = x[k] - x[j];
  const double len2 = e.squaredNorm();
  if (!(len2 > 0)) return point_point(x, i, j);
  const double beta = (x[i] - x[j]).dot(e) / len2;
  if (beta <= 0) return point_point(x, i, j);
  if (beta >= 1) return point_point(x, i, k);
  PairDistance d;
  d.features = ClosestFeatures::PointEdge;
  d.parameters = 1;
  // r = x_i - (1 - beta) x_j - beta x_k
  d.a[i] = 1;
  d.a[j] = -(1 - beta);
  d.a[k] = -beta;
  d.da[0][j] = 1;
  d.da[0][k] = -1;
  d.squared = (x[i] - x[j] - beta * e).squaredNorm();
  return d;
}

const PairDistance& nearer(const PairDistance& a, const PairDistance& b) {
  return b.squared < a.squared ? b : a;
}

} // namespace

PairDistance point_triangle_distance(const PairPoints& x) {
  const Vec3 e1 = x[2] - x[1], e2 = x[3] - x[1], w = x[0] - x[1];
  const double a11 = e1.squaredNorm(), a22 = e2.squaredNorm(), a12 = e1.dot(e2);
  const double det = e1.cross(e2).squaredNorm();
  if (det > kFlatSin2 * a11 * a22) {
    const double b1 = e1.dot(w), b2 = e2.dot(w);
    const double beta1 = (a22 * b1 - a12 * b2) / det, beta2 = (a11 * b2 - a12 * b1) / det;
    if (beta1 >= 0 && beta2 >= 0 && beta1 + beta2 <= 1) {
      PairDistance d;
      d.features = ClosestFeatures::PointFace;
      d.parameters = 2;
      // r = x0 - (1 - beta1 - beta2) x1 - beta1 x2 - beta2 x3
      d.a = {1, -(1 - beta1 - beta2), -beta1, -beta2};
      d.da[0] = {0, 1, -1, 0};
      d.da[1] = {0, 1, 0, -1};
      d.squared = (w - beta1 * e1 - beta2 * e2).squaredNorm();
      return d;
    }
  }
  // The projection falls outside (or the triangle is flat): the closest point is on the boundary.
  return nearer(nearer(point_segment(x, 0, 1, 2), point_segment(x, 0, 2, 3)), point_segment(x, 0, 3, 1));
}

PairDistance edge_edge_distance(const PairPoints& x) {
  const Vec3 e0 = x[1] - x[0], e1 = x[3] - x[2], w = x[0] - x[2];
  const double a = e0.squaredNorm(), b = e0.dot(e1), c = e1.squaredNorm();
  const double det = e0.cross(e1).squaredNorm();
  if (det > kFlatSin2 * a * c) {
    const double d0 = e0.dot(w), d1 = e1.dot(w);
    const double s = (b * d1 - c * d0) / det, t = (a * d1 - b * d0) / det;
    if (s >= 0 && s <= 1 && t >= 0 && t <= 1) {
      PairDistance d;
      d.features = ClosestFeatures::EdgeEdge;
      d.parameters = 2;
      // r = (1 - s) x0 + s x1 - (1 - t) x2 - t x3
      d.a = {1 - s, s, -(1 - t), -t};
      d.da[0] = {-1, 1, 0, 0};
      d.da[1] = {0, 0, 1, -1};
      d.squared = (w + s * e0 - t * e1).squaredNorm();
      return d;
    }
  }
  // The lines' closest points lie outside the segments (or the segments are parallel): the
  // minimum over the parameter square is on its boundary, an end against the other segment.
  return nearer(nearer(point_segment(x, 0, 2, 3), point_segment(x, 1, 2, 3)),
                nearer(point_segment(x, 2, 0, 1), point_segment(x, 3, 0, 1)));
}

PairDistance pair_distance(PairKind kind, const PairPoints& x) {
  return kind == PairKind::PointTriangle ? point_triangle_distance(x) : edge_edge_distance(x);
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
