#include <gshell/guard/contact_barrier.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>

namespace gshell {
namespace {

using Vec3 = Eigen::Vector3d;
using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

double mollifier(double q) {
  if (!(q < kParallelSin2)) return 1; // also for a zero-length edge (q NaN)
  const double t = q / kParallelSin2;
  return t * (2 - t);
}

double parallel_sin2(const PairPoints& x) {
  const Vec3 e0 = x[1] - x[0], e1 = x[3] - x[2];
  return e0.cross(e1).squaredNorm() / (e0.squaredNorm() * e1.squaredNorm());
}

// q = sin^2 of the angle between e0 = x1 - x0 and e1 = x3 - x2, with its gradient and Hessian
// by the 12 coordinates. q = 1 - w, w = u^2 / (A B), u = e0.e1, A = |e0|^2, B = |e1|^2; the
// derivatives go through (u, A, B) by the chain rule, the value through |e0 x e1|^2 / (A B)
// (no cancellation for nearly parallel segments).
struct ParallelMeasure {
  double q = 1;
  Vector12d grad = Vector12d::Zero();
  Matrix12d hess = Matrix12d::Zero();
};

ParallelMeasure parallel_measure(const PairPoints& x, bool want_hessian) {
  ParallelMeasure p;
  const Vec3 e0 = x[1] - x[0], e1 = x[3] - x[2];
  const double A = e0.squaredNorm(), B = e1.squaredNorm(), u = e0.dot(e1);
  p.q = parallel_sin2(x);
  // Gradients of u, A, B by (e0, e1).
  Eigen::Matrix<double, 6, 3> J;
  J << e1, 2 * e0, Vec3::Zero(), e0, Vec3::Zero(), 2 * e1;
  const double AB = A * B;
  const Eigen::Vector3d phi(2 * u / AB, -u * u / (A * AB), -u * u / (AB * B)); // dw/d(u, A, B)
  const Vector6d gw = J * phi;
  // e0 = x1 - x0, e1 = x3 - x2: d/dx0 = -d/de0, d/dx1 = d/de0, d/dx2 = -d/de1, d/dx3 = d/de1.
  Eigen::Matrix<double, 6, 12> L = Eigen::Matrix<double, 6, 12>::Zero();
  for (int d = 0; d < 3; ++d) {
    L(d, d) = -1;
    L(d, 3 + d) = 1;
    L(3 + d, 6 + d) = -1;
    L(3 + d, 9 + d) = 1;
  }
  p.grad = -L.transpose() * gw;
  if (!want_hessian) return p;
  Eigen::Matrix3d Phi; // second derivatives of w by (u, A, B)
  Phi << 2 / AB, -2 * u / (A * AB), -2 * u / (AB * B),
         -2 * u / (A * AB), 2 * u * u / (A * A * AB), u * u / (AB * AB),
         -2 * u / (AB * B), u * u / (AB * AB), 2 * u * u / (AB * B * B);
  Matrix6d hw = J * Phi * J.transpose();
  hw.block<3, 3>(0, 3).diagonal().array() += phi[0]; // d2u = [[0, I], [I, 0]]
  hw.block<3, 3>(3, 0).diagonal().array() += phi[0];
  hw.block<3, 3>(0, 0).diagonal().array() += 2 * phi[1]; // d2A = [[2I, 0], [0, 0]]
  hw.block<3, 3>(3, 3).diagonal().array() += 2 * phi[2]; // d2B = [[0, 0], [0, 2I]]
  p.hess = -L.transpose() * hw * L;
  return p;
}

} // namespace

BarrierValue barrier(double s, double s_hat) {
  if (s >= s_hat) return {};
  if (!(s > 0)) return {std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                        std::numeric_limits<double>::infinity()};
  const double gap = s - s_hat, log_ratio = std::log(s / s_hat);
  return {-gap * gap * log_ratio, -2 * gap * log_ratio - gap * gap / s,
          -2 * log_ratio - 4 * gap / s + gap * gap / (s * s)};
}

double pair_barrier(PairKind kind, const PairPoints& x, double dhat, Vector12d* gradient, Matrix12d* hessian) {
  const double s_hat = dhat * dhat;
  const PairDistance d = pair_distance(kind, x);
  if (d.squared >= s_hat) {
    if (gradient) gradient->setZero();
    if (hessian) hessian->setZero();
    return 0;
  }
  if (!(d.squared > 0)) return std::numeric_limits<double>::infinity();
  const BarrierValue b = barrier(d.squared, s_hat);
  ParallelMeasure par;
  const bool mollified = kind == PairKind::EdgeEdge && [&] {
    par = parallel_measure(x, hessian != nullptr);
    return par.q < kParallelSin2;
  }();
  double m = 1, dm = 0, d2m = 0;
  if (mollified) {
    const double t = par.q / kParallelSin2;
    m = t * (2 - t);
    dm = (2 - 2 * t) / kParallelSin2;
    d2m = -2 / (kParallelSin2 * kParallelSin2);
  }
  if (!gradient && !hessian) return pair_barrier_energy(kind, x, d.squared, dhat);
  const Vector12d gs = squared_distance_gradient(x, d);
  const Vector12d gb = b.db * gs;
  if (gradient) *gradient = m * gb + (mollified ? Vector12d(b.b * dm * par.grad) : Vector12d::Zero());
  if (hessian) {
    Matrix12d h = b.d2b * gs * gs.transpose() + b.db * squared_distance_hessian(x, d);
    if (mollified) {
      const Vector12d gm = dm * par.grad;
      h = m * h + b.b * (d2m * par.grad * par.grad.transpose() + dm * par.hess) + gm * gb.transpose() +
          gb * gm.transpose();
    }
    *hessian = h;
  }
  return m * b.b;
}

Matrix12d pair_barrier_gauss_newton(PairKind kind, const PairPoints& x, double dhat) {
  const double s_hat = dhat * dhat;
  const PairDistance d = pair_distance(kind, x);
  if (!(d.squared < s_hat) || !(d.squared > 0)) return Matrix12d::Zero();
  const BarrierValue b = barrier(d.squared, s_hat);
  // grad s grad s^T = 4 s grad d grad d^T: f''(d) grad d grad d^T = (b'' + b' / (2 s)) grad s grad s^T.
  double coefficient = std::max(b.d2b + b.db / (2 * d.squared), 0.0);
  if (kind == PairKind::EdgeEdge) coefficient *= mollifier(parallel_sin2(x));
  const Vector12d gs = squared_distance_gradient(x, d);
  return coefficient * gs * gs.transpose();
}

double pair_barrier_energy(PairKind kind, const PairPoints& x, double s, double dhat) {
  const double s_hat = dhat * dhat;
  if (s >= s_hat) return 0;
  if (!(s > 0)) return std::numeric_limits<double>::infinity();
  const double b = barrier(s, s_hat).b;
  return kind == PairKind::EdgeEdge ? mollifier(parallel_sin2(x)) * b : b;
}

namespace {

template <class Matrix> void project_square(Matrix& m) {
  Eigen::SelfAdjointEigenSolver<Matrix> eig(m);
  if (eig.eigenvalues().minCoeff() >= 0) return;
  m.noalias() = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0).asDiagonal() * eig.eigenvectors().transpose();
}

} // namespace

void project_to_psd(Matrix12d& h) {
  int used[12], n = 0;
  for (int i = 0; i < 12; ++i)
    if (h.row(i).any()) used[n++] = i;
  if (n == 12) return project_square(h);
  if (n == 0) return;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 12, 12> sub(n, n); // on the stack
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) sub(i, j) = h(used[i], used[j]);
  project_square(sub);
  h.setZero();
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) h(used[i], used[j]) = sub(i, j);
}

} // namespace gshell
