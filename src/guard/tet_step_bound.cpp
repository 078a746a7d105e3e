#include <gshell/guard/tet_step_bound.h>

#include <gshell/error.h>

#include "solver/simd_dispatch.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace gshell {

namespace {

double det3(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) { return a.dot(b.cross(c)); }

double horner(const std::array<double, 4>& a, double c0, double s) { return ((a[3] * s + a[2]) * s + a[1]) * s + c0; }

// The shape checks of tet_step_bound and tets_cutting_step (`who` names the caller); the vertex ids
// are checked by each where it reads them.
void check_shapes(const char* who, const Eigen::MatrixXi& T, const Eigen::MatrixXd& X, const Eigen::MatrixXd& D,
                  const std::vector<char>* skip) {
  const std::string name(who);
  if (X.cols() != 3 || D.rows() != X.rows() || D.cols() != 3) throw InputError(name + ": X and D must both be N x 3");
  if (T.rows() > 0 && T.cols() != 4) throw InputError(name + ": T must be K x 4 with vertex ids in 0..N-1");
  if (skip && static_cast<Eigen::Index>(skip->size()) != T.rows())
    throw InputError(name + ": skip needs one flag per tet");
}

} // namespace

std::array<double, 4> tet_volume_cubic(const Eigen::Vector3d x[4], const Eigen::Vector3d d[4]) {
  const Eigen::Vector3d e1 = x[1] - x[0], e2 = x[2] - x[0], e3 = x[3] - x[0];
  const Eigen::Vector3d f1 = d[1] - d[0], f2 = d[2] - d[0], f3 = d[3] - d[0];
  return {det3(e1, e2, e3), det3(f1, e2, e3) + det3(e1, f2, e3) + det3(e1, e2, f3),
          det3(e1, f2, f3) + det3(f1, e2, f3) + det3(f1, f2, e3), det3(f1, f2, f3)};
}

double cubic_step_bound(const std::array<double, 4>& a, double keep, double max_step) {
  // g(s) = p(s) - keep p(0), g(0) > 0: find its first root in (0, max_step].
  const double c0 = (1 - keep) * a[0];
  if (!(c0 > 0) || !(max_step > 0)) return 0;
  // Split [0, max_step] at the critical points of g (roots of 3 a3 s^2 + 2 a2 s + a1) into pieces
  // where g is monotone; the first piece whose right end has g <= 0 holds the first root.
  double cuts[3];
  int ncuts = 0;
  const double qa = 3 * a[3], qb = 2 * a[2], qc = a[1];
  if (qa != 0) {
    const double disc = qb * qb - 4 * qa * qc;
    if (disc >= 0) {
      // The numerically stable pair of roots (no cancellation between -qb and the square root).
      const double q = -0.5 * (qb + std::copysign(std::sqrt(disc), qb));
      if (q != 0) {
        cuts[ncuts++] = q / qa;
        cuts[ncuts++] = qc / q;
      } else {
        cuts[ncuts++] = 0;
      }
    }
  } else if (qb != 0) {
    cuts[ncuts++] = -qc / qb;
  }
  std::sort(cuts, cuts + ncuts);
  double lo = 0;
  for (int i = 0; i <= ncuts; ++i) {
    const double hi = i < ncuts ? cuts[i] : max_step;
    if (!(hi > lo)) continue;
    const double right = std::min(hi, max_step);
    if (horner(a, c0, right) <= 0) {
      // g(lo) > 0 >= g(right), g monotone in between: bisect, keeping g(lo) > 0.
      double l = lo, r = right;
      for (int it = 0; it < 200 && r - l > 1e-15 * r; ++it) {
        const double mid = 0.5 * (l + r);
        if (!(mid > l && mid < r)) break;
        if (horner(a, c0, mid) > 0)
          l = mid;
        else
          r = mid;
      }
      return l;
    }
    lo = right;
    if (lo >= max_step) break;
  }
  return max_step;
}

