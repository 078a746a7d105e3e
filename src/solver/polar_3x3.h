#pragma once
// Closest rotation of a 3x3 matrix, inline so the solver's local step can use it without a call.
// Fast path: Higham's scaled Newton iteration X <- (g X + X^-T / g) / 2 for the orthogonal polar
// factor, which converges quadratically and is exact to round-off; it is a rotation when det F > 0.
// Inverted, nearly singular or rank-deficient F take a one-sided Jacobi SVD instead (rare in a shell).
#include "solver/simd_dispatch.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace gshell::detail {

inline double frob2(const Eigen::Matrix3d& A) { return A.squaredNorm(); }

/// Cofactor matrix of X (X^-T = C / det X).
inline void cofactor(const Eigen::Matrix3d& X, Eigen::Matrix3d& C) {
  C(0, 0) = X(1, 1) * X(2, 2) - X(1, 2) * X(2, 1);
  C(0, 1) = X(1, 2) * X(2, 0) - X(1, 0) * X(2, 2);
  C(0, 2) = X(1, 0) * X(2, 1) - X(1, 1) * X(2, 0);
  C(1, 0) = X(0, 2) * X(2, 1) - X(0, 1) * X(2, 2);
  C(1, 1) = X(0, 0) * X(2, 2) - X(0, 2) * X(2, 0);
  C(1, 2) = X(0, 1) * X(2, 0) - X(0, 0) * X(2, 1);
  C(2, 0) = X(0, 1) * X(1, 2) - X(0, 2) * X(1, 1);
  C(2, 1) = X(0, 2) * X(1, 0) - X(0, 0) * X(1, 2);
  C(2, 2) = X(0, 0) * X(1, 1) - X(0, 1) * X(1, 0);
}

/// Newton polar iteration; false when F is inverted, too ill-conditioned, or does not converge.
inline bool rotation_by_newton(const Eigen::Matrix3d& F, Eigen::Matrix3d& R) {
  Eigen::Matrix3d X = F, C;
  const double f2 = frob2(F);
  cofactor(X, C);
  double det = X.row(0).dot(C.row(0));
  // det / |F|^3 ~ sigma_2 sigma_3 / sigma_1^2: below ~1e-6 Newton needs many steps; let the SVD do it.
  if (!(det > 1e-6 * f2 * std::sqrt(f2))) return false;
  bool scale = true;
  for (int it = 0; it < 24; ++it) {
    double a = 0.5, b = 0.5 / det;
    if (scale) { // Frobenius-norm scaling g = sqrt(|X^-1| / |X|) speeds up the first steps
      const double g = std::sqrt(std::sqrt(frob2(C) / (frob2(X) * det * det)));
      a *= g;
      b /= g;
    }
    const Eigen::Matrix3d Xn = a * X + b * C;
    const double delta2 = (Xn - X).squaredNorm();
    X = Xn;
    // Quadratic convergence: the error after this step is ~ delta^2 / 2, i.e. round-off.
    if (delta2 < 1e-16) {
      R = X;
      return true;
    }
    scale = delta2 > 1e-6;
    cofactor(X, C);
    det = X.row(0).dot(C.row(0));
    if (!(det > 0)) return false;
  }
  return false;
}

