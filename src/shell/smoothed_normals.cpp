#include <gshell/shell/smoothed_normals.h>

#include "geometry/vertex_stars.h"
#include "quality/check_mesh_input.h"

#include <gshell/error.h>
#include <gshell/shell/offset_shell.h>

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <array>
#include <cmath>
#include <vector>

namespace gshell {

namespace {

using Rows3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

constexpr double kRelativeResidual = 1e-2;
constexpr int kMaxIterations = 200;
// Below this length the average of the unit normals around a vertex has (nearly) cancelled.
constexpr double kCancelled = 0.1;

// t (2/3) area / length^2 of an edge of a face: the cotangent weight on an equilateral mesh,
// positive on any (a zero-length edge only on a zero-area face, which weighs nothing).
double edge_weight(double t, double area, double squared_length) {
  return squared_length > 0 ? t * (2.0 / 3.0) * area / squared_length : 0.0;
}

Eigen::VectorXd face_areas(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  Eigen::VectorXd area(F.rows());
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, F.rows(), 1 << 14), [&](const auto& r) {
    for (Eigen::Index f = r.begin(); f < r.end(); ++f) {
      const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
      area[f] = 0.5 * (b - a).cross(c - a).norm();
    }
  });
  return area;
}

// M + t L applied matrix-free over the vertex stars. The edge weights are computed once per
// corner from a row-major copy of the positions and each face's area (one value per face, so the
// operator is exactly symmetric) and stored in star order: an application then reads only its
// argument at the neighbours, the one access it cannot make in order.
class DiffusionStep {
public:
  DiffusionStep(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXd& area, double t)
      : stars_(detail::RowMajorFaces(F), static_cast<int>(V.rows())), first_(V.rows() + 1, 0), mass_(V.rows()),
        diagonal_(V.rows()) {
    const int n = static_cast<int>(V.rows());
    for (int i = 0; i < n; ++i) first_[i + 1] = first_[i] + stars_.degree(i);
    detail::assign_populated(weights_, static_cast<std::size_t>(first_[n]));
    Rows3 P(n, 3);
    for_each_vertex([&](int i) { P.row(i) = V.row(i); });
    auto weight = [&](int f, int i, int j) { return edge_weight(t, area[f], (P.row(i) - P.row(j)).squaredNorm()); };
    for_each_vertex([&](int i) {
      double m = 0, w = 0;
      for (int k = 0; k < stars_.degree(i); ++k) { // usable faces only
        const auto& c = stars_.corner(i, k);
        auto& wk = weights_[first_[i] + k];
        wk = {weight(c.face, i, c.next), weight(c.face, i, c.prev)};
        m += area[c.face] / 3;
        w += wk[0] + wk[1];
      }
      mass_[i] = m;
      diagonal_[i] = m + w;
    });
  }

  int size() const { return static_cast<int>(mass_.size()); }
  double mass(int i) const { return mass_[i]; }
  double diagonal(int i) const { return diagonal_[i]; }

  /// y = M x + t L x; with_mass false: y = t L x only.
  void apply(const Rows3& x, Rows3& y, bool with_mass = true) const {
    for_each_vertex([&](int i) {
      Eigen::RowVector3d s = with_mass ? Eigen::RowVector3d(mass_[i] * x.row(i)) : Eigen::RowVector3d::Zero();
      for (int k = 0; k < stars_.degree(i); ++k) {
        const auto& c = stars_.corner(i, k);
        const auto& wk = weights_[first_[i] + k];
        s += wk[0] * (x.row(i) - x.row(c.next)) + wk[1] * (x.row(i) - x.row(c.prev));
      }
      y.row(i) = s;
    });
  }

  template <class Body> void for_each_vertex(Body&& body) const {
    tbb::parallel_for(tbb::blocked_range<int>(0, size(), 1 << 12), [&](const auto& r) {
      for (int i = r.begin(); i < r.end(); ++i) body(i);
    });
  }

private:
  detail::VertexStars stars_;
  std::vector<std::size_t> first_;                // first corner of each vertex in weights_
  std::vector<std::array<double, 2>> weights_;    // per corner: t w(i, next), t w(i, prev)
  Eigen::VectorXd mass_, diagonal_;
};

