#include "guard/start_check.h"

#include <gshell/quality/shell_certificate.h>
#include <gshell/shell/prism_tets.h>

#include "quality/boundary_rows.h"
#include "quality/face_pair_search.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace gshell::detail {
ItemGroups StartChecker::top_incidence(const Eigen::MatrixXi& M, const std::vector<int>& ids) const {
  return group_items(n_, [&](auto&& add) {
    for (int id : ids)
      for (int k = 0; k < M.cols(); ++k)
        if (M(id, k) >= n_) add(M(id, k) - n_, id);
  });
}

void StartChecker::place(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top) const {
  if (!trees_) { // no first check of the whole shell gave its trees: the same trees, unflagged
    X_.resize(2 * n_, 3);
    X_ << base, top;
    const Eigen::Index m = F_.rows();
    trees_.emplace(CertificateTrees{FaceSet(X_, boundary_.F.topRows(m)),
                                    FaceSet(X_, boundary_.F.bottomRows(boundary_.size() - m))});
    return;
  }
  // Every vertex that moved since the last check, flagged or not, so the tree is exact for the
  // positions whoever moved them: a pass down the columns (contiguous), cheap beside the tests.
  std::vector<char> differs(2 * n_, 0);
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < n_; ++i) {
      differs[i] |= base(i, c) != X_(i, c);
      differs[n_ + i] |= top(i, c) != X_(n_ + i, c);
    }
  std::vector<int> changed;
  for (int i = 0; i < 2 * n_; ++i)
    if (differs[i]) {
      X_.row(i) = i < n_ ? base.row(i) : top.row(i - n_);
      changed.push_back(i);
    }
  trees_->base.move_vertices(X_, changed);
  trees_->upper.move_vertices(X_, changed);
}

StartChecker::StartChecker(const Eigen::MatrixXi& F, int n, std::vector<char> skip_tets,
                           std::vector<char> excluded_triangles)
    : F_(F), n_(n), boundary_(shell_boundary(F, n)), skip_(std::move(skip_tets)) {
  if (skip_.empty()) skip_.assign(3 * static_cast<std::size_t>(F.rows()), 0);
  exclude_triangles(std::move(excluded_triangles));
}

void StartChecker::exclude_triangles(std::vector<char> excluded_triangles) {
  excluded_ = std::move(excluded_triangles);
  if (excluded_.empty()) excluded_.assign(boundary_.size(), 0);
  rows_.clear();
  for (int r = 0; r < boundary_.size(); ++r)
    if (!excluded_[r]) rows_.push_back(r);
}

const StartChecker::Parts& StartChecker::parts() const {
  if (parts_) return *parts_;
  Parts& p = parts_.emplace();
  p.parts = shell_parts(F_, n_);
  p.vertices = group_items(p.parts.count(), [&](auto&& add) {
    for (int i = 0; i < n_; ++i)
      if (p.parts.of_vertex[i] >= 0) add(p.parts.of_vertex[i], i);
  });
  p.excluded = parts_with_flagged_rows(p.parts, boundary_, excluded_, n_);
  return p;
}

const Eigen::MatrixXi& StartChecker::tets() const {
  if (T_.rows() == 0 && F_.rows() > 0) T_ = build_prism_tets(F_, n_);
  return T_;
}

StartChecker::~StartChecker() = default;

void StartChecker::nesting_to_thin(const std::vector<std::pair<int, int>>& nested, const Eigen::MatrixXd& X,
                                   StartViolations& v) const {
  if (nested.empty()) return;
  const Parts& p = this->parts();
  // Per holder part, the boxes of the base parts inside its layer.
  std::vector<std::vector<Eigen::AlignedBox3d>> inside(p.parts.count());
  for (const auto& [probe, t] : nested) {
    const int own = p.parts.of_vertex[probe < n_ ? probe : probe - n_], holder = p.parts.of_vertex[F_(t / 3, 0)];
    if (p.excluded[own] || p.excluded[holder]) continue;
    if (probe >= n_) {
      v.nested_parts.push_back(own);
      continue;
    }
    Eigen::AlignedBox3d box;
    for (int i : p.vertices.items_of({own})) box.extend(X.row(i).transpose());
    inside[holder].push_back(box);
  }
  std::sort(v.nested_parts.begin(), v.nested_parts.end());
  v.nested_parts.erase(std::unique(v.nested_parts.begin(), v.nested_parts.end()), v.nested_parts.end());
  std::vector<char> thin(n_, 0);
  for (Eigen::Index f = 0; f < F_.rows(); ++f) {
    const std::vector<Eigen::AlignedBox3d>& boxes = inside[p.parts.of_vertex[F_(f, 0)]];
    if (boxes.empty()) continue;
    Eigen::AlignedBox3d prism;
    for (int k = 0; k < 3; ++k) {
      prism.extend(X.row(F_(f, k)).transpose());
      prism.extend(X.row(n_ + F_(f, k)).transpose());
    }
    if (std::any_of(boxes.begin(), boxes.end(), [&](const Eigen::AlignedBox3d& b) { return b.intersects(prism); }))
      for (int k = 0; k < 3; ++k) thin[F_(f, k)] = 1;
  }
  for (int i = 0; i < n_; ++i)
    if (thin[i]) v.nested_tops.push_back(i);
}