/// Closest rotation through a one-sided Jacobi SVD: columns of B = F V are rotated pairwise until
/// mutually orthogonal; then R maps (v1, v2, v1 x v2) to (u1, u2, u1 x u2), which is
/// U diag(1, 1, det U V^T) V^T for the two largest singular values and handles every rank.
inline Eigen::Matrix3d rotation_by_svd(const Eigen::Matrix3d& F) {
  // R(cF) = R(F) for c > 0: normalise so squared norms neither overflow nor underflow.
  const double largest = F.cwiseAbs().maxCoeff();
  if (!(largest > 0)) return Eigen::Matrix3d::Identity(); // F = 0 (or NaN): every rotation is as close
  Eigen::Matrix3d B = F / largest, V = Eigen::Matrix3d::Identity();
  const double eps = 1e-15;
  for (int sweep = 0; sweep < 40; ++sweep) {
    bool rotated = false;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        const double alpha = B.col(p).squaredNorm(), beta = B.col(q).squaredNorm(), gamma = B.col(p).dot(B.col(q));
        if (gamma == 0 || std::abs(gamma) <= eps * std::sqrt(alpha * beta)) continue;
        rotated = true;
        const double zeta = (beta - alpha) / (2 * gamma);
        const double t = (zeta >= 0 ? 1.0 : -1.0) / (std::abs(zeta) + std::sqrt(1 + zeta * zeta));
        const double c = 1 / std::sqrt(1 + t * t), s = c * t;
        const Eigen::Vector3d bp = B.col(p), bq = B.col(q), vp = V.col(p), vq = V.col(q);
        B.col(p) = c * bp - s * bq;
        B.col(q) = s * bp + c * bq;
        V.col(p) = c * vp - s * vq;
        V.col(q) = s * vp + c * vq;
      }
    if (!rotated) break;
  }
  Eigen::Vector3d sigma(B.col(0).norm(), B.col(1).norm(), B.col(2).norm());
  int order[3] = {0, 1, 2};
  std::sort(order, order + 3, [&](int i, int j) { return sigma[i] > sigma[j]; });
  const int i1 = order[0], i2 = order[1];
  const Eigen::Vector3d v1 = V.col(i1), v2 = V.col(i2);
  const Eigen::Vector3d u1 = B.col(i1) / sigma[i1];
  Eigen::Vector3d u2 = sigma[i2] > 0 ? Eigen::Vector3d(B.col(i2) / sigma[i2]) : v2; // rank 1: any u2 ⟂ u1 is optimal
  u2 -= u2.dot(u1) * u1;
  if (u2.norm() < 1e-8) { // the fallback v2 was parallel to u1: take any perpendicular axis
    Eigen::Index k;
    u1.cwiseAbs().minCoeff(&k);
    u2 = u1.cross(Eigen::Vector3d::Unit(k));
  }
  u2.normalize();
  Eigen::Matrix3d U, W;
  U << u1, u2, u1.cross(u2);
  W << v1, v2, v1.cross(v2);
  return U * W.transpose();
}

inline Eigen::Matrix3d closest_rotation_inline(const Eigen::Matrix3d& F) {
  Eigen::Matrix3d R;
  if (rotation_by_newton(F, R)) return R;
  return rotation_by_svd(F);
}

/// Lanes of the batched polar decomposition: four AVX-512 registers of doubles. Each Newton step
/// is a chain of dependent operations (a division, a sum, a reduction over lanes); with 32
/// independent lanes those latencies overlap, which doubles the throughput of 8 lanes.
constexpr int kPolarLanes = 32;

/// Cofactors C of the kPolarLanes matrices X (lane layout of closest_rotations_lanes) and their
/// determinants.
GSHELL_SIMD_KERNEL void cofactor_lanes(const double (*X)[kPolarLanes], double (*C)[kPolarLanes], double* det) {
  for (int l = 0; l < kPolarLanes; ++l) {
    C[0][l] = X[4][l] * X[8][l] - X[5][l] * X[7][l];
    C[1][l] = X[5][l] * X[6][l] - X[3][l] * X[8][l];
    C[2][l] = X[3][l] * X[7][l] - X[4][l] * X[6][l];
    C[3][l] = X[2][l] * X[7][l] - X[1][l] * X[8][l];
    C[4][l] = X[0][l] * X[8][l] - X[2][l] * X[6][l];
    C[5][l] = X[1][l] * X[6][l] - X[0][l] * X[7][l];
    C[6][l] = X[1][l] * X[5][l] - X[2][l] * X[4][l];
    C[7][l] = X[2][l] * X[3][l] - X[0][l] * X[5][l];
    C[8][l] = X[0][l] * X[4][l] - X[1][l] * X[3][l];
    det[l] = X[0][l] * C[0][l] + X[1][l] * C[1][l] + X[2][l] * C[2][l];
  }
}

