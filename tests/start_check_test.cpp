// The guarded start's incremental checks (src/guard/start_check.h, internal to the library): after
// a first whole-shell check, a check given the moved top vertices finds exactly the violations of
// the whole shell's exact certificate that touch a moved vertex, although it moves only their
// faces in its tree. Motions here are random, large enough to invert tets and cross triangles,
// with vertices put back as the guard does and some moved without being flagged (the tree must
// follow them too).
#include "guard/start_check.h"

#include <gshell/geometry/builtin_mesh.h>
#include <gshell/quality/shell_certificate.h>
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
