#include <gshell/deform/tet_locator.h>

#include <gshell/error.h>

#include "quality/face_bvh.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>

namespace gshell {

struct TetLocator::Boundary {
  std::once_flag built;
  std::vector<int> tet_of; ///< per boundary face, the usable tet it bounds
  std::optional<detail::FaceBvh> bvh;
};

TetLocator::TetLocator(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T)
    : X_(X), T_(T), boundary_(std::make_shared<Boundary>()) {
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

const TetLocator::Boundary& TetLocator::boundary() const {
  std::call_once(boundary_->built, [this] {
    // A face of one usable tet only lies on the boundary of their union; the nearest point of the
    // union to a point outside it lies on such a face, in the tet that face bounds.
    struct TetFace {
      std::array<int, 3> ids; // sorted
      int tet;
    };
    std::vector<TetFace> faces;
    faces.reserve(4 * usable_.size());
    for (const int t : usable_)
      for (int corner = 0; corner < 4; ++corner) {
        std::array<int, 3> ids;
        for (int k = 0, m = 0; k < 4; ++k)
          if (k != corner) ids[m++] = T_(t, k);
        std::sort(ids.begin(), ids.end());
        faces.push_back({ids, t});
      }
    tbb::parallel_sort(faces.begin(), faces.end(), [](const TetFace& a, const TetFace& b) { return a.ids < b.ids; });
    std::vector<int> rows;
    for (std::size_t a = 0, b = 0; a < faces.size(); a = b) {
      for (b = a + 1; b < faces.size() && faces[b].ids == faces[a].ids;) ++b;
      if (b == a + 1) rows.push_back(static_cast<int>(a));
    }
    Eigen::MatrixXi F(static_cast<Eigen::Index>(rows.size()), 3);
    boundary_->tet_of.resize(rows.size());
    for (std::size_t r = 0; r < rows.size(); ++r) {
      const TetFace& f = faces[rows[r]];
      F.row(static_cast<Eigen::Index>(r)) << f.ids[0], f.ids[1], f.ids[2];
      boundary_->tet_of[r] = f.tet;
    }
    boundary_->bvh.emplace(X_, F, detail::FaceBvh::Use::distances);
  });
  return *boundary_;
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
  // Outside every tet of its cell, so outside every tet (a tet holding p has p's cell in its
  // box): the nearest tet is the one whose boundary face is nearest.
  const Boundary& b = boundary();
  int face = -1;
  const double d2 = b.bvh->squared_distance(p, std::numeric_limits<double>::infinity(), [](int) { return true; }, &face);
  if (face < 0) return {}; // p not finite
  const int best_tet = b.tet_of[static_cast<std::size_t>(face)];
  const double best = std::sqrt(d2);
  hit.tet = best_tet;
  hit.bary = affine_coordinates(best_tet, p);
  hit.distance = best;
  hit.inside = hit.bary.minCoeff() >= -kInsideTolerance;
  if (hit.inside) hit.distance = 0;
  return hit;
}

} // namespace gshell