/// Closest rotations of kPolarLanes matrices at once, in struct-of-arrays layout: entry (r, c)
/// of lane l at [(3 r + c) * kPolarLanes + l]. The Newton iteration runs on all lanes together
/// (the branch-free loops over lanes vectorise) until every lane has converged; lanes that are
/// inverted, too ill-conditioned or unconverged are redone by the SVD.
/// A SIMD kernel body (solver/simd_dispatch.h): inlined into each instruction-set variant of its
/// caller, so it is plain loops (no Eigen in the hot path; rare lanes go to rotation_by_svd).
GSHELL_SIMD_KERNEL void closest_rotations_lanes(const double* F, double* R) {
  constexpr int W = kPolarLanes;
  alignas(64) double X[9][W], C[9][W], det[W], g[W], delta2[W], valid[W];
  for (int k = 0; k < 9; ++k)
    for (int l = 0; l < W; ++l) X[k][l] = F[k * W + l];
  cofactor_lanes(X, C, det);
  for (int l = 0; l < W; ++l) {
    double a = 0, b = 0;
#pragma GCC unroll 9
    for (int k = 0; k < 9; ++k) {
      a += X[k][l] * X[k][l];
      b += C[k][l] * C[k][l];
    }
    // Same acceptance as rotation_by_newton (det > 1e-6 |F|^3), squared to avoid a root.
    valid[l] = (det[l] > 0 && det[l] * det[l] > 1e-12 * a * a * a) ? 1.0 : 0.0;
    // Frobenius scaling g = sqrt(|X^-1| / |X|) for the first step (later steps are near 1); a
    // rejected lane's value is replaced below. (std::sqrt vectorises where errno is not kept:
    // the kernel files are compiled with -fno-math-errno.)
    const double ratio = b / (a * det[l] * det[l]);
    g[l] = std::sqrt(std::sqrt(ratio > 0 ? ratio : 1.0));
  }
  // Rejected lanes iterate on the identity (finite, so they cannot disturb the vector loop) and
  // are redone by the SVD at the end.
  for (int l = 0; l < W; ++l) {
    const bool ok = valid[l] != 0.0;
#pragma GCC unroll 9
    for (int k = 0; k < 9; ++k) {
      const double id = (k % 4 == 0) ? 1.0 : 0.0;
      X[k][l] = ok ? X[k][l] : id;
      C[k][l] = ok ? C[k][l] : id;
    }
    det[l] = ok ? det[l] : 1.0;
    g[l] = ok ? g[l] : 1.0;
  }
  bool converged = false;
  for (int it = 0; it < 24 && !converged; ++it) {
    for (int l = 0; l < W; ++l) {
      const double a = 0.5 * g[l], b = 0.5 / (g[l] * det[l]);
      double sq[9];
#pragma GCC unroll 9
      for (int k = 0; k < 9; ++k) {
        const double xn = a * X[k][l] + b * C[k][l];
        const double d = xn - X[k][l];
        sq[k] = d * d;
        X[k][l] = xn;
      }
      // Summed as a tree: a running sum would be a chain of nine dependent additions per step.
      const double d2 = ((sq[0] + sq[1]) + (sq[2] + sq[3])) + ((sq[4] + sq[5]) + (sq[6] + sq[7])) + sq[8];
      delta2[l] = d2 * valid[l];
      g[l] = 1.0;
    }
    double worst = 0;
    for (int l = 0; l < W; ++l) worst = worst > delta2[l] ? worst : delta2[l];
    converged = worst < 1e-16;
    if (!converged) {
      cofactor_lanes(X, C, det);
      for (int l = 0; l < W; ++l) { // a lane that lost its sign is left to the SVD
        const double keep = det[l] > 0 ? 1.0 : 0.0;
        valid[l] *= keep;
        det[l] = keep * det[l] + (1.0 - keep);
      }
    }
  }
  for (int k = 0; k < 9; ++k)
    for (int l = 0; l < W; ++l) R[k * W + l] = X[k][l];
  for (int l = 0; l < W; ++l) {
    if (!(valid[l] != 0.0 && delta2[l] < 1e-16)) {
      Eigen::Matrix3d Fl;
      for (int k = 0; k < 9; ++k) Fl(k / 3, k % 3) = F[k * W + l];
      const Eigen::Matrix3d Rl = rotation_by_svd(Fl);
      for (int k = 0; k < 9; ++k) R[k * W + l] = Rl(k / 3, k % 3);
    }
  }
}

} // namespace gshell::detail