// Whether x = N0 already meets the stopping test, ||t L N0|| <= tolerance ||M N0|| (smooth normals at
// this radius: a sphere, a cylinder, a fine mesh of a smooth surface), found by one serial pass over
// the faces, without the vertex stars and stored weights the iteration needs (at 2.6M vertices
// those take longer to build than this whole test).
bool already_smooth(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXd& area,
                    const Eigen::MatrixXd& N0, double t) {
  Rows3 LN = Rows3::Zero(V.rows(), 3);
  Eigen::VectorXd mass = Eigen::VectorXd::Zero(V.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const int v[3] = {F(f, 0), F(f, 1), F(f, 2)};
    if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) continue; // not a usable face (as the stars)
    for (int k = 0; k < 3; ++k) {
      const int i = v[k], j = v[(k + 1) % 3];
      mass[i] += area[f] / 3;
      const Eigen::RowVector3d d = edge_weight(t, area[f], (V.row(i) - V.row(j)).squaredNorm()) * (N0.row(i) - N0.row(j));
      LN.row(i) += d;
      LN.row(j) -= d;
    }
  }
  return LN.squaredNorm() <= kRelativeResidual * kRelativeResidual * (mass.asDiagonal() * N0).squaredNorm();
}

} // namespace

Eigen::MatrixXd smoothed_vertex_normals(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double radius,
                                        NormalSmoothing* stats) {
  detail::check_triangle_mesh(V, F, "smoothed_vertex_normals");
  if (!(radius >= 0) || !std::isfinite(radius))
    throw InputError("smoothed_vertex_normals: radius must be >= 0 and finite");
  NormalSmoothing local;
  NormalSmoothing& s = stats ? *stats : local;
  s = {};
  const Eigen::MatrixXd N0 = vertex_normals(V, F);
  if (radius == 0 || V.rows() == 0) return N0;
  const double t = radius * radius;
  const Eigen::VectorXd area = face_areas(V, F);
  if (already_smooth(V, F, area, N0, t)) return N0;

  const DiffusionStep K(V, F, area, t);
  const int n = K.size();
  // Jacobi-preconditioned CG from x = N0 on (M + t L) x = M N0: the first residual is -t L N0.
  // z = r / diagonal is formed where it is used. Isolated vertices (no usable face: zero
  // diagonal) stay out of the iteration.
  auto inverse_diagonal = [&](int i) { return K.diagonal(i) > 0 ? 1 / K.diagonal(i) : 0.0; };
  Rows3 x = N0, r(n, 3), p(n, 3), q(n, 3);
  K.apply(x, r, false);
  r = -r;
  double b2 = 0;
  for (int i = 0; i < n; ++i) b2 += K.mass(i) * K.mass(i) * N0.row(i).squaredNorm();
  K.for_each_vertex([&](int i) { p.row(i) = inverse_diagonal(i) * r.row(i); });
  double rz = r.cwiseProduct(p).sum();
  const double stop = kRelativeResidual * kRelativeResidual * b2;
  while (s.iterations < kMaxIterations && r.squaredNorm() > stop) {
    K.apply(p, q);
    const double pq = p.cwiseProduct(q).sum();
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
    x += alpha * p;
    r -= alpha * q;
    double rz_new = 0;
    for (int i = 0; i < n; ++i) rz_new += inverse_diagonal(i) * r.row(i).squaredNorm();
    const double beta = rz_new / rz;
    K.for_each_vertex([&](int i) { p.row(i) = inverse_diagonal(i) * r.row(i) + beta * p.row(i); });
    rz = rz_new;
    ++s.iterations;
  }
  Eigen::MatrixXd N = N0;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const double len = x.row(i).norm();
    if (len > kCancelled && std::isfinite(len)) N.row(i) = x.row(i) / len;
  }
  return N;
}

} // namespace gshell
