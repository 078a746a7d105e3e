#include <gshell/guard/volume_barrier.h>

#include <gshell/error.h>

#include "quality/filtered_orientation.h"

#include <Eigen/Geometry>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <Eigen/LU>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <cmath>
#include <limits>
#include <string>

namespace gshell {

namespace {

// psi(u) = -(u - 1)^2 log u and its first two derivatives, for 0 < u < 1.
double psi(double u) { return -(u - 1) * (u - 1) * std::log(u); }
double psi1(double u) { return -2 * (u - 1) * std::log(u) - (u - 1) * (u - 1) / u; }
double psi2(double u) { return -2 * std::log(u) - 4 * (u - 1) / u + (u - 1) * (u - 1) / (u * u); }

constexpr double kInf = std::numeric_limits<double>::infinity();

} // namespace

VolumeBarrier::VolumeBarrier(const RestTets& rest, double j_hat, std::vector<char> skip)
    : T_(rest.T), inv_det_rest_(rest.size()), weight_(rest.size()), j_hat_(j_hat) {
  set_j_hat(j_hat);
  set_skip(std::move(skip));
  for (int t = 0; t < rest.size(); ++t) {
    inv_det_rest_[t] = rest.dm_inv(t).determinant();
    weight_[t] = rest.volume[t];
  }
}

void VolumeBarrier::set_skip(std::vector<char> skip) {
  const auto tets = static_cast<std::size_t>(T_.rows());
  if (!skip.empty() && skip.size() != tets) throw InputError("VolumeBarrier: expected one skip flag per tet");
  if (skip.empty()) skip.assign(tets, 0);
  skip_ = std::move(skip);
}

void VolumeBarrier::set_j_hat(double j_hat) {
  if (!(j_hat > 0 && j_hat <= 1)) throw InputError("VolumeBarrier: j_hat must be in (0, 1] (got " + std::to_string(j_hat) + ")");
  j_hat_ = j_hat;
}

double VolumeBarrier::relative_volume(const Eigen::MatrixXd& X, int t, Eigen::Vector3d* grad) const {
  const Eigen::Vector3d x0 = X.row(T_(t, 0)).transpose();
  const Eigen::Vector3d e1 = X.row(T_(t, 1)).transpose() - x0, e2 = X.row(T_(t, 2)).transpose() - x0,
                        e3 = X.row(T_(t, 3)).transpose() - x0;
  const Eigen::Vector3d c1 = e2.cross(e3); // d det / d e1
  const double c = inv_det_rest_[t];
  if (grad) {
    const Eigen::Vector3d c2 = e3.cross(e1), c3 = e1.cross(e2);
    grad[1] = c * c1;
    grad[2] = c * c2;
    grad[3] = c * c3;
    grad[0] = -(grad[1] + grad[2] + grad[3]);
  }
  return c * e1.dot(c1);
}

bool VolumeBarrier::positively_oriented(const Eigen::MatrixXd& X, int t) const {
  double p[4][3];
  for (int k = 0; k < 4; ++k)
    for (int c = 0; c < 3; ++c) p[k][c] = X(T_(t, k), c);
  return detail::orientation_sign(p[0], p[1], p[2], p[3]) > 0;
}

double VolumeBarrier::energy(const Eigen::MatrixXd& X, std::vector<int>* active) const {
  const int K = static_cast<int>(T_.rows());
  // Fixed-size chunks summed in order: the value does not depend on the thread schedule.
  constexpr int kChunk = 4096;
  const int chunks = (K + kChunk - 1) / kChunk;
  std::vector<double> part(chunks, 0.0);
  std::vector<std::vector<int>> chunk_active(active ? chunks : 0);
  tbb::parallel_for(0, chunks, [&](int ci) {
    double e = 0;
    for (int t = ci * kChunk; t < std::min(K, (ci + 1) * kChunk); ++t) {
      if (skip_[t]) continue;
      const double u = relative_volume(X, t, nullptr) / j_hat_;
      // Near zero the rounded determinant can be positive for a tet that is flat or inverted: the
      // barrier's domain is the exact sign's (the certificate's), checked where it is active.
      if (!(u > 0) || (u < 1 && !positively_oriented(X, t))) {
        e = kInf;
        break;
      }
      if (u < 1) {
        e += weight_[t] * psi(u);
        if (active) chunk_active[ci].push_back(t);
      }
    }
    part[ci] = e;
  });
  double E = 0;
  for (double e : part) E += e;
  if (active) {
    active->clear();
    for (const auto& c : chunk_active) active->insert(active->end(), c.begin(), c.end());
  }
  return E;
}

void VolumeBarrier::add_gradient(const Eigen::MatrixXd& X, double scale, Eigen::MatrixXd& G,
                                 const std::vector<int>& active) const {
  for (int t : active) {
    Eigen::Vector3d g[4];
    const double u = relative_volume(X, t, g) / j_hat_;
    if (!(u > 0) || u >= 1) continue;
    const double s = scale * weight_[t] * psi1(u) / j_hat_;
    for (int j = 0; j < 4; ++j) G.row(T_(t, j)) += s * g[j].transpose();
  }
}

namespace {

using Matrix9d = Eigen::Matrix<double, 9, 9>;
using Vector9d = Eigen::Matrix<double, 9, 1>;

// a d^2(det E)/dE^2 + b grad(det E) grad(det E)^T, E = [e1 e2 e3] the tet's edge matrix (vec
// index 3 k + i = E(i, k), Eigen's column-major order), projected onto its positive eigenvalues.
// Its eigensystem is known in closed form from the SVD E = U S V^T (the determinant's Hessian as
// in analytic eigensystems of distortion energies): with sgn = det U det V and D = U Q V^T,
//   for each pair i < j (k the third index): Q = (e_i e_j^T -+ e_j e_i^T) / sqrt 2, eigenvalue
//     +-sgn a s_k (two "flip" and "twist" modes per pair);
//   Q = diag(w) for the three eigenvectors w of the 3 x 3 matrix
//     sgn a [0 s3 s2; s3 0 s1; s2 s1 0] + b g g^T,  g = (s2 s3, s1 s3, s1 s2),
//     where the gradient lives (grad det E = sgn U diag(g) V^T).
// Nine closed-form modes instead of a 9 x 9 eigensolver: the latter was a third of a large
// repair's iteration (docs/guarded-generation.md, "Large repairs").
Matrix9d projected_det_barrier_hessian(const Eigen::Matrix3d& E, double a, double b) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d& U = svd.matrixU();
  const Eigen::Matrix3d& V = svd.matrixV();
  const Eigen::Vector3d sv = svd.singularValues();
  const double sgn = U.determinant() * V.determinant() < 0 ? -1.0 : 1.0;
  Matrix9d h = Matrix9d::Zero();
  auto add_mode = [&](double lambda, const Eigen::Matrix3d& D) {
    if (!(lambda > 0)) return;
    const Eigen::Map<const Vector9d> q(D.data());
    h.noalias() += lambda * q * q.transpose();
  };
  const double r = std::sqrt(0.5);
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) {
      const int k = 3 - i - j;
      const Eigen::Matrix3d uv = U.col(i) * V.col(j).transpose(), vu = U.col(j) * V.col(i).transpose();
      add_mode(-sgn * a * sv[k], r * (uv + vu));
      add_mode(sgn * a * sv[k], r * (uv - vu));
    }
  const Eigen::Vector3d g(sv[1] * sv[2], sv[0] * sv[2], sv[0] * sv[1]);
  Eigen::Matrix3d M;
  M << 0, sv[2], sv[1], sv[2], 0, sv[0], sv[1], sv[0], 0;
  M = sgn * a * M + b * g * g.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(M);
  for (int m = 0; m < 3; ++m) {
    const Eigen::Vector3d w = eig.eigenvectors().col(m);
    add_mode(eig.eigenvalues()[m], U * w.asDiagonal() * V.transpose());
  }
  return h;
}

} // namespace

