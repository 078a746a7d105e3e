#include "guard/start_check.h"

#include "quality/face_bvh.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Intersections_3/Triangle_3_Triangle_3.h>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace gshell::detail {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;

K::Point_3 point(const Eigen::MatrixXd& X, int i) { return K::Point_3(X(i, 0), X(i, 1), X(i, 2)); }

// Exact: do boundary rows a and b meet? (INTERIM: neighbours sharing a vertex are not tested.)
bool rows_intersect(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F, int a, int b) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (F(a, i) == F(b, j)) return false;
  const K::Triangle_3 ta(point(X, F(a, 0)), point(X, F(a, 1)), point(X, F(a, 2)));
  const K::Triangle_3 tb(point(X, F(b, 0)), point(X, F(b, 1)), point(X, F(b, 2)));
  if (ta.is_degenerate() || tb.is_degenerate()) return false;
  return CGAL::do_intersect(ta, tb);
}

} // namespace

StartChecker::StartChecker(const Eigen::MatrixXi& T, const ShellBoundary& boundary, std::vector<char> skip_tets,
                           std::vector<char> excluded_triangles, int num_vertices)
    : T_(T), boundary_(boundary), skip_(std::move(skip_tets)), excluded_(std::move(excluded_triangles)),
      N_(num_vertices) {
  if (skip_.empty()) skip_.assign(T_.rows(), 0);
  if (excluded_.empty()) excluded_.assign(boundary_.size(), 0);
}

StartViolations StartChecker::check(const Eigen::MatrixXd& X, const std::vector<char>* moved) const {
  StartViolations v;
  auto touches = [&](auto row, int cols) {
    for (int k = 0; k < cols; ++k)
      if ((*moved)[row(k)]) return true;
    return false;
  };
  // Tets.
  tbb::enumerable_thread_specific<std::vector<int>> inverted;
  tbb::parallel_for(tbb::blocked_range<int>(0, static_cast<int>(T_.rows()), 4096), [&](const tbb::blocked_range<int>& r) {
    for (int t = r.begin(); t < r.end(); ++t) {
      if (skip_[t]) continue;
      if (moved && !touches([&](int k) { return T_(t, k); }, 4)) continue;
      if (CGAL::orientation(point(X, T_(t, 0)), point(X, T_(t, 1)), point(X, T_(t, 2)), point(X, T_(t, 3))) !=
          CGAL::POSITIVE)
        inverted.local().push_back(t);
    }
  });
  for (const auto& part : inverted) v.inverted_tets.insert(v.inverted_tets.end(), part.begin(), part.end());
  std::sort(v.inverted_tets.begin(), v.inverted_tets.end());

  // Pairs: every admissible pair whose boxes meet, or only those with a moved row.
  const Eigen::MatrixXi& F = boundary_.F;
  std::vector<int> rows, changed;
  for (int r = 0; r < boundary_.size(); ++r) {
    if (excluded_[r]) continue;
    rows.push_back(r);
    if (moved && touches([&](int k) { return F(r, k); }, 3)) changed.push_back(r);
  }
  auto sub = [&](const std::vector<int>& ids) {
    Eigen::MatrixXi S(static_cast<int>(ids.size()), 3);
    for (std::size_t i = 0; i < ids.size(); ++i) S.row(static_cast<int>(i)) = F.row(ids[i]);
    return S;
  };
  tbb::enumerable_thread_specific<std::vector<std::pair<int, int>>> found;
  auto consider = [&](int a, int b) {
    if (a == b) return;
    if (boundary_.part[a] == BoundaryPart::Base && boundary_.part[b] == BoundaryPart::Base) return;
    if (rows_intersect(X, F, a, b)) found.local().emplace_back(std::min(a, b), std::max(a, b));
  };
  const Eigen::MatrixXi all_rows = sub(rows);
  const FaceBvh all(X, all_rows, FaceBvh::Use::pairs);
  const std::vector<int>& all_face = all.faces_in_leaf_order();
  if (!moved) {
    all.for_each_overlapping_pair([&](int s, int t) { consider(rows[all_face[s]], rows[all_face[t]]); });
  } else if (!changed.empty()) {
    std::vector<char> is_changed(boundary_.size(), 0);
    for (int r : changed) is_changed[r] = 1;
    const FaceBvh some(X, sub(changed), FaceBvh::Use::pairs);
    const std::vector<int>& some_face = some.faces_in_leaf_order();
    some.for_each_overlapping_pair(all, [&](int s, int t) {
      const int a = changed[some_face[s]], b = rows[all_face[t]];
      if (is_changed[b] && b < a) return; // seen from b's side
      consider(a, b);
    });
  }
  for (const auto& part : found) v.intersections.insert(v.intersections.end(), part.begin(), part.end());
  std::sort(v.intersections.begin(), v.intersections.end());
  v.intersections.erase(std::unique(v.intersections.begin(), v.intersections.end()), v.intersections.end());
  return v;
}

} // namespace gshell::detail
