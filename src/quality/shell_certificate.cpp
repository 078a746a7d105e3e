#include <gshell/quality/shell_certificate.h>

#include <gshell/error.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/seconds_since.h>
#include <gshell/shell/prism_tets.h>

#include "quality/check_mesh_input.h"
#include "quality/embedded_stars.h"
#include "quality/face_pair_search.h"
#include "quality/filtered_orientation.h"
#include "quality/nested_parts.h"

#include <tbb/parallel_invoke.h>

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
      const auto tets = prism_corner_tets(F(f, 0), F(f, 1), F(f, 2));
      for (int t = 0; t < 3; ++t) {
        const auto& c = tets[t];
        inverted[3 * f + t] = detail::orientation_sign(corner[c[0]], corner[c[1]], corner[c[2]], corner[c[3]]) <= 0;
      }
    }
  });
  std::vector<int> ids;
  for (int t = 0; t < 3 * m; ++t)
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

struct ShellCertifier::State {
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
  const auto t0 = std::chrono::steady_clock::now();
  State& s = *state_;
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
    if (!s.pairs) s.pairs = std::make_unique<State::Pairs>(s.F, n);
    State::Pairs& p = *s.pairs;
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

    c.top_self_intersections = c.top_base_intersections = c.wall_intersections = 0;
    c.base_self_intersections = options.base_self_intersections ? 0 : -1;
    const detail::FacePairs pairs = found.sorted();
    c.intersections.reserve(pairs.size());
    for (const auto& [a, b] : pairs) {
      const IntersectionKind kind = kind_of(p.boundary.part[a], p.boundary.part[b]);
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

} // namespace gshell
