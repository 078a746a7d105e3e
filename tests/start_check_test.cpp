// The guarded start's incremental checks (src/guard/start_check.h, internal to the library): after
// a first whole-shell check, a check given the moved top vertices finds exactly the violations of
// the whole shell's exact certificate that touch a moved vertex, although it moves only their
// faces in its tree. Motions here are random, large enough to invert tets and cross triangles,
// with vertices put back as the guard does and some moved without being flagged (the tree must
// follow them too).
#include "guard/start_check.h"

#include <gshell/geometry/builtin_mesh.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/quality/triangle_intersections.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>

#include <gtest/gtest.h>

#include <random>
#include <utility>
#include <vector>

using namespace gshell;

namespace {

struct Expected {
  std::vector<int> inverted_tets;
  std::vector<std::pair<int, int>> intersections;
};

// The whole shell's certificate, restricted to the tets and boundary rows with a flagged top vertex.
Expected brute_force(const TriMesh& m, const Eigen::MatrixXd& top, const std::vector<char>& moved,
                     const ShellBoundary& boundary) {
  const int n = static_cast<int>(m.V.rows());
  auto flagged = [&](int v) { return v >= n && moved[v - n]; };
  CertifyOptions options;
  options.base_self_intersections = false;
  const ShellCertificate c = certify_shell(m.V, top, m.F, options);
  const Eigen::MatrixXi T = build_prism_tets(m.F, n);
  auto row_flagged = [&](int r) {
    return flagged(boundary.F(r, 0)) || flagged(boundary.F(r, 1)) || flagged(boundary.F(r, 2));
  };
  Expected e;
  for (int t : c.inverted_tet_ids)
    if (flagged(T(t, 0)) || flagged(T(t, 1)) || flagged(T(t, 2)) || flagged(T(t, 3))) e.inverted_tets.push_back(t);
  for (const BoundaryIntersection& p : c.intersections)
    if (row_flagged(p.a) || row_flagged(p.b)) e.intersections.emplace_back(p.a, p.b);
  return e;
}

// Runs `rounds` random moves on the shell of m at thickness eta; returns the violations seen.
std::pair<int, int> run_random_moves(const TriMesh& m, double eta, double reach, int rounds) {
  const int n = static_cast<int>(m.V.rows());
  const Eigen::MatrixXd rest = offset_top(m.V, m.F, eta);
  Eigen::MatrixXd top = rest;
  const detail::StartChecker checker(m.F, n, {}, {});
  const detail::StartViolations first = checker.check(m.V, top);
  EXPECT_TRUE(first.certificate && first.inverted_tets.empty() && first.intersections.empty());

  std::mt19937 random(7);
  std::uniform_int_distribution<int> vertex(0, n - 1), count(1, 12);
  std::uniform_real_distribution<double> offset(-reach, reach);
  int inverted = 0, crossing = 0;
  std::vector<int> displaced;
  for (int round = 0; round < rounds; ++round) {
    std::vector<char> moved(n, 0);
    for (int k = count(random); k > 0; --k) {
      const int i = vertex(random);
      top.row(i) += Eigen::RowVector3d(offset(random), offset(random), offset(random));
      moved[i] = 1;
      displaced.push_back(i);
    }
    if (round % 3 == 2) // put some back, as settle does
      for (int k = 0; k < 4 && !displaced.empty(); ++k) {
        const int i = displaced.back();
        displaced.pop_back();
        top.row(i) = rest.row(i);
        moved[i] = 1;
      }
    if (round % 4 == 3) { // a vertex moved without a flag: tested only against flagged ones
      const int i = vertex(random);
      top.row(i) += Eigen::RowVector3d(offset(random), offset(random), offset(random));
    }
    const detail::StartViolations found = checker.check(m.V, top, &moved);
    const Expected want = brute_force(m, top, moved, checker.boundary());
    EXPECT_EQ(found.inverted_tets, want.inverted_tets) << "round " << round;
    EXPECT_EQ(found.intersections, want.intersections) << "round " << round;
    inverted += static_cast<int>(want.inverted_tets.size());
    crossing += static_cast<int>(want.intersections.size());
  }
  return {inverted, crossing};
}

} // namespace

TEST(StartCheck, IncrementalChecksFindTheCertificatesViolationsAtMovedVerticesOnAClosedShell) {
  const auto [inverted, crossing] = run_random_moves(make_torus(32, 1.0, 0.4), 0.1, 0.3, 40);
  EXPECT_GT(inverted, 0) << "the motions no longer invert tets: the test shows nothing";
  EXPECT_GT(crossing, 0) << "the motions no longer cross triangles: the test shows nothing";
}

