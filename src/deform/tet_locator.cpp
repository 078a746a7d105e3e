#include <gshell/deform/tet_locator.h>

#include <gshell/error.h>
#include <gshell/geometry/closest_point.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

namespace gshell {

TetLocator::TetLocator(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T) : X_(X), T_(T) {
  if (X.cols() != 3 || (T.size() > 0 && T.cols() != 4))
    throw InputError("TetLocator: X must be N x 3 and T K x 4");
  if (T.size() > 0 && (T.minCoeff() < 0 || T.maxCoeff() >= X.rows()))
    throw InputError("TetLocator: T has a vertex id outside 0.." + std::to_string(X.rows() - 1));
  const int K = static_cast<int>(T.rows());
  inverse_edges_.assign(K, Eigen::Matrix3d::Zero());
  std::vector<Eigen::Vector3d> bmin(K), bmax(K);
  Eigen::Vector3d extent_sum = Eigen::Vector3d::Zero();
  Eigen::Vector3d all_min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d all_max = -all_min;
  for (int t = 0; t < K; ++t) {
    const Eigen::Vector3d x0 = X.row(T(t, 0)).transpose();
    Eigen::Matrix3d D;
    for (int k = 0; k < 3; ++k) D.col(k) = X.row(T(t, k + 1)).transpose() - x0;
    bmin[t] = bmax[t] = x0;
    for (int k = 1; k < 4; ++k) {
      bmin[t] = bmin[t].cwiseMin(X.row(T(t, k)).transpose());
      bmax[t] = bmax[t].cwiseMax(X.row(T(t, k)).transpose());
    }
    const Eigen::Vector3d extent = bmax[t] - bmin[t];
    const double det = D.determinant();
    if (!std::isfinite(det) || std::abs(det) <= 1e-14 * extent.prod() || extent.minCoeff() <= 0) continue;
    inverse_edges_[t] = D.inverse();
    usable_.push_back(t);
    extent_sum += extent;
    all_min = all_min.cwiseMin(bmin[t]);
    all_max = all_max.cwiseMax(bmax[t]);
  }
  if (usable_.empty()) return;
  cell_size_ = extent_sum / static_cast<double>(usable_.size());
  origin_ = all_min;
  lo_ = cell_of(all_min);
  hi_ = cell_of(all_max);
  for (int t : usable_) {
    const Cell a = cell_of(bmin[t]), b = cell_of(bmax[t]);
    for (auto i = a.x(); i <= b.x(); ++i)
      for (auto j = a.y(); j <= b.y(); ++j)
        for (auto k = a.z(); k <= b.z(); ++k) cells_[key(Cell(i, j, k))].push_back(t);
  }
}

TetLocator::Cell TetLocator::cell_of(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d q = (p - origin_).cwiseQuotient(cell_size_);
  // Far-away query points get clamped cell ids; they only steer the ring search's start.
  constexpr double kLimit = 1 << 20;
  return Cell(static_cast<std::int64_t>(std::floor(std::clamp(q.x(), -kLimit, kLimit))),
              static_cast<std::int64_t>(std::floor(std::clamp(q.y(), -kLimit, kLimit))),
              static_cast<std::int64_t>(std::floor(std::clamp(q.z(), -kLimit, kLimit))));
}

std::uint64_t TetLocator::key(const Cell& c) const {
  // Occupied cells lie in [lo_, hi_]; 21 bits per axis cover 2M cells along each.
  const std::uint64_t i = static_cast<std::uint64_t>(c.x() - lo_.x()) & 0x1FFFFF;
  const std::uint64_t j = static_cast<std::uint64_t>(c.y() - lo_.y()) & 0x1FFFFF;
  const std::uint64_t k = static_cast<std::uint64_t>(c.z() - lo_.z()) & 0x1FFFFF;
  return (i << 42) | (j << 21) | k;
}

const std::vector<int>* TetLocator::tets_in(const Cell& c) const {
  for (int a = 0; a < 3; ++a)
    if (c[a] < lo_[a] || c[a] > hi_[a]) return nullptr;
  const auto it = cells_.find(key(c));
  return it == cells_.end() ? nullptr : &it->second;
}

Eigen::Vector4d TetLocator::affine_coordinates(int t, const Eigen::Vector3d& p) const {
  const Eigen::Vector3d l = inverse_edges_[t] * (p - X_.row(T_(t, 0)).transpose());
  return Eigen::Vector4d(1.0 - l.sum(), l.x(), l.y(), l.z());
}

double TetLocator::distance_to_tet(int t, const Eigen::Vector3d& p) const {
  if (affine_coordinates(t, p).minCoeff() >= 0) return 0;
  static constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  double best = std::numeric_limits<double>::infinity();
  for (const auto& f : kFaces) {
    const Eigen::Vector3d q = closest_point_on_triangle(p, X_.row(T_(t, f[0])).transpose(),
                                                        X_.row(T_(t, f[1])).transpose(),
                                                        X_.row(T_(t, f[2])).transpose());
    best = std::min(best, (q - p).norm());
  }
  return best;
}

TetHit TetLocator::locate(const Eigen::Vector3d& p) const {
  TetHit hit;
  if (usable_.empty()) return hit;
  const Cell c = cell_of(p);
  double deepest = -std::numeric_limits<double>::infinity();
  if (const auto* list = tets_in(c)) {
    for (int t : *list) {
      const Eigen::Vector4d l = affine_coordinates(t, p);
      if (l.minCoeff() > deepest) {
        deepest = l.minCoeff();
        hit.tet = t;
        hit.bary = l;
      }
    }
  }
  if (hit.tet >= 0 && deepest >= -kInsideTolerance) {
    hit.inside = true;
    return hit;
  }
  // Outside every tet of its cell: search rings of cells around it for the nearest tet. Tets not
  // registered within ring r have bounding boxes outside the (2r+1)^3 block, hence lie farther
  // than r * min(cell size) from p.
  double best = std::numeric_limits<double>::infinity();
  int best_tet = -1;
  auto visit = [&](const Cell& cell) {
    if (const auto* list = tets_in(cell))
      for (int t : *list) {
        const double d = distance_to_tet(t, p);
        if (d < best || (d == best && t < best_tet)) {
          best = d;
          best_tet = t;
        }
      }
  };
  const double step = cell_size_.minCoeff();
  std::int64_t max_r = 0;
  for (int a = 0; a < 3; ++a) max_r = std::max({max_r, std::abs(c[a] - lo_[a]), std::abs(hi_[a] - c[a])});
  for (std::int64_t r = 0; r <= max_r; ++r) {
    const std::int64_t x0 = std::max(c.x() - r, lo_.x()), x1 = std::min(c.x() + r, hi_.x());
    const std::int64_t y0 = std::max(c.y() - r, lo_.y()), y1 = std::min(c.y() + r, hi_.y());
    for (auto i = x0; i <= x1; ++i)
      for (auto j = y0; j <= y1; ++j) {
        if (std::abs(i - c.x()) == r || std::abs(j - c.y()) == r) {
          for (auto k = std::max(c.z() - r, lo_.z()); k <= std::min(c.z() + r, hi_.z()); ++k) visit(Cell(i, j, k));
        } else {
          visit(Cell(i, j, c.z() - r));
          if (r > 0) visit(Cell(i, j, c.z() + r));
        }
      }
    if (best_tet >= 0 && best <= static_cast<double>(r) * step) break;
  }
  hit.tet = best_tet;
  hit.bary = affine_coordinates(best_tet, p);
  hit.distance = best;
  hit.inside = hit.bary.minCoeff() >= -kInsideTolerance;
  if (hit.inside) hit.distance = 0;
  return hit;
}

} // namespace gshell
