#include "guard/start_check.h"

#include <gshell/quality/shell_certificate.h>
#include <gshell/shell/prism_tets.h>

#include "quality/face_pair_search.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace gshell::detail {
namespace {

Eigen::MatrixXi rows_of(const Eigen::MatrixXi& B, const std::vector<int>& ids) {
  Eigen::MatrixXi S(static_cast<int>(ids.size()), 3);
  for (std::size_t i = 0; i < ids.size(); ++i) S.row(static_cast<int>(i)) = B.row(ids[i]);
  return S;
}

} // namespace

StartChecker::StartChecker(const Eigen::MatrixXi& F, int n, std::vector<char> skip_tets,
                           std::vector<char> excluded_triangles)
    : F_(F), n_(n), boundary_(shell_boundary(F, n)), skip_(std::move(skip_tets)),
      excluded_(std::move(excluded_triangles)) {
  if (skip_.empty()) skip_.assign(3 * static_cast<std::size_t>(F.rows()), 0);
  if (excluded_.empty()) excluded_.assign(boundary_.size(), 0);
  for (int r = 0; r < boundary_.size(); ++r)
    if (!excluded_[r]) rows_.push_back(r);
}

const Eigen::MatrixXi& StartChecker::tets() const {
  if (T_.rows() == 0 && F_.rows() > 0) T_ = build_prism_tets(F_, n_);
  return T_;
}

StartChecker::~StartChecker() = default;

StartViolations StartChecker::check(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                                    const std::vector<char>* moved) const {
  StartViolations v;
  if (!moved) { // the whole shell: the certificate itself, without the base's own pairs
    CertifyOptions options;
    options.base_self_intersections = false;
    const ShellCertificate& c = v.certificate.emplace(certify_shell(base, top, F_, options));
    for (int t : c.inverted_tet_ids)
      if (!skip_[t]) v.inverted_tets.push_back(t);
    for (const BoundaryIntersection& p : c.intersections)
      if (!excluded_[p.a] && !excluded_[p.b]) v.intersections.emplace_back(p.a, p.b);
    return v;
  }

  const Eigen::MatrixXi& T = tets();
  Eigen::MatrixXd X(2 * n_, 3);
  X << base, top;
  auto is_moved = [&](int vertex) { return vertex >= n_ && (*moved)[vertex - n_]; };
  tbb::enumerable_thread_specific<std::vector<int>> inverted;
  tbb::parallel_for(tbb::blocked_range<int>(0, static_cast<int>(T.rows()), 8192), [&](const tbb::blocked_range<int>& r) {
    auto point = [&](int i) { return ExactPoint(X(i, 0), X(i, 1), X(i, 2)); };
    for (int t = r.begin(); t < r.end(); ++t) {
      if (skip_[t] || !(is_moved(T(t, 1)) || is_moved(T(t, 2)) || is_moved(T(t, 3)) || is_moved(T(t, 0)))) continue;
      if (CGAL::orientation(point(T(t, 0)), point(T(t, 1)), point(T(t, 2)), point(T(t, 3))) != CGAL::POSITIVE)
        inverted.local().push_back(t);
    }
  });
  for (const auto& part : inverted) v.inverted_tets.insert(v.inverted_tets.end(), part.begin(), part.end());
  std::sort(v.inverted_tets.begin(), v.inverted_tets.end());

  // Pairs of (a row with a moved vertex) x (any row); base/base pairs cannot have one. The tree
  // over all rows is refit between rounds: a round moves few vertices, and rebuilding it (the
  // Morton sort) was most of a round's cost on big meshes.
  const Eigen::MatrixXi& B = boundary_.F;
  std::vector<int> changed;
  for (int r : rows_)
    if (is_moved(B(r, 0)) || is_moved(B(r, 1)) || is_moved(B(r, 2))) changed.push_back(r);
  if (changed.empty()) return v;
  std::vector<char> is_changed(boundary_.size(), 0);
  for (int r : changed) is_changed[r] = 1;
  if (all_) {
    all_->move_to(X, rows_F_);
  } else {
    rows_F_ = rows_of(B, rows_);
    all_ = std::make_unique<FaceSet>(X, rows_F_);
  }
  const FaceSet some(X, rows_of(B, changed));
  const FaceSet& all = *all_;
  const std::vector<int>& rows = rows_;
  PairCollector found;
  some.for_each_pair_meeting_beyond_shared(all, [&](int s, int t) {
    const int a = changed[s], b = rows[t];
    if (a == b || (is_changed[b] && b < a)) return; // each pair of changed rows once
    found.add(std::min(a, b), std::max(a, b));
  });
  v.intersections = found.sorted();
  return v;
}

} // namespace gshell::detail