ShellCertificate StartChecker::certify(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                                       std::vector<std::pair<int, int>>* base_crossings) const {
  CertifyOptions options;
  options.base_self_intersections = base_crossings != nullptr;
  // Its trees serve the later checks; a start that mends nothing frees them with the checker.
  ShellCertificate c = certify_shell_keeping_trees(base, top, F_, options, trees_);
  X_.resize(2 * n_, 3);
  X_ << base, top;
  if (base_crossings) { // handed over, and the certificate left as if they had not been searched
    base_crossings->clear();
    std::erase_if(c.intersections, [&](const BoundaryIntersection& p) {
      if (p.kind != IntersectionKind::BaseBase) return false;
      base_crossings->emplace_back(p.a, p.b); // base row f is face f
      return true;
    });
    c.base_self_intersections = -1;
  }
  return c;
}

StartViolations StartChecker::violations(ShellCertificate certificate) const {
  StartViolations v;
  const ShellCertificate& c = v.certificate.emplace(std::move(certificate));
  for (int t : c.inverted_tet_ids)
    if (!skip_[t]) v.inverted_tets.push_back(t);
  for (const BoundaryIntersection& p : c.intersections)
    if (!excluded_[p.a] && !excluded_[p.b]) v.intersections.emplace_back(p.a, p.b);
  if (v.inverted_tets.empty() && v.intersections.empty()) nesting_to_thin(c.nested, X_, v);
  return v;
}

StartViolations StartChecker::check(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                                    const std::vector<char>* moved) const {
  if (!moved) return violations(certify(base, top));
  StartViolations v;

  if (top_tets_.start.empty()) { // the incidences of the checks after the first, made once
    const Eigen::MatrixXi& T = tets();
    std::vector<int> tets;
    for (int t = 0; t < T.rows(); ++t)
      if (!skip_[t]) tets.push_back(t);
    top_tets_ = top_incidence(T, tets);
    top_rows_ = top_incidence(boundary_.F, rows_);
  }
  std::vector<int> moved_ids;
  for (int i = 0; i < n_; ++i)
    if ((*moved)[i]) moved_ids.push_back(i);

  const Eigen::MatrixXi& T = tets();
  const std::vector<int> tets = top_tets_.items_of(moved_ids);
  auto point = [&](int i) {
    const auto p = i < n_ ? base.row(i) : top.row(i - n_);
    return ExactPoint(p(0), p(1), p(2));
  };
  tbb::enumerable_thread_specific<std::vector<int>> inverted;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tets.size(), 1024), [&](const auto& r) {
    for (std::size_t k = r.begin(); k < r.end(); ++k) {
      const int t = tets[k];
      if (CGAL::orientation(point(T(t, 0)), point(T(t, 1)), point(T(t, 2)), point(T(t, 3))) != CGAL::POSITIVE)
        inverted.local().push_back(t);
    }
  });
  for (const auto& part : inverted) v.inverted_tets.insert(v.inverted_tets.end(), part.begin(), part.end());
  std::sort(v.inverted_tets.begin(), v.inverted_tets.end());

  // Pairs of (a row with a moved vertex) x (any row); base/base pairs cannot have one. The tree
  // over all rows follows the positions vertex by vertex (FaceSet::move_vertices): a check moves
  // few vertices, and rebuilding the tree (the Morton sort), or refitting all of it, was most of
  // a check's cost on big meshes.
  const std::vector<int> changed = top_rows_.items_of(moved_ids);
  if (changed.empty()) return v;
  place(base, top);
  const Eigen::MatrixXi& B = boundary_.F;
  const FaceSet some(X_, rows_of(B, changed), nullptr, trees_->upper.frame());
  auto is_changed = [&](int row) { return std::binary_search(changed.begin(), changed.end(), row); };
  PairCollector found;
  auto add = [&](int s, int b) {
    const int a = changed[s];
    if (a == b || (b < a && is_changed(b)) || excluded_[b]) return; // each pair of changed rows once
    found.add(std::min(a, b), std::max(a, b));
  };
  const int m = static_cast<int>(F_.rows());
  some.for_each_pair_meeting_beyond_shared(trees_->base, [&](int s, int t) { add(s, t); });
  some.for_each_pair_meeting_beyond_shared(trees_->upper, [&](int s, int t) { add(s, m + t); });
  v.intersections = found.sorted();
  // A part moved whole through another part's surface crosses nothing on the way: tested over the
  // whole shell (a pass over its tets, only where it has several parts) once nothing else is
  // found, as the one-vertex-per-sheet test presumes.
  if (v.inverted_tets.empty() && v.intersections.empty())
    nesting_to_thin(nested_probes(base, top, F_, parts().parts), X_, v);
  return v;
}

} // namespace gshell::detail