namespace {

// Tets settled in lanes, kLanes at a time: the volume cubic of each and whether the Bernstein
// coefficients of g(s) = p(s) - keep p(0) on [0, max_step] all lie above a margin (g lies in their
// convex hull, so g > 0 there). The margin exceeds by far both the rounding of any evaluation of g
// on [0, max_step] and the difference between these coefficients and tet_volume_cubic's (other
// order of operations, fused multiply-adds): a settled tet is one for which cubic_step_bound
// returns max_step, and most tets of a step are settled here without a root search. Only tets
// within about 1e-13 of flat, or whose cubic comes near the kept fraction, go on to the search.
constexpr int kLanes = 16;

struct TetLanes {
  double x[4][3][kLanes] = {}; // corner, axis, lane
  double d[4][3][kLanes] = {};
};

GSHELL_SIMD_KERNEL void settle_lanes_body(const TetLanes& t, double keep, double h, unsigned char* settled) {
  for (int l = 0; l < kLanes; ++l) {
    double e[3][3], f[3][3]; // edge k (from corner 0 to corner k + 1), axis
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) {
        e[k][a] = t.x[k + 1][a][l] - t.x[0][a][l];
        f[k][a] = t.d[k + 1][a][l] - t.d[0][a][l];
      }
    // det[e1 + s f1, e2 + s f2, e3 + s f3] = (e1 + s f1) . (c + s m + s^2 g) with c = e2 x e3,
    // m = f2 x e3 + e2 x f3, g = f2 x f3 (plain arithmetic: the loop vectorises across lanes).
    double c[3], m[3], g[3];
    for (int a = 0; a < 3; ++a) {
      const int b = (a + 1) % 3, q = (a + 2) % 3;
      c[a] = e[1][b] * e[2][q] - e[1][q] * e[2][b];
      m[a] = f[1][b] * e[2][q] - f[1][q] * e[2][b] + e[1][b] * f[2][q] - e[1][q] * f[2][b];
      g[a] = f[1][b] * f[2][q] - f[1][q] * f[2][b];
    }
    double a0 = 0, a1 = 0, a2 = 0, a3 = 0;
    for (int a = 0; a < 3; ++a) {
      a0 += e[0][a] * c[a];
      a1 += e[0][a] * m[a] + f[0][a] * c[a];
      a2 += e[0][a] * g[a] + f[0][a] * m[a];
      a3 += f[0][a] * g[a];
    }
    const double c0 = (1 - keep) * a0, c1 = a1 * h, c2 = a2 * h * h, c3 = a3 * h * h * h;
    const double b1 = c0 + c1 / 3, b2 = c0 + (2 * c1 + c2) / 3, b3 = c0 + c1 + c2 + c3;
    // Every product summed into a coefficient, and so every coefficient and every rounding of
    // them, is bounded by mag: the margin lies 30 times above any such rounding difference.
    double mag = 1;
    for (int k = 0; k < 3; ++k)
      mag *= std::abs(e[k][0]) + std::abs(e[k][1]) + std::abs(e[k][2]) +
             h * (std::abs(f[k][0]) + std::abs(f[k][1]) + std::abs(f[k][2]));
    const double margin = 1e-13 * mag;
    settled[l] = (c0 > margin) & (b1 > margin) & (b2 > margin) & (b3 > margin);
  }
}

GSHELL_SIMD_DISPATCH(void, settle_lanes, settle_lanes_body,
                     (const TetLanes& t, double keep, double h, unsigned char* settled), (t, keep, h, settled))

} // namespace

TetStepBound tet_step_bound(const Eigen::MatrixXi& T, const Eigen::MatrixXd& X, const Eigen::MatrixXd& D,
                            double keep_fraction, double max_step, const std::vector<char>* skip) {
  check_shapes("tet_step_bound", T, X, D, skip);
  const int K = static_cast<int>(T.rows());
  // A vertex's position and motion side by side (48 bytes, one cache line at most two): in a
  // whole shell every vertex is read by a dozen tets. Where the tets are few beside the vertices
  // (a guard repairing a small region of a large shell) the copy would cost more than the tets:
  // they read X and D where they are.
  const int N = static_cast<int>(X.rows());
  const bool interleave = 4 * static_cast<long long>(K) >= N;
  Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor> PM(interleave ? N : 0, 6);
  if (interleave)
    tbb::parallel_for(tbb::blocked_range<int>(0, N, 8192), [&](const tbb::blocked_range<int>& r) {
      for (int i = r.begin(); i < r.end(); ++i) PM.row(i) << X.row(i), D.row(i);
    });
  TetStepBound init;
  init.step = max_step;
  // position(v, a), motion(v, a): coordinate a of vertex v's position and motion.
  auto least_bound = [&](auto&& position, auto&& motion) {
    return tbb::parallel_reduce(
        tbb::blocked_range<int>(0, K, 4096), init,
        [&](const tbb::blocked_range<int>& r, TetStepBound best) {
          TetLanes lanes;
          int tet_in_lane[kLanes];
          unsigned char settled[kLanes];
          int used = 0;
          // The tets not settled in their lanes, each alone, in tet order.
          auto finish_lanes = [&] {
            settle_lanes(lanes, keep_fraction, max_step, settled);
            for (int l = 0; l < used; ++l) {
              if (settled[l]) continue;
              const int t = tet_in_lane[l];
              Eigen::Vector3d x[4], d[4];
              for (int j = 0; j < 4; ++j) {
                x[j] = Eigen::Vector3d(lanes.x[j][0][l], lanes.x[j][1][l], lanes.x[j][2][l]);
                d[j] = Eigen::Vector3d(lanes.d[j][0][l], lanes.d[j][1][l], lanes.d[j][2][l]);
              }
              const std::array<double, 4> a = tet_volume_cubic(x, d);
              if (!(a[0] > 0)) continue;
              // Each tet's bound on the whole [0, max_step], not below the running best: the
              // bisection's last bits depend on its interval, and the running best on the thread
              // schedule.
              const double s = cubic_step_bound(a, keep_fraction, max_step);
              if (s < best.step || (s == best.step && best.tet >= 0 && t < best.tet)) {
                best.step = s;
                best.tet = t;
              }
            }
            used = 0;
          };
          for (int t = r.begin(); t < r.end(); ++t) {
            for (int j = 0; j < 4; ++j)
              if (T(t, j) < 0 || T(t, j) >= N) // a bad id would read past X or D
                throw InputError("tet_step_bound: T must be K x 4 with vertex ids in 0..N-1");
            if (skip && (*skip)[t]) continue;
            bool moves = false;
            for (int j = 0; j < 4; ++j) {
              const int v = T(t, j);
              for (int a = 0; a < 3; ++a) {
                lanes.x[j][a][used] = position(v, a);
                lanes.d[j][a][used] = motion(v, a);
                moves = moves || lanes.d[j][a][used] != lanes.d[0][a][used];
              }
            }
            if (!moves) continue; // a translation keeps the volume
            tet_in_lane[used] = t;
            if (++used == kLanes) finish_lanes();
          }
          finish_lanes();
          return best;
        },
        [](const TetStepBound& a, const TetStepBound& b) {
          return a.step < b.step || (a.step == b.step && a.tet < b.tet) ? a : b;
        });
  };
  if (interleave)
    return least_bound([&](int v, int a) { return PM(v, a); }, [&](int v, int a) { return PM(v, 3 + a); });
  return least_bound([&](int v, int a) { return X(v, a); }, [&](int v, int a) { return D(v, a); });
}

