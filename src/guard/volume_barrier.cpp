#include <gshell/guard/volume_barrier.h>

#include <gshell/error.h>

#include <Eigen/Geometry>
#include <Eigen/Eigenvalues>
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
    : T_(rest.T), inv_det_rest_(rest.size()), weight_(rest.size()), skip_(std::move(skip)), j_hat_(j_hat) {
  if (!(j_hat > 0 && j_hat <= 1)) throw InputError("VolumeBarrier: j_hat must be in (0, 1] (got " + std::to_string(j_hat) + ")");
  if (!skip_.empty() && static_cast<int>(skip_.size()) != rest.size())
    throw InputError("VolumeBarrier: expected one skip flag per tet");
  if (skip_.empty()) skip_.assign(rest.size(), 0);
  for (int t = 0; t < rest.size(); ++t) {
    inv_det_rest_[t] = rest.Dm_inv[t].determinant();
    weight_[t] = rest.volume[t];
  }
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
      if (!(u > 0)) {
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

void VolumeBarrier::add_hessian(const Eigen::MatrixXd& X, double scale, std::vector<Eigen::Triplet<double>>& H,
                                const std::vector<int>& active, bool projected) const {
  using Matrix9d = Eigen::Matrix<double, 9, 9>;
  for (int t : active) {
    Eigen::Vector3d g[4];
    const double u = relative_volume(X, t, g) / j_hat_;
    if (!(u > 0) || u >= 1) continue;
    const double s = scale * weight_[t] * psi2(u) / (j_hat_ * j_hat_);
    if (!projected) {
      for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b)
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
              H.emplace_back(3 * T_(t, a) + i, 3 * T_(t, b) + j, s * g[a][i] * g[b][j]);
      continue;
    }
    // In the edges e_k = x_k - x_0 (k = 1..3): J = c e1 . (e2 x e3), dJ/de_k = g[k], and
    // d^2J/de_k de_l = -c [e_m]x (k, l, m cyclic) and its transpose for (l, k).
    const Eigen::Vector3d x0 = X.row(T_(t, 0)).transpose();
    Eigen::Vector3d e[3];
    for (int k = 0; k < 3; ++k) e[k] = X.row(T_(t, k + 1)).transpose() - x0;
    auto cross_matrix = [](const Eigen::Vector3d& v) {
      Eigen::Matrix3d m;
      m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
      return m;
    };
    const double c = inv_det_rest_[t];
    const double s1 = scale * weight_[t] * psi1(u) / j_hat_;
    Matrix9d h = Matrix9d::Zero();
    for (int k = 0; k < 3; ++k) {
      const int l = (k + 1) % 3, m = (k + 2) % 3;
      const Eigen::Matrix3d block = -s1 * c * cross_matrix(e[m]); // s1 d^2J/de_k de_l
      h.block<3, 3>(3 * k, 3 * l) += block;
      h.block<3, 3>(3 * l, 3 * k) += block.transpose();
    }
    Eigen::Matrix<double, 9, 1> grad;
    for (int k = 0; k < 3; ++k) grad.segment<3>(3 * k) = g[k + 1];
    h += s * grad * grad.transpose();
    const Eigen::SelfAdjointEigenSolver<Matrix9d> eig(h);
    if (eig.eigenvalues().minCoeff() < 0)
      h = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0).asDiagonal() * eig.eigenvectors().transpose();
    // Back to the corners: d e_k / d x_k = I, d e_k / d x_0 = -I.
    Eigen::Matrix<double, 12, 12> hx;
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) {
        Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
        auto edge_block = [&](int k, int l) { return h.block<3, 3>(3 * k, 3 * l); };
        if (a > 0 && b > 0) block = edge_block(a - 1, b - 1);
        else if (a > 0) block = -(edge_block(a - 1, 0) + edge_block(a - 1, 1) + edge_block(a - 1, 2));
        else if (b > 0) block = -(edge_block(0, b - 1) + edge_block(1, b - 1) + edge_block(2, b - 1));
        else
          for (int k = 0; k < 3; ++k)
            for (int l = 0; l < 3; ++l) block += edge_block(k, l);
        hx.block<3, 3>(3 * a, 3 * b) = block;
      }
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) H.emplace_back(3 * T_(t, a) + i, 3 * T_(t, b) + j, hx(3 * a + i, 3 * b + j));
  }
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