void VolumeBarrier::add_hessian(const Eigen::MatrixXd& X, double scale, std::vector<Eigen::Triplet<double>>& H,
                                const std::vector<int>& active, bool projected,
                                const std::vector<char>* kept_vertices) const {
  // One 12 x 12 block per tet of `active` (its kept part), written at its own place in H: chunks
  // of tets run in parallel and the triplets keep the order of `active` (the assembled matrix does
  // not depend on the schedule). A large repair has hundreds of thousands of active tets.
  if (kept_vertices && kept_vertices->size() != static_cast<std::size_t>(X.rows()))
    throw InputError("VolumeBarrier::add_hessian: expected one flag per vertex in `kept_vertices`");
  auto kept = [&](int vertex) { return !kept_vertices || (*kept_vertices)[vertex]; };
  constexpr int kChunk = 1024;
  const int n = static_cast<int>(active.size());
  const int chunks = (n + kChunk - 1) / kChunk;
  // Where each chunk's triplets start: a tet with f kept corners writes 9 f^2.
  std::vector<std::size_t> start(chunks + 1, H.size());
  for (int ci = 0; ci < chunks; ++ci) {
    std::size_t count = 0;
    for (int k = ci * kChunk; k < std::min(n, (ci + 1) * kChunk); ++k) {
      std::size_t f = 0;
      for (int a = 0; a < 4; ++a) f += kept(T_(active[k], a));
      count += 9 * f * f;
    }
    start[ci + 1] = start[ci] + count;
  }
  H.resize(start[chunks]);
  tbb::parallel_for(0, chunks, [&](int ci) {
    Eigen::Triplet<double>* out = H.data() + start[ci];
    for (int k = ci * kChunk; k < std::min(n, (ci + 1) * kChunk); ++k) {
      const int t = active[k];
      if (!kept(T_(t, 0)) && !kept(T_(t, 1)) && !kept(T_(t, 2)) && !kept(T_(t, 3))) continue; // writes nothing
      Eigen::Vector3d g[4];
      const double u = relative_volume(X, t, g) / j_hat_;
      Eigen::Matrix<double, 12, 12> hx = Eigen::Matrix<double, 12, 12>::Zero();
      const bool inside = u > 0 && u < 1; // always, for the list energy() gave at this X
      const double s = inside ? scale * weight_[t] * psi2(u) / (j_hat_ * j_hat_) : 0.0;
      if (inside && !projected) {
        for (int a = 0; a < 4; ++a)
          for (int b = 0; b < 4; ++b) hx.block<3, 3>(3 * a, 3 * b) = s * g[a] * g[b].transpose();
      } else if (inside) {
        // In the edges e_k = x_k - x_0: J = c det[e1 e2 e3], so the tet's Hessian in them is
        // s1 c d^2det + s grad J grad J^T with grad J = c grad det.
        const Eigen::Vector3d x0 = X.row(T_(t, 0)).transpose();
        Eigen::Matrix3d E;
        for (int e = 0; e < 3; ++e) E.col(e) = X.row(T_(t, e + 1)).transpose() - x0;
        const double c = inv_det_rest_[t];
        const double s1 = scale * weight_[t] * psi1(u) / j_hat_;
        const Matrix9d h = projected_det_barrier_hessian(E, s1 * c, s * c * c);
        // Back to the corners: d e_k / d x_k = I, d e_k / d x_0 = -I.
        for (int a = 0; a < 4; ++a)
          for (int b = 0; b < 4; ++b) {
            Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
            auto edge_block = [&](int k2, int l) { return h.block<3, 3>(3 * k2, 3 * l); };
            if (a > 0 && b > 0) block = edge_block(a - 1, b - 1);
            else if (a > 0) block = -(edge_block(a - 1, 0) + edge_block(a - 1, 1) + edge_block(a - 1, 2));
            else if (b > 0) block = -(edge_block(0, b - 1) + edge_block(1, b - 1) + edge_block(2, b - 1));
            else
              for (int k2 = 0; k2 < 3; ++k2)
                for (int l = 0; l < 3; ++l) block += edge_block(k2, l);
            hx.block<3, 3>(3 * a, 3 * b) = block;
          }
      }
      for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b)
          if (kept(T_(t, a)) && kept(T_(t, b)))
            for (int i = 0; i < 3; ++i)
              for (int j = 0; j < 3; ++j)
                *out++ = Eigen::Triplet<double>(3 * T_(t, a) + i, 3 * T_(t, b) + j, hx(3 * a + i, 3 * b + j));
    }
  });
}

std::vector<int> VolumeBarrier::active_tets(const Eigen::MatrixXd& X) const {
  std::vector<int> active;
  energy(X, &active);
  return active;
}

double VolumeBarrier::min_relative_volume(const Eigen::MatrixXd& X) const {
  double m = kInf;
  for (int t = 0; t < T_.rows(); ++t)
    if (!skip_[t]) m = std::min(m, relative_volume(X, t, nullptr));
  return m;
}

} // namespace gshell