bool tets_keep_volume(const Eigen::MatrixXi& T, const Eigen::MatrixXd& X0, const Eigen::MatrixXd& X1,
                      double keep_fraction, const std::vector<char>* skip) {
  check_shapes("tets_keep_volume", T, X0, X1, skip);
  const int K = static_cast<int>(T.rows()), N = static_cast<int>(X0.rows());
  if (K > 0 && (T.minCoeff() < 0 || T.maxCoeff() >= N))
    throw InputError("tets_keep_volume: T must be K x 4 with vertex ids in 0..N-1");
  const auto six_volume = [&T](const Eigen::MatrixXd& X, int t) {
    const Eigen::Vector3d x0 = X.row(T(t, 0)).transpose();
    return det3(X.row(T(t, 1)).transpose() - x0, X.row(T(t, 2)).transpose() - x0, X.row(T(t, 3)).transpose() - x0);
  };
  return tbb::parallel_reduce(
      tbb::blocked_range<int>(0, K, 4096), true,
      [&](const tbb::blocked_range<int>& r, bool kept) {
        for (int t = r.begin(); kept && t < r.end(); ++t) {
          if (skip && (*skip)[t]) continue;
          const double before = six_volume(X0, t);
          kept = !(before > 0) || six_volume(X1, t) > keep_fraction * before;
        }
        return kept;
      },
      [](bool a, bool b) { return a && b; });
}

std::vector<int> tets_cutting_step(const Eigen::MatrixXi& T, const Eigen::MatrixXd& X, const Eigen::MatrixXd& D,
                                   double keep_fraction, double max_step, const std::vector<char>* skip) {
  check_shapes("tets_cutting_step", T, X, D, skip);
  const int K = static_cast<int>(T.rows()), N = static_cast<int>(X.rows());
  if (K > 0 && (T.minCoeff() < 0 || T.maxCoeff() >= N))
    throw InputError("tets_cutting_step: T must be K x 4 with vertex ids in 0..N-1");
  constexpr int kBlock = 4096;
  std::vector<std::vector<int>> found((K + kBlock - 1) / kBlock);
  tbb::parallel_for(0, static_cast<int>(found.size()), [&](int b) {
    for (int t = b * kBlock; t < std::min(K, (b + 1) * kBlock); ++t) {
      if (skip && (*skip)[t]) continue;
      Eigen::Vector3d x[4], d[4];
      for (int j = 0; j < 4; ++j) {
        x[j] = X.row(T(t, j)).transpose();
        d[j] = D.row(T(t, j)).transpose();
      }
      if (d[0] == d[1] && d[0] == d[2] && d[0] == d[3]) continue; // a translation keeps the volume
      const std::array<double, 4> a = tet_volume_cubic(x, d);
      if (a[0] > 0 && cubic_step_bound(a, keep_fraction, max_step) < max_step) found[b].push_back(t);
    }
  });
  std::vector<int> out;
  for (const auto& f : found) out.insert(out.end(), f.begin(), f.end());
  return out;
}

} // namespace gshell
