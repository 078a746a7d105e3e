#include <gshell/quality/shell_certificate.h>

#include <gshell/error.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/seconds_since.h>
#include <gshell/shell/prism_tets.h>

#include "quality/boundary_rows.h"
#include "quality/certificate_trees.h"
#include "quality/check_mesh_input.h"
#include "quality/embedded_stars.h"
#include "quality/face_pair_search.h"
#include "quality/filtered_orientation.h"
#include "quality/nested_parts.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <initializer_list>
#include <optional>
#include <string>

namespace gshell {
namespace {

void check_input(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top, const Eigen::MatrixXi& F) {
  if (base.rows() != top.rows() || (base.rows() > 0 && (base.cols() != 3 || top.cols() != 3)))
    throw InputError("certify_shell: base and top must be n x 3 with the same n (got " + std::to_string(base.rows()) +
                     " and " + std::to_string(top.rows()) + " rows)");
  detail::check_triangle_mesh(base, F, "certify_shell (base)");
  detail::check_triangle_mesh(top, F, "certify_shell (top)");
  detail::check_distinct_corners(F, "certify_shell");
}

// Whether each of the three tets of the prism over face (a, b, c) is not positively oriented,
// its corners given base a, b, c, then top a, b, c.
std::array<bool, 3> inverted_in_prism(const double* const corner[6], int a, int b, int c) {
  const auto tets = prism_corner_tets(a, b, c);
  std::array<bool, 3> inverted;
  for (int t = 0; t < 3; ++t) {
    const auto& k = tets[t];
    inverted[t] = detail::orientation_sign(corner[k[0]], corner[k[1]], corner[k[2]], corner[k[3]]) <= 0;
  }
  return inverted;
}

// Tets (rows of build_prism_tets) whose exact orientation is not positive, ascending.
std::vector<int> inverted_tets(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top, const Eigen::MatrixXi& F) {
  using RowMajorPoints = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
  const RowMajorPoints B = base, T = top; // a vertex's coordinates in one cache line
  const int m = static_cast<int>(F.rows());
  std::vector<char> inverted(3 * static_cast<std::size_t>(m), 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, m, 4096), [&](const tbb::blocked_range<int>& r) {
    for (int f = r.begin(); f < r.end(); ++f) {
      const double* corner[6]; // prism corners: base in face order, then the tops
      for (int k = 0; k < 3; ++k) {
        corner[k] = B.row(F(f, k)).data();
        corner[k + 3] = T.row(F(f, k)).data();
      }
      const std::array<bool, 3> in_prism = inverted_in_prism(corner, F(f, 0), F(f, 1), F(f, 2));
      for (int t = 0; t < 3; ++t) inverted[3 * f + t] = in_prism[t];
    }
  });
  std::vector<int> ids;
  for (int t = 0; t < 3 * m; ++t)
    if (inverted[t]) ids.push_back(t);
  return ids;
}

// inverted_tets(base, top, F) from `previous`, those of a shell that differs from (base, top) at
// the shell vertices flagged in `moved` (base i is i, top i is n + i): only the tets of faces with
// a moved corner are tested again.
std::vector<int> inverted_tets_after_moves(const std::vector<int>& previous, const Eigen::MatrixXd& base,
                                           const Eigen::MatrixXd& top, const Eigen::MatrixXi& F,
                                           const std::vector<char>& moved) {
  const int n = static_cast<int>(base.rows()), m = static_cast<int>(F.rows());
  auto is_moved = [&](int f) {
    for (int k = 0; k < 3; ++k)
      if (moved[F(f, k)] || moved[n + F(f, k)]) return true;
    return false;
  };
  tbb::enumerable_thread_specific<std::vector<int>> found;
  tbb::parallel_for(tbb::blocked_range<int>(0, m, 4096), [&](const tbb::blocked_range<int>& r) {
    for (int f = r.begin(); f < r.end(); ++f) {
      if (!is_moved(f)) continue;
      double xyz[6][3]; // prism corners: base in face order, then the tops
      const double* corner[6];
      for (int k = 0; k < 6; ++k) {
        const Eigen::MatrixXd& V = k < 3 ? base : top;
        for (int d = 0; d < 3; ++d) xyz[k][d] = V(F(f, k % 3), d);
        corner[k] = xyz[k];
      }
      const std::array<bool, 3> in_prism = inverted_in_prism(corner, F(f, 0), F(f, 1), F(f, 2));
      for (int t = 0; t < 3; ++t)
        if (in_prism[t]) found.local().push_back(3 * f + t);
    }
  });
  std::vector<int> ids;
  for (int t : previous)
    if (!is_moved(t / 3)) ids.push_back(t);
  for (const std::vector<int>& part : found) ids.insert(ids.end(), part.begin(), part.end());
  std::sort(ids.begin(), ids.end());
  return ids;
}

IntersectionKind kind_of(BoundaryPart a, BoundaryPart b) {
  if (a == BoundaryPart::Wall || b == BoundaryPart::Wall) return IntersectionKind::Wall;
  if (a != b) return IntersectionKind::TopBase;
  return a == BoundaryPart::Top ? IntersectionKind::TopTop : IntersectionKind::BaseBase;
}

// c's pair counts and list from `pairs` (ascending rows a < b of `boundary`).
void set_intersections(ShellCertificate& c, const detail::FacePairs& pairs, const ShellBoundary& boundary,
                       const CertifyOptions& options) {
  c.top_self_intersections = c.top_base_intersections = c.wall_intersections = 0;
  c.base_self_intersections = options.base_self_intersections ? 0 : -1;
  c.intersections.clear();
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

namespace {

// A certifier's data (ShellCertifier::State), apart from the class so that
// certify_shell_keeping_trees can take its trees.
struct CertifierData {
  // What the pair tests need, set up at the first shell whose pairs are tested (the tets alone
  // need none of it).
  struct Pairs {
    ShellBoundary boundary;
    Eigen::MatrixXi base_rows, upper_rows; // rows of boundary.F: base faces, then top faces and walls
    detail::ShellStars stars;
    Eigen::MatrixXd X;          // 2n x 3: base, then top
    std::vector<char> embedded; // embedded_shell_stars of the shell being certified
    // Two trees, base rows and the rest (top and walls), so that base/base pairs cost nothing
    // when they are not wanted. Built for the first shell, refit for the next.
    std::optional<detail::FaceSet> base_set, upper_set;
    detail::ShellParts parts;

    Pairs(const Eigen::MatrixXi& F, int n)
        : boundary(shell_boundary(F, n)), base_rows(boundary.F.topRows(F.rows())),
          upper_rows(boundary.F.bottomRows(boundary.size() - F.rows())), stars(F, n),
          parts(detail::shell_parts(F, n)) {}
  };

  Eigen::MatrixXi F;
  int n = 0;
  std::unique_ptr<Pairs> pairs;
};

ShellCertificate certify_with(CertifierData& s, const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                              const CertifyOptions& options);

} // namespace

struct ShellCertifier::State : CertifierData {};

ShellCertifier::ShellCertifier(const Eigen::MatrixXi& F, int n) {
  detail::check_face_indices(F, n, "ShellCertifier");
  detail::check_distinct_corners(F, "ShellCertifier");
  state_ = std::make_unique<State>();
  state_->F = F;
  state_->n = n;
}

ShellCertifier::~ShellCertifier() = default;
ShellCertifier::ShellCertifier(ShellCertifier&&) noexcept = default;
ShellCertifier& ShellCertifier::operator=(ShellCertifier&&) noexcept = default;

ShellCertificate ShellCertifier::certify(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                                         const CertifyOptions& options) {
  return certify_with(*state_, base, top, options);
}

namespace {

ShellCertificate certify_with(CertifierData& s, const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                              const CertifyOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const int n = s.n, m = static_cast<int>(s.F.rows());
  for (const Eigen::MatrixXd* V : {&base, &top})
    if (V->rows() != n || V->cols() != 3 || !V->allFinite())
      throw InputError("ShellCertifier: base and top must be " + std::to_string(n) +
                       " x 3 with finite coordinates (got " + std::to_string(V->rows()) + " x " +
                       std::to_string(V->cols()) + (V->allFinite() ? ")" : ", not finite)"));

  ShellCertificate c;
  if (!options.test_intersections) {
    c.inverted_tet_ids = inverted_tets(base, top, s.F);
  } else {
    if (!s.pairs) s.pairs = std::make_unique<CertifierData::Pairs>(s.F, n);
    CertifierData::Pairs& p = *s.pairs;
    // Rows: base faces 0..m-1, then top faces, then walls.
    p.X.resize(2 * n, 3);
    p.X << base, top;
    p.embedded = p.stars.embedded(base, top, options.base_self_intersections);
    auto place = [&](std::optional<detail::FaceSet>& set, const Eigen::MatrixXi& rows) {
      if (set) set->move_to(p.X, rows, &p.embedded);
      else set.emplace(p.X, rows, &p.embedded);
    };
    tbb::parallel_invoke([&] { c.inverted_tet_ids = inverted_tets(base, top, s.F); },
                         [&] { place(p.base_set, p.base_rows); }, [&] { place(p.upper_set, p.upper_rows); });
    c.nested = detail::nested_probes(base, top, s.F, p.parts);
    c.nested_parts = static_cast<int>(c.nested.size());
    detail::PairCollector found;
    p.upper_set->for_each_pair_meeting_beyond_shared([&](int f, int g) { found.add(m + f, m + g); });
    p.upper_set->for_each_pair_meeting_beyond_shared(*p.base_set, [&](int f, int g) { found.add(g, m + f); });
    if (options.base_self_intersections)
      p.base_set->for_each_pair_meeting_beyond_shared([&](int f, int g) { found.add(f, g); });

    set_intersections(c, found.sorted(), p.boundary, options);
  }
  c.inverted_tets = static_cast<int>(c.inverted_tet_ids.size());
  c.seconds = seconds_since(t0);
  return c;
}

} // namespace

ShellCertificate detail::certify_shell_keeping_trees(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                                                     const Eigen::MatrixXi& F, const CertifyOptions& options,
                                                     std::optional<CertificateTrees>& trees) {
  const auto t0 = std::chrono::steady_clock::now();
  check_input(base, top, F);
  if (!options.test_intersections) throw InputError("certify_shell_keeping_trees: no trees without the pair tests");
  CertifierData s;
  s.F = F;
  s.n = static_cast<int>(base.rows());
  ShellCertificate c = certify_with(s, base, top, options);
  CertifierData::Pairs& p = *s.pairs;
  p.base_set->forget_stars(); // the flags are the certifier's, freed with it
  p.upper_set->forget_stars();
  trees.emplace(CertificateTrees{std::move(*p.base_set), std::move(*p.upper_set)});
  c.seconds = seconds_since(t0);
  return c;
}

ShellCertificate certify_shell(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top, const Eigen::MatrixXi& F,
                               const CertifyOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  check_input(base, top, F);
  ShellCertificate c = ShellCertifier(F, static_cast<int>(base.rows())).certify(base, top, options);
  c.seconds = seconds_since(t0);
  return c;
}

ShellCertificate recertify_shell(const ShellCertificate& previous, const Eigen::MatrixXd& previous_base,
                                 const Eigen::MatrixXd& previous_top, const Eigen::MatrixXd& base,
                                 const Eigen::MatrixXd& top, const Eigen::MatrixXi& F, const CertifyOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  check_input(base, top, F);
  const int n = static_cast<int>(base.rows());
  for (const Eigen::MatrixXd* V : {&previous_base, &previous_top})
    if (V->rows() != n || V->cols() != 3)
      throw InputError("recertify_shell: the previous shell must be " + std::to_string(n) + " x 3 like the new one");
  if (options.test_intersections &&
      (!previous.intersections_tested() || options.base_self_intersections != (previous.base_self_intersections >= 0)))
    throw InputError("recertify_shell: the previous certificate did not test the pairs these options ask for");

  // Shell vertices (base i is i, top i is n + i) whose position differs, compared exactly.
  std::vector<char> moved(2 * static_cast<std::size_t>(n), 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 4096), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i < r.end(); ++i) {
      moved[i] = (base.row(i).array() != previous_base.row(i).array()).any();
      moved[n + i] = (top.row(i).array() != previous_top.row(i).array()).any();
    }
  });
  ShellCertificate c;
  if (options.test_intersections && std::find(moved.begin(), moved.end(), 1) == moved.end()) {
    c = previous; // the same shell
    c.seconds = seconds_since(t0);
    return c;
  }
  c.inverted_tet_ids = inverted_tets_after_moves(previous.inverted_tet_ids, base, top, F, moved);
  c.inverted_tets = static_cast<int>(c.inverted_tet_ids.size());
  if (!options.test_intersections) {
    c.seconds = seconds_since(t0);
    return c;
  }
  const ShellBoundary boundary = shell_boundary(F, n);
  std::vector<int> changed; // rows with a moved vertex, ascending
  std::vector<char> is_changed(boundary.size(), 0);
  for (int r = 0; r < boundary.size(); ++r)
    if (moved[boundary.F(r, 0)] || moved[boundary.F(r, 1)] || moved[boundary.F(r, 2)]) {
      changed.push_back(r);
      is_changed[r] = 1;
    }
  // Previous verdicts on pairs of unchanged rows stand: both triangles are where they were.
  detail::FacePairs pairs;
  for (const BoundaryIntersection& p : previous.intersections)
    if (!is_changed[p.a] && !is_changed[p.b]) pairs.emplace_back(p.a, p.b);
  if (!changed.empty()) {
    Eigen::MatrixXd X(2 * n, 3);
    X << base, top;
    // The unchanged rows that can meet a changed one: those whose box meets a changed row's box,
    // as certify_shell's pair search would visit them; then the exact tests between the changed
    // rows and those.
    const std::vector<char> near = detail::rows_near(boundary, X, changed, 0);
    std::vector<int> near_rows;
    for (int r = 0; r < boundary.size(); ++r)
      if (near[r] && !is_changed[r]) near_rows.push_back(r);
    // Without star flags every pair is decided by the exact test itself (the flags only skip
    // pairs that test would clear).
    const detail::FaceSet changed_set(X, detail::rows_of(boundary.F, changed)),
        near_set(X, detail::rows_of(boundary.F, near_rows));
    auto wanted = [&](int a, int b) {
      return options.base_self_intersections || boundary.part[a] != BoundaryPart::Base ||
             boundary.part[b] != BoundaryPart::Base;
    };
    detail::PairCollector found;
    changed_set.for_each_pair_meeting_beyond_shared([&](int f, int g) {
      if (wanted(changed[f], changed[g])) found.add(std::min(changed[f], changed[g]), std::max(changed[f], changed[g]));
    });
    changed_set.for_each_pair_meeting_beyond_shared(near_set, [&](int f, int g) {
      const int a = changed[f], b = near_rows[g];
      if (wanted(a, b)) found.add(std::min(a, b), std::max(a, b));
    });
    const detail::FacePairs more = found.sorted();
    pairs.insert(pairs.end(), more.begin(), more.end());
    std::sort(pairs.begin(), pairs.end());
  }
  set_intersections(c, pairs, boundary, options);
  c.nested = detail::nested_probes(base, top, F, detail::shell_parts(F, n));
  c.nested_parts = static_cast<int>(c.nested.size());
  c.seconds = seconds_since(t0);
  return c;
}

} // namespace gshell