TEST(StartCheck, IncrementalChecksFindTheCertificatesViolationsAtMovedVerticesOnAnOpenShell) {
  // An open tube: its walls are boundary rows too, and pairs with them are counted the same.
  const auto [inverted, crossing] = run_random_moves(make_cylinder(24, 0.5, 1.0), 0.08, 0.25, 40);
  EXPECT_GT(inverted, 0);
  EXPECT_GT(crossing, 0);
}

// Guarded generation runs the first check in two parts: it certifies the paper's top and finds
// the base's own crossings, excludes the triangles around the crossings found, then makes the check's
// violations. That must find the crossings the base's own test finds and leave every check as a
// checker given those exclusions up front makes them.
TEST(StartCheck, AFirstCheckWithTheBasesOwnPairsFindsItsCrossingsAndChecksAsBefore) {
  TriMesh m = make_sphere(3);
  m.V.row(0) *= -1.3; // through the centre and out of the far side: the base crosses itself
  const int n = static_cast<int>(m.V.rows());
  const Eigen::MatrixXd top = offset_top(m.V, m.F, 0.05);

  detail::StartChecker two_parts(m.F, n, {}, {});
  std::vector<std::pair<int, int>> crossings;
  const ShellCertificate with_pairs = two_parts.certify(m.V, top, &crossings);
  ASSERT_FALSE(crossings.empty());
  EXPECT_EQ(crossings, surface_self_intersections(m.V, m.F));

  // Rows of the faces with a corner on a crossing face, as generation excludes them.
  std::vector<char> corner(n, 0);
  for (const auto& [f, g] : crossings)
    for (int k = 0; k < 3; ++k) corner[m.F(f, k)] = corner[m.F(g, k)] = 1;
  const ShellBoundary& boundary = two_parts.boundary();
  std::vector<char> excluded(boundary.size(), 0);
  for (int r = 0; r < boundary.size(); ++r) {
    const int f = boundary.face[r];
    excluded[r] = corner[m.F(f, 0)] || corner[m.F(f, 1)] || corner[m.F(f, 2)];
  }
  two_parts.exclude_triangles(excluded);
  const detail::StartViolations a = two_parts.violations(with_pairs);
  const detail::StartChecker up_front(m.F, n, {}, excluded);
  const detail::StartViolations b = up_front.check(m.V, top);
  auto expect_same = [](const detail::StartViolations& x, const detail::StartViolations& y) {
    EXPECT_EQ(x.inverted_tets, y.inverted_tets);
    EXPECT_EQ(x.intersections, y.intersections);
    EXPECT_EQ(x.nested_parts, y.nested_parts);
  };
  expect_same(a, b);
  ASSERT_TRUE(a.certificate && b.certificate);
  EXPECT_GT(a.certificate->top_base_intersections, 0); // the pushed vertex's top: all of them excluded
  EXPECT_EQ(a.certificate->base_self_intersections, -1); // as if the base's pairs were not searched
  EXPECT_EQ(a.certificate->top_self_intersections, b.certificate->top_self_intersections);
  EXPECT_EQ(a.certificate->top_base_intersections, b.certificate->top_base_intersections);
  EXPECT_EQ(a.certificate->inverted_tet_ids, b.certificate->inverted_tet_ids);
  ASSERT_EQ(a.certificate->intersections.size(), b.certificate->intersections.size());
  for (std::size_t k = 0; k < a.certificate->intersections.size(); ++k) {
    EXPECT_EQ(a.certificate->intersections[k].a, b.certificate->intersections[k].a);
    EXPECT_EQ(a.certificate->intersections[k].b, b.certificate->intersections[k].b);
  }

  // The later checks keep the trees of the first and the exclusions given after it.
  Eigen::MatrixXd moved_top = top;
  std::vector<char> moved(n, 0);
  for (int i = 0; i < n; i += 7) {
    moved_top.row(i) = m.V.row(i) - 0.5 * (top.row(i) - m.V.row(i)); // below the base: inverts its tets
    moved[i] = 1;
  }
  const detail::StartViolations a2 = two_parts.check(m.V, moved_top, &moved);
  EXPECT_FALSE(a2.inverted_tets.empty());
  expect_same(a2, up_front.check(m.V, moved_top, &moved));
}
