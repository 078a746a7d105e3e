#include <gshell/quality/shell_certificate.h>

#include <gshell/error.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/shell/prism_tets.h>

#include "quality/check_mesh_input.h"
#include "quality/embedded_stars.h"
#include "quality/face_pair_search.h"

#include <tbb/parallel_invoke.h>

#include <chrono>
#include <optional>
#include <string>

namespace gshell {
namespace {

using detail::ExactPoint;

void check_input(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top, const Eigen::MatrixXi& F) {
  if (base.rows() != top.rows() || (base.rows() > 0 && (base.cols() != 3 || top.cols() != 3)))
    throw InputError("certify_shell: base and top must be n x 3 with the same n (got " + std::to_string(base.rows()) +
                     " and " + std::to_string(top.rows()) + " rows)");
  detail::check_triangle_mesh(base, F, "certify_shell (base)");
  detail::check_triangle_mesh(top, F, "certify_shell (top)");
  detail::check_distinct_corners(F, "certify_shell");
}

// Tets (rows of build_prism_tets) whose exact orientation is not positive, ascending.
std::vector<int> inverted_tets(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T) {
  const int count = static_cast<int>(T.rows());
  std::vector<char> inverted(count, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, count, 8192), [&](const tbb::blocked_range<int>& r) {
    auto point = [&](int v) { return ExactPoint(X(v, 0), X(v, 1), X(v, 2)); };
    for (int t = r.begin(); t < r.end(); ++t)
      inverted[t] = CGAL::orientation(point(T(t, 0)), point(T(t, 1)), point(T(t, 2)), point(T(t, 3))) != CGAL::POSITIVE;
  });
  std::vector<int> ids;
  for (int t = 0; t < count; ++t)
    if (inverted[t]) ids.push_back(t);
  return ids;
}

IntersectionKind kind_of(BoundaryPart a, BoundaryPart b) {
  if (a == BoundaryPart::Wall || b == BoundaryPart::Wall) return IntersectionKind::Wall;
  if (a != b) return IntersectionKind::TopBase;
  return a == BoundaryPart::Top ? IntersectionKind::TopTop : IntersectionKind::BaseBase;
}

} // namespace

const char* to_string(IntersectionKind kind) {
  switch (kind) {
  case IntersectionKind::TopTop: return "top/top";
  case IntersectionKind::TopBase: return "top/base";
  case IntersectionKind::Wall: return "wall";
  case IntersectionKind::BaseBase: return "base/base";
  }
  return "unknown";
}

ShellCertificate certify_shell(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top, const Eigen::MatrixXi& F,
                               const CertifyOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  check_input(base, top, F);
  const int n = static_cast<int>(base.rows());
  Eigen::MatrixXd X(2 * n, 3);
  X << base, top;

  ShellCertificate c;
  if (!options.test_intersections) {
    c.inverted_tet_ids = inverted_tets(X, build_prism_tets(F, n));
  } else {
    // Two trees, base rows and the rest (top and walls), so that base/base pairs cost nothing
    // when they are not wanted. Rows: base faces 0..m-1, then top faces, then walls.
    const ShellBoundary boundary = shell_boundary(F, n);
    const int m = static_cast<int>(F.rows());
    const std::vector<char> embedded = detail::embedded_shell_stars(base, top, F);
    std::optional<detail::FaceSet> base_set, upper_set;
    tbb::parallel_invoke([&] { c.inverted_tet_ids = inverted_tets(X, build_prism_tets(F, n)); },
                         [&] { base_set.emplace(X, boundary.F.topRows(m).eval(), &embedded); },
                         [&] { upper_set.emplace(X, boundary.F.bottomRows(boundary.size() - m).eval(), &embedded); });
    detail::PairCollector found;
    upper_set->for_each_pair_meeting_beyond_shared([&](int f, int g) { found.add(m + f, m + g); });
    upper_set->for_each_pair_meeting_beyond_shared(*base_set, [&](int f, int g) { found.add(g, m + f); });
    if (options.base_self_intersections)
      base_set->for_each_pair_meeting_beyond_shared([&](int f, int g) { found.add(f, g); });

    c.top_self_intersections = c.top_base_intersections = c.wall_intersections = 0;
    c.base_self_intersections = options.base_self_intersections ? 0 : -1;
    const detail::FacePairs pairs = found.sorted();
    c.intersections.reserve(pairs.size());
    for (const auto& [a, b] : pairs) {
      const IntersectionKind kind = kind_of(boundary.part[a], boundary.part[b]);
      c.intersections.push_back({a, b, kind});
      switch (kind) {
      case IntersectionKind::TopTop: ++c.top_self_intersections; break;
      case IntersectionKind::TopBase: ++c.top_base_intersections; break;
      case IntersectionKind::Wall: ++c.wall_intersections; break;
      case IntersectionKind::BaseBase: ++c.base_self_intersections; break;
      }
    }
  }
  c.inverted_tets = static_cast<int>(c.inverted_tet_ids.size());
  c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return c;
}

} // namespace gshell
