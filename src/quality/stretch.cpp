#include <gshell/quality/stretch.h>

#include <gshell/error.h>

#include "solver/polar_3x3.h"
#include "solver/simd_dispatch.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace gshell {

namespace {

Eigen::Matrix3d deformation_gradient(const RestTets& rest, const Eigen::MatrixXd& X, Eigen::Index t) {
  const Eigen::Vector3d x0 = X.row(rest.T(t, 0));
  Eigen::Matrix3d D;
  D << X.row(rest.T(t, 1)).transpose() - x0, X.row(rest.T(t, 2)).transpose() - x0,
      X.row(rest.T(t, 3)).transpose() - x0;
  return D * rest.dm_inv(t);
}

// Stretch of tets [t_begin, t_end), kPolarLanes at a time through the batched polar decomposition.
GSHELL_SIMD_KERNEL void tet_stretch_body(const RestTets& rest, const Eigen::MatrixXd& X, int t_begin, int t_end,
                                         double* s) {
  constexpr int W = detail::kPolarLanes;
  alignas(64) double Fs[9 * W], Rs[9 * W];
  for (int t0 = t_begin; t0 < t_end; t0 += W) {
    const int lanes = std::min(W, t_end - t0);
    for (int l = 0; l < W; ++l) {
      const Eigen::Matrix3d F = l < lanes ? deformation_gradient(rest, X, t0 + l) : Eigen::Matrix3d::Identity();
      for (int k = 0; k < 9; ++k) Fs[k * W + l] = F(k / 3, k % 3);
    }
    detail::closest_rotations_lanes(Fs, Rs);
    for (int l = 0; l < lanes; ++l) {
      double d2 = 0;
      for (int k = 0; k < 9; ++k) d2 += (Fs[k * W + l] - Rs[k * W + l]) * (Fs[k * W + l] - Rs[k * W + l]);
      s[t0 + l] = d2;
    }
  }
}

GSHELL_SIMD_DISPATCH(void, tet_stretch_block, tet_stretch_body,
                     (const RestTets& rest, const Eigen::MatrixXd& X, int t_begin, int t_end, double* s),
                     (rest, X, t_begin, t_end, s))

// The positions are the caller's: every tet must find its four vertices among the rows of X.
void check_positions(const RestTets& rest, const Eigen::MatrixXd& X, const char* what) {
  if (!rest.complete())
    throw InputError(std::string(what) + ": rest tets are incomplete (no Dm_inv in any form, or volumes missing)");
  if (X.cols() != 3)
    throw InputError(std::string(what) + ": positions must be N x 3 (got " + std::to_string(X.cols()) + " columns)");
  if (rest.size() > 0 && (rest.T.minCoeff() < 0 || rest.T.maxCoeff() >= X.rows()))
    throw InputError(std::string(what) + ": a tet refers to a vertex outside the " + std::to_string(X.rows()) +
                     " rows of the positions");
}

} // namespace

Eigen::VectorXd tet_stretch(const RestTets& rest, const Eigen::MatrixXd& X) {
  constexpr int kBlock = 64 * detail::kPolarLanes;
  check_positions(rest, X, "tet_stretch");
  const int K = rest.size();
  Eigen::VectorXd s(K);
  tbb::parallel_for(0, (K + kBlock - 1) / kBlock,
                    [&](int b) { tet_stretch_block(rest, X, b * kBlock, std::min(K, (b + 1) * kBlock), s.data()); });
  return s;
}

Eigen::VectorXd tet_deformation_determinants(const RestTets& rest, const Eigen::MatrixXd& X) {
  check_positions(rest, X, "tet_deformation_determinants");
  Eigen::VectorXd d(rest.size());
  tbb::parallel_for(0, rest.size(), [&](int t) { d[t] = deformation_gradient(rest, X, t).determinant(); });
  return d;
}

StretchStats stretch_stats(const Eigen::VectorXd& s, const Eigen::VectorXd& d, const Eigen::VectorXd& volume) {
  if (d.size() != s.size() || volume.size() != s.size())
    throw InputError("stretch_stats: stretch, determinants and volume need one value per tet (got " +
                     std::to_string(s.size()) + ", " + std::to_string(d.size()) + ", " + std::to_string(volume.size()) +
                     ")");
  StretchStats stats;
  const Eigen::Index K = s.size();
  if (K == 0) return stats;
  stats.mean = s.mean();
  stats.volume_mean = s.dot(volume) / volume.sum();
  stats.max = s.maxCoeff();
  // Nearest-rank 99th percentile: the smallest value that at least 99% of the tets do not exceed.
  std::vector<double> sorted(s.data(), s.data() + K);
  const std::size_t rank = static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(K))) - 1;
  std::nth_element(sorted.begin(), sorted.begin() + rank, sorted.end());
  stats.p99 = sorted[rank];
  stats.inverted = static_cast<int>((d.array() <= 0).count());
  return stats;
}

StretchStats stretch_stats(const RestTets& rest, const Eigen::MatrixXd& X) {
  return stretch_stats(tet_stretch(rest, X), tet_deformation_determinants(rest, X), rest.volume);
}

} // namespace gshell
