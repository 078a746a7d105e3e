// Guarded generation (guard/guarded_shell.h through generate_shell): cases where the paper's
// unguarded result inverts tets or intersects itself come out valid, checked by certifying the
// returned top from scratch with exact predicates, and as thick as the space allows; where the
// unguarded result is valid the guard leaves it alone; allow_invalid is the unguarded path bit for
// bit.
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/error.h>
#include <gshell/guard/guarded_shell.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/quality/shell_metrics.h>
#include <gshell/quality/stretch.h>
#include <gshell/shell/generate_report.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/shell_solver.h>

#include "shell_fixtures.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>
#include <string>
#include <vector>

using namespace gshell;

namespace {

GenerateOptions options_for(ShellMethod method, double eta, bool allow_invalid = false) {
  GenerateOptions o;
  o.method = method;
  o.thickness = eta;
  o.allow_invalid = allow_invalid;
  return o;
}

// The exact certificate of the returned shell, computed here again (not the result's own).
ShellCertificate recertify(const GenerateResult& r) { return certify_shell(r.shell.base, r.shell.top, r.shell.F); }

void expect_valid(const GenerateResult& r) {
  const ShellCertificate c = recertify(r);
  EXPECT_EQ(c.inverted_tets, 0);
  EXPECT_EQ(c.top_self_intersections, 0);
  EXPECT_EQ(c.top_base_intersections, 0);
  EXPECT_EQ(c.wall_intersections, 0);
  EXPECT_EQ(c.nested_parts, 0);
  EXPECT_EQ(c.base_self_intersections, 0);
  EXPECT_TRUE(r.metrics.certificate.valid());
  EXPECT_TRUE(r.guarded);
  EXPECT_EQ(r.metrics.certificate.inverted_tets, c.inverted_tets);
}

bool invalid(const GenerateResult& r) { return !recertify(r).valid(); }

// A sphere with random radial bumps of up to `amplitude` (relative), fixed seed: still star-shaped,
// so the base does not intersect itself.
TriMesh bumpy_sphere(int level, double amplitude) {
  TriMesh m = make_sphere(level, 1.0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-amplitude, amplitude);
  for (int i = 0; i < m.V.rows(); ++i) m.V.row(i) *= 1 + u(rng);
  return m;
}

// make_plane(8) and the same plane turned about the x axis, crossing the first.
TriMesh crossing_planes() {
  TriMesh crossing = make_plane(8), upright = crossing;
  upright.V.col(2) = upright.V.col(1);
  upright.V.col(1).setZero();
  const int n = static_cast<int>(crossing.V.rows());
  crossing.V.conservativeResize(2 * n, 3);
  crossing.V.bottomRows(n) = upright.V;
  crossing.F.conservativeResize(2 * upright.F.rows(), 3);
  crossing.F.bottomRows(upright.F.rows()) = upright.F.array() + n;
  return crossing;
}

} // namespace

TEST(GuardedGeneration, MakePlaneFacesUp) {
  // The fixtures below rely on make_plane's normals being +z.
  const TriMesh p = make_plane(2);
  const Eigen::Vector3d a = p.V.row(p.F(0, 0)), b = p.V.row(p.F(0, 1)), c = p.V.row(p.F(0, 2));
  EXPECT_GT((b - a).cross(c - a).z(), 0);
}

TEST(GuardedGeneration, TightVFoldIsValidAndThickWhereTheVOpens) {
  const TriMesh m = test::folded_plane(12, 30);
  const double eta = 0.1;
  for (ShellMethod method : {ShellMethod::Rigid, ShellMethod::Curvature}) {
    SCOPED_TRACE(to_string(method));
    ASSERT_TRUE(invalid(generate_shell(m.V, m.F, options_for(method, eta, true)))) << "the case no longer fails unguarded";
    const GenerateResult g = generate_shell(m.V, m.F, options_for(method, eta));
    expect_valid(g);
    // At the open end the two halves are 2 sin(15 deg) ~ 0.52 apart: room for the full thickness.
    for (int i = 0; i < m.V.rows(); ++i)
      if (std::abs(m.V(i, 0)) > 0.25 && std::abs(m.V(i, 1)) < 0.8) EXPECT_GT(g.metrics.vertex_thickness[i], 0.8) << i;
    EXPECT_GT(g.metrics.thinned_vertices, 0); // the crease has no room
    // The repair ran, and its guarded energy never rose.
    const std::vector<double>& E = g.guard.solve.energy;
    ASSERT_GT(E.size(), 1u);
    for (std::size_t k = 1; k < E.size(); ++k) EXPECT_LE(E[k], E[k - 1]) << "iteration " << k;
  }
}

TEST(GuardedGeneration, SheetsCloserThanTwiceTheThicknessMeetHalfway) {
  const double eta = 0.2, gap = 0.3;
  const TriMesh m = test::facing_sheets(10, gap);
  ASSERT_TRUE(invalid(generate_shell(m.V, m.F, options_for(ShellMethod::Rigid, eta, true))));
  const GenerateResult g = generate_shell(m.V, m.F, options_for(ShellMethod::Rigid, eta));
  expect_valid(g);
  // Each top gets at most half the gap; the guard gives away little of it.
  for (int i = 0; i < m.V.rows(); ++i) {
    const double lift = std::abs(g.shell.top(i, 2) - m.V(i, 2));
    EXPECT_LT(lift, 0.5 * gap) << i;
    EXPECT_GT(lift, 0.3 * gap) << i;
  }
}

TEST(GuardedGeneration, TorusThickerThanItsHoleThinsOnlyInTheHole) {
  const double R = 1.0, r = 0.4, eta = 0.7; // the hole's radius R - r = 0.6 < eta
  const TriMesh m = make_torus(24, R, r);
  for (ShellMethod method : {ShellMethod::Rigid, ShellMethod::Curvature}) {
    SCOPED_TRACE(to_string(method));
    const GenerateResult g = generate_shell(m.V, m.F, options_for(method, eta));
    expect_valid(g);
    // The top stays out of the axis' neighbourhood it cannot all share, and on the outer
    // equator (room everywhere) it is as thick as the unguarded result.
    const GenerateResult u = generate_shell(m.V, m.F, options_for(method, eta, true));
    for (int i = 0; i < m.V.rows(); ++i) {
      const double radial = m.V.row(i).head<2>().norm();
      if (radial > R + 0.9 * r) EXPECT_NEAR(g.metrics.vertex_thickness[i], u.metrics.vertex_thickness[i], 0.05) << i;
    }
  }
}

TEST(GuardedGeneration, ProgressNamesEachStageAndCountsItsIterationsFromOne) {
  // A log of a guarded run read "iteration 13 ... iteration 1 ... iteration 50 ... iteration 1":
  // three solves, unnamed. Every stage is now named before its iterations, and the iterations
  // shown under each name are exactly that stage's.
  const TriMesh m = bumpy_sphere(3, 0.4); // inverts unguarded: the repair runs
  GenerateOptions o = options_for(ShellMethod::Rigid, thickness_from_ratio(m.V, 0.05));
  std::vector<std::string> stages;
  std::vector<std::vector<int>> seen;
  o.solve.stage = [&](const char* name) {
    stages.emplace_back(name);
    seen.emplace_back();
  };
  o.solve.progress = [&](int it, double, double) {
    ASSERT_FALSE(seen.empty()) << "an iteration before any stage was named";
    seen.back().push_back(it);
  };
  const GenerateResult g = generate_shell(m.V, m.F, o);
  ASSERT_GT(g.guard.repaired_vertices, 0);
  // The phases without iterations are named too, as they begin (at millions of faces they take
  // tens of seconds a progress display would otherwise leave silent).
  ASSERT_EQ(stages, (std::vector<std::string>{"setup", "factor", "paper", "start", "repair", "relax", "metrics",
                                              "certificate"}));
  const std::map<std::string, int> counts = {{"paper", g.guard.paper.iterations},
                                             {"repair", g.guard.solve.iterations},
                                             {"relax", g.guard.relax.iterations}};
  for (std::size_t k = 0; k < stages.size(); ++k) {
    SCOPED_TRACE(stages[k]);
    const auto count = counts.find(stages[k]);
    if (count == counts.end()) {
      EXPECT_TRUE(seen[k].empty());
      continue;
    }
    ASSERT_GT(count->second, 0);
    std::vector<int> expected(count->second);
    std::iota(expected.begin(), expected.end(), 1); // generation relaxes in one round
    EXPECT_EQ(seen[k], expected);
  }
  // The other methods name theirs: the curvature prisms, the unguarded run's paper iterations.
  stages.clear();
  seen.clear();
  o.method = ShellMethod::Curvature;
  o.allow_invalid = true;
  generate_shell(m.V, m.F, o);
  EXPECT_EQ(stages,
            (std::vector<std::string>{"curvature prisms", "setup", "factor", "paper", "metrics", "certificate"}));
  stages.clear();
  o.method = ShellMethod::Offset;
  o.allow_invalid = false;
  generate_shell(m.V, m.F, o);
  EXPECT_EQ(stages, (std::vector<std::string>{"metrics", "certificate"}));
}

TEST(GuardedGeneration, WhatAStartThatGivesUpStaysOutOfTheGuardAndAloneInvalid) {
  // A start that gives up (on real input only a degenerate base makes it: a rim folded flat onto
  // its neighbours) leaves its unmended tets and boundary pairs out of the guard, so that the
  // guarded solver still starts valid for its barriers. Forced here on a bumpy sphere whose
  // unguarded shell inverts and intersects, by allowing the start two rounds (one thinning): the
  // repair then runs beside what was handed over, every tet and pair left invalid must be one the
  // start handed over, everything else certifies clean, and the warning says so.
  const TriMesh m = bumpy_sphere(3, 0.4);
  GenerateOptions o = options_for(ShellMethod::Rigid, thickness_from_ratio(m.V, 0.05));
  o.guard.start_max_rounds = 2;
  const GenerateResult g = generate_shell(m.V, m.F, o);
  ASSERT_TRUE(g.guarded);
  const std::vector<int>& handed = g.guard.start.inverted_tets; // ascending, as the checker reports them
  ASSERT_FALSE(handed.empty() || g.guard.start.intersections.empty()) << "want both tets and pairs handed over";
  EXPECT_GT(g.guard.repaired_vertices, 0);
  const ShellCertificate c = recertify(g);
  EXPECT_EQ(c.base_self_intersections, 0);
  for (int t : c.inverted_tet_ids)
    EXPECT_TRUE(std::binary_search(handed.begin(), handed.end(), t)) << "tet " << t << " inverted but guarded";
  for (const BoundaryIntersection& p : c.intersections)
    EXPECT_TRUE(g.guard.unprotected_triangles[p.a] || g.guard.unprotected_triangles[p.b])
        << "rows " << p.a << ", " << p.b << " intersect but were guarded";
  EXPECT_FALSE(g.metrics.certificate.valid());
  const std::vector<std::string> w = generate_warnings(g);
  EXPECT_TRUE(std::any_of(w.begin(), w.end(), [](const std::string& s) {
    return s.find("the valid start could not mend") != std::string::npos;
  }));
  // With every round it needs, the start mends the same input (the cap alone made it give up).
  o.guard.start_max_rounds = GuardOptions{}.start_max_rounds;
  expect_valid(generate_shell(m.V, m.F, o));
}

TEST(GuardedGeneration, SphereAtHalfItsRadiusIsValid) {
  const TriMesh m = make_sphere(3, 1.0);
  const double eta = thickness_from_ratio(m.V, 0.5);
  for (ShellMethod method : {ShellMethod::Rigid, ShellMethod::Curvature}) {
    SCOPED_TRACE(to_string(method));
    expect_valid(generate_shell(m.V, m.F, options_for(method, eta)));
    // Nothing collides on a convex surface: the guard keeps the paper's result (compared with the
    // paper's plain iteration from the offset surface, which the unguarded path runs).
    GenerateOptions plain = options_for(method, eta);
    plain.solve.anderson_history = 0;
    plain.guard.start_smoothing = 0;
    const GenerateResult g = generate_shell(m.V, m.F, plain);
    expect_valid(g);
    const GenerateResult u = generate_shell(m.V, m.F, options_for(method, eta, true));
    // (Not bit for bit: under load the two runs have differed in the last bits; a guard that
    // acted would move tops by a fraction of eta.)
    EXPECT_LT((g.shell.top - u.shell.top).cwiseAbs().maxCoeff(), 1e-9 * eta);
  }
}

TEST(GuardedGeneration, BumpySphereThatInvertsUnguardedComesOutValid) {
  const TriMesh m = bumpy_sphere(3, 0.25);
  const double eta = thickness_from_ratio(m.V, 0.05);
  for (ShellMethod method : {ShellMethod::Rigid, ShellMethod::Curvature}) {
    SCOPED_TRACE(to_string(method));
    const GenerateResult u = generate_shell(m.V, m.F, options_for(method, eta, true));
    ASSERT_GT(recertify(u).inverted_tets, 0) << "the case no longer inverts unguarded";
    const GenerateResult g = generate_shell(m.V, m.F, options_for(method, eta));
    expect_valid(g);
    // Thinning is local: the top keeps most of the unguarded result's thickness (distance to the
    // base surface, already below eta between the bumps).
    EXPECT_GT(g.metrics.thickness_mean, 0.9 * u.metrics.thickness_mean);
  }
}

TEST(GuardedGeneration, PlaneAndCylinderKeepThePaperResult) {
  for (const TriMesh& m : {make_plane(16), make_cylinder(24)}) {
    const double eta = thickness_from_ratio(m.V, 0.05);
    const GenerateResult g = generate_shell(m.V, m.F, options_for(ShellMethod::Rigid, eta));
    expect_valid(g);
    EXPECT_EQ(g.metrics.thinned_vertices, 0);
    EXPECT_EQ(g.guard.repaired_vertices, 0);
  }
}

// Every field of two certificates but the time.
void expect_same_certificate(const ShellCertificate& a, const ShellCertificate& b) {
  EXPECT_EQ(a.inverted_tets, b.inverted_tets);
  EXPECT_EQ(a.top_self_intersections, b.top_self_intersections);
  EXPECT_EQ(a.top_base_intersections, b.top_base_intersections);
  EXPECT_EQ(a.wall_intersections, b.wall_intersections);
  EXPECT_EQ(a.base_self_intersections, b.base_self_intersections);
  EXPECT_EQ(a.inverted_tet_ids, b.inverted_tet_ids);
  ASSERT_EQ(a.intersections.size(), b.intersections.size());
  for (std::size_t k = 0; k < a.intersections.size(); ++k) {
    EXPECT_EQ(a.intersections[k].a, b.intersections[k].a) << k;
    EXPECT_EQ(a.intersections[k].b, b.intersections[k].b) << k;
  }
}

TEST(GuardedGeneration, TopNeedingNoMendingCarriesTheCertificateOfItsFirstCheck) {
  // Where the start's first check finds nothing to mend, the result is the paper's top and the
  // certificate that check computed is reported instead of a second run: it must be the one a
  // fresh certification of the returned shell gives, field by field. The crossing planes have
  // violations the guard leaves alone (around the base's own crossing), so their certificate is
  // not empty.
  const TriMesh crossing = crossing_planes();
  for (const TriMesh& m : {make_sphere(3, 1.0), make_cylinder(24), crossing}) {
    const GenerateResult g = generate_shell(m.V, m.F, options_for(ShellMethod::Rigid, thickness_from_ratio(m.V, 0.02)));
    ASSERT_EQ(g.guard.start.rounds, 1);
    ASSERT_EQ(g.guard.repaired_vertices, 0);
    EXPECT_TRUE((g.guard.start.scale.array() == 1).all());
    // A guarded result lists the shell's pairs, not the base's own (those are counted only).
    CertifyOptions shell_pairs;
    shell_pairs.base_self_intersections = false;
    ShellCertificate expected = certify_shell(g.shell.base, g.shell.top, g.shell.F, shell_pairs);
    expected.base_self_intersections = recertify(g).base_self_intersections;
    expect_same_certificate(g.metrics.certificate, expected);
  }
  EXPECT_GT(generate_shell(crossing.V, crossing.F, options_for(ShellMethod::Rigid, thickness_from_ratio(crossing.V, 0.02)))
                .metrics.certificate.base_self_intersections,
            0);
}

TEST(GuardedGeneration, AMendedTopIsCertifiedAsAFreshCertificateWould) {
  // Where the start thins, repairs and lifts, the result's certificate is made from the first
  // check's (of the paper's top, which had violations) by testing again only what moved
  // (recertify_shell): it must be a fresh certification's, field by field. The crossing planes
  // keep the pairs near their crossing, which the guard leaves alone: a certificate not empty.
  const TriMesh crossing = crossing_planes();
  struct Case {
    TriMesh mesh;
    double eta;
  };
  int leftover_pairs = 0, mended = 0;
  const TriMesh bumpy = bumpy_sphere(3, 0.25);
  for (const Case& c : {Case{test::folded_plane(12, 30), 0.1}, Case{bumpy, thickness_from_ratio(bumpy.V, 0.05)},
                        Case{test::facing_sheets(10, 0.3), 0.2}, Case{crossing, 0.3}}) {
    const GenerateResult g = generate_shell(c.mesh.V, c.mesh.F, options_for(ShellMethod::Rigid, c.eta));
    ASSERT_TRUE(g.guard.start.certificate);
    SCOPED_TRACE(std::to_string(c.mesh.V.rows()) + " vertices");
    ASSERT_FALSE(g.guard.start.certificate->valid()); // the paper's top needed mending
    mended += g.shell.top != g.guard.paper_top;
    CertifyOptions shell_pairs;
    shell_pairs.base_self_intersections = false;
    ShellCertificate expected = certify_shell(g.shell.base, g.shell.top, g.shell.F, shell_pairs);
    expected.base_self_intersections = recertify(g).base_self_intersections;
    expect_same_certificate(g.metrics.certificate, expected);
    leftover_pairs += static_cast<int>(expected.intersections.size());
  }
  EXPECT_EQ(mended, 3); // all but the crossing planes, whose violations the guard leaves alone
  EXPECT_GT(leftover_pairs, 0);
}

TEST(GuardedGeneration, AllowInvalidIsThePapersUnguardedSolveBitForBit) {
  // The unguarded path written out: rest tets of the normal prisms, base held, top from the
  // offset surface, the paper's plain local/global iterations (generation's Anderson default
  // and the early CG stop are for the guarded path), on both linear paths.
  const TriMesh m = bumpy_sphere(3, 0.25);
  const double eta = thickness_from_ratio(m.V, 0.05);
  const int n = static_cast<int>(m.V.rows());
  const RestTets rest = normal_prism_rest_tets(m.V, m.F, eta);
  GenerateOptions o = options_for(ShellMethod::Rigid, eta, true);
  ASSERT_GT(o.solve.anderson_history, 0); // the default the unguarded path must not take
  for (const LinearSolver kind : {LinearSolver::Direct, LinearSolver::ConjugateGradient}) {
    LinearSolverOptions exact;
    exact.kind = kind;
    exact.cg_relative_tolerance = 0;
    const ShellSolver solver(rest, 2 * n, test::vertex_range(0, n), {}, exact);
    Eigen::MatrixXd X(2 * n, 3);
    X << m.V, offset_top(m.V, m.F, eta);
    SolveOptions plain;
    plain.max_iterations = o.solve.max_iterations;
    plain.tolerance = o.solve.tolerance;
    const SolveResult s = solver.solve(X, plain);
    o.linear.kind = kind;
    const GenerateResult u = generate_shell(m.V, m.F, o);
    EXPECT_TRUE(u.shell.top == X.bottomRows(n)) << (kind == LinearSolver::Direct ? "direct" : "cg");
    EXPECT_EQ(u.solve.energy, s.energy);
  }
  o.linear.kind = LinearSolver::Auto;
  const GenerateResult u = generate_shell(m.V, m.F, o);
  EXPECT_FALSE(u.guarded);
  EXPECT_FALSE(u.metrics.certificate.valid()); // this case inverts: the flag says so
  EXPECT_EQ(u.metrics.certificate.inverted_tets, recertify(u).inverted_tets);
}

TEST(GuardedGeneration, EveryMethodMeasuresItsShellAsShellMetricsWould) {
  // Generation measures its result without shell_metrics' own certificate and certifies it in a
  // step of its own (from the guard's first check when guarded): the report must still be the
  // one shell_metrics gives of the same shell, the unguarded certificate's tets-only form and
  // counted form included. The bumpy sphere inverts tets unguarded, so that form is not empty.
  const TriMesh m = bumpy_sphere(3, 0.25);
  const double eta = thickness_from_ratio(m.V, 0.05);
  int inverted_unguarded = 0;
  for (const ShellMethod method : {ShellMethod::Offset, ShellMethod::Rigid, ShellMethod::Curvature})
    for (const bool allow_invalid : {false, true})
      for (const bool count : {false, true}) {
        GenerateOptions o = options_for(method, eta, allow_invalid);
        o.count_intersections = count;
        const GenerateResult r = generate_shell(m.V, m.F, o);
        SCOPED_TRACE(to_string(method) + (allow_invalid ? " unguarded" : "") + (count ? " counted" : ""));
        // A guarded result is always tested in full.
        const ShellMetrics expected = shell_metrics(m.V, m.F, r.shell.top, eta, count || r.guarded);
        EXPECT_TRUE(r.metrics.tet_stretch == expected.tet_stretch);
        EXPECT_TRUE(r.metrics.tet_determinant == expected.tet_determinant);
        EXPECT_TRUE(r.metrics.vertex_thickness == expected.vertex_thickness);
        EXPECT_EQ(r.metrics.stretch.volume_mean, expected.stretch.volume_mean);
        EXPECT_EQ(r.metrics.stretch.p99, expected.stretch.p99);
        EXPECT_EQ(r.metrics.thinned_vertices, expected.thinned_vertices);
        EXPECT_EQ(r.metrics.thickness_min, expected.thickness_min);
        EXPECT_EQ(r.metrics.thickness_mean, expected.thickness_mean);
        expect_same_certificate(r.metrics.certificate, expected.certificate);
        if (!r.guarded) inverted_unguarded += r.metrics.certificate.inverted_tets;
        EXPECT_GE(r.seconds.metrics, 0);
      }
  EXPECT_GT(inverted_unguarded, 0);
}

TEST(GuardedGeneration, IdealTetsMadeOnDemandGiveTheSameShellBitForBit) {
  // Given a function that makes the ideal tets, guarded_shell lets go of them through the start's
  // certificate and makes them again only where the start thinned a top: the same shell as given
  // the tets, with one call where nothing is thinned and two where the repair runs.
  struct Case {
    TriMesh mesh;
    double ratio;
    bool thinned;
  };
  for (const Case& c : {Case{make_sphere(3, 1.0), 0.02, false}, Case{bumpy_sphere(3, 0.25), 0.05, true}}) {
    const Eigen::MatrixXd& V = c.mesh.V;
    const Eigen::MatrixXi& F = c.mesh.F;
    const double eta = thickness_from_ratio(V, c.ratio);
    auto make = [&] { return prism_rest_tets(F, static_cast<int>(V.rows()), normal_prisms(V, F, eta)); };
    const GuardOptions options = generation_guard_options();
    const RestTets rest = make();
    const GuardedShell given = guarded_shell(V, F, rest, eta, options, {});
    int calls = 0;
    const GuardedShell made = guarded_shell(V, F, [&] { ++calls; return make(); }, eta, options, {});
    EXPECT_EQ(given.repaired_vertices > 0, c.thinned);
    EXPECT_EQ(calls, c.thinned ? 2 : 1);
    EXPECT_TRUE(made.top == given.top);
    EXPECT_EQ(made.repaired_vertices, given.repaired_vertices);
    EXPECT_EQ(made.solve.iterations, given.solve.iterations);
    EXPECT_EQ(made.lift.moves, given.lift.moves);
  }
}

TEST(GuardedGeneration, AFirstTopAtThePapersMinimumLeavesItNothingToDo) {
  // The deformer regenerates a frame from that frame's own solve: started at the paper's minimum,
  // the paper's iterations stop at once, and the guard mends the top as it does from the offset.
  const TriMesh m = bumpy_sphere(3, 0.25);
  const int n = static_cast<int>(m.V.rows());
  const double eta = thickness_from_ratio(m.V, 0.05);
  const RestTets rest = normal_prism_rest_tets(m.V, m.F, eta);
  SolveOptions solve;
  solve.tolerance = 1e-8;
  solve.max_iterations = 1000;
  const ShellSolver paper(rest, 2 * n, test::vertex_range(0, n));
  Eigen::MatrixXd X(2 * n, 3);
  X << m.V, offset_top(m.V, m.F, eta);
  const SolveResult minimum = paper.solve(X, solve);
  ASSERT_GT(minimum.iterations, 5);
  const GuardOptions options = generation_guard_options();
  const GuardedShell from_offset = guarded_shell(m.V, m.F, rest, eta, options, solve);
  const GuardedShell from_minimum = guarded_shell(m.V, m.F, rest, eta, options, solve, {}, X.bottomRows(n));
  EXPECT_GT(from_offset.paper.iterations, 5);
  EXPECT_LE(from_minimum.paper.iterations, 2);
  EXPECT_GT(from_minimum.repaired_vertices, 0); // this case inverts unguarded
  EXPECT_TRUE(certify_shell(m.V, from_minimum.top, m.F).valid());
  EXPECT_THROW(guarded_shell(m.V, m.F, rest, eta, options, solve, {}, Eigen::MatrixXd::Zero(n - 1, 3)), InputError);
}

TEST(GuardedGeneration, SmoothedStartIsAheadAtEveryIterationOnASplitMesh) {
  // A bumpy sphere split at its edges' midpoints twice: flat at the coarse faces, so its vertex
  // normals jump at the coarse edges, at a thickness of a few fine edges. The paper's iterations
  // smooth those jumps over about the thickness, a face or so per iteration; started from normals
  // already smoothed (GuardOptions::start_smoothing) they are ahead from the first iterate on and
  // end at the same minimum. The plain iteration (no Anderson) makes the comparison iterate by
  // iterate.
  const TriMesh m = midpoint_subdivision(bumpy_sphere(3, 0.1), 2);
  GenerateOptions o = options_for(ShellMethod::Rigid, thickness_from_ratio(m.V, 0.1));
  o.solve.anderson_history = 0;
  o.guard.start_smoothing = 0;
  const GenerateResult raw = generate_shell(m.V, m.F, o);
  o.guard.start_smoothing = generation_guard_options().start_smoothing;
  ASSERT_GT(o.guard.start_smoothing, 0);
  const GenerateResult smoothed = generate_shell(m.V, m.F, o);
  EXPECT_GT(smoothed.guard.smoothing.iterations, 0);
  const std::vector<double>&Er = raw.solve.energy, &Es = smoothed.solve.energy;
  for (std::size_t k = 0; k < std::min(Er.size(), Es.size()); ++k) EXPECT_LT(Es[k], Er[k]) << "iteration " << k;
  EXPECT_LT(smoothed.solve.iterations, raw.solve.iterations);
  EXPECT_NEAR(Es.back(), Er.back(), 1e-4 * Er.back());
  expect_valid(raw);
  expect_valid(smoothed);
  // The unguarded paper result keeps the offset start (allow_invalid: the paper bit for bit).
  o.allow_invalid = true;
  EXPECT_EQ(generate_shell(m.V, m.F, o).solve.energy.front(), Er.front());
}

TEST(GuardedGeneration, SameBitsWithOneThreadAndMany) {
  // The repair's step bounds and sums do not depend on the thread schedule: a case that needs the
  // repair gives the same top with one thread as with all of them.
  const TriMesh m = bumpy_sphere(3, 0.25);
  const GenerateOptions o = options_for(ShellMethod::Rigid, thickness_from_ratio(m.V, 0.05));
  const GenerateResult many = generate_shell(m.V, m.F, o);
  ASSERT_GT(many.guard.repaired_vertices, 0);
  ASSERT_GT(many.guard.solve.iterations, 1);
  GenerateResult one;
  tbb::task_arena(1).execute([&] { one = generate_shell(m.V, m.F, o); });
  EXPECT_EQ(one.guard.solve.iterations, many.guard.solve.iterations);
  EXPECT_TRUE(one.shell.top == many.shell.top);
}

TEST(GuardedGeneration, TopsPulledOntoTheBaseAreHeldThere) {
  // Two sheets 0.01 eta apart: the start pulls the tops to a few 1e-5 of their offset, closer to
  // the base than the contact step bound resolves (it returned 0: 50 repair iterations standing
  // still). The repair now holds every top below 1e-4 of its offset, and their neighbours, where
  // the start put them; here that is all of them, and the result is valid.
  // (Generation then also tries the lifting alone, try_lift_only: off here.)
  const double eta = 0.2;
  const TriMesh m = test::facing_sheets(6, 0.01 * eta);
  GenerateOptions o = options_for(ShellMethod::Rigid, eta);
  o.guard.try_lift_only = false;
  const GenerateResult g = generate_shell(m.V, m.F, o);
  expect_valid(g);
  int below = 0;
  for (int i = 0; i < m.V.rows(); ++i) below += g.guard.start.scale[i] < GenerateOptions{}.guard.repair_min_scale;
  EXPECT_GT(below, 0);
  EXPECT_EQ(g.guard.repaired_vertices, 0);
  EXPECT_EQ(g.guard.solve.iterations, 0);
  EXPECT_TRUE(g.shell.top == g.guard.start.top);
}

TEST(GuardedGeneration, LiftingRaisesHeldTopsByValidMovesThatLowerTheEnergy) {
  // The repair holds the tops the start pulled below repair_min_scale, and their neighbours;
  // the lift then raises those that have room. With the threshold raised to half the wanted
  // offset many held tops have room (at the default only tops pinned to the base by tight creases
  // are held, as on CGAL's double-torus-example, too special to build here). The lift must keep
  // the shell valid, lower the shell energy E by exactly what it reports, and lower the stretch.
  const TriMesh m = bumpy_sphere(3, 0.25);
  const int n = static_cast<int>(m.V.rows());
  GenerateOptions o = options_for(ShellMethod::Rigid, thickness_from_ratio(m.V, 0.05));
  o.guard.repair_min_scale = 0.5;
  o.guard.try_lift_only = false; // compared with the repair's result, below
  ASSERT_GT(o.guard.lift_sweeps, 0) << "generation lifts by default";
  const GenerateResult lifted = generate_shell(m.V, m.F, o);
  o.guard.lift_sweeps = 0;
  const GenerateResult held = generate_shell(m.V, m.F, o);
  EXPECT_EQ(held.guard.lift.moves, 0);
  ASSERT_GT(lifted.guard.lift.moves, 0);
  expect_valid(lifted);
  const RestTets rest = prism_rest_tets(m.F, n, normal_prisms(m.V, m.F, o.thickness));
  const std::vector<int> base = test::vertex_range(0, n);
  const ShellSolver energy(rest, 2 * n, base);
  Eigen::MatrixXd before(2 * n, 3), after(2 * n, 3);
  before << m.V, held.shell.top;
  after << m.V, lifted.shell.top;
  EXPECT_GT(lifted.guard.lift.energy_drop, 0);
  EXPECT_NEAR(energy.energy(before) - energy.energy(after), lifted.guard.lift.energy_drop,
              1e-9 * energy.energy(before));
  EXPECT_LT(lifted.metrics.stretch.volume_mean, held.metrics.stretch.volume_mean);
  // The reported smallest relative volume is the returned shell's, the lifted tops' tets included.
  const double smallest = tet_deformation_determinants(rest, after).minCoeff();
  EXPECT_NEAR(lifted.guard.solve.min_relative_volume, smallest, 1e-12 * std::abs(smallest));
  // Only tops thinner than 0.9 of the paper's (the unguarded result) moved.
  const GenerateResult paper = generate_shell(m.V, m.F, options_for(ShellMethod::Rigid, o.thickness, true));
  int thin = 0;
  for (int i = 0; i < n; ++i) {
    const bool is_thin = (held.shell.top.row(i) - m.V.row(i)).norm() < 0.9 * (paper.shell.top.row(i) - m.V.row(i)).norm();
    thin += is_thin;
    if (!is_thin) EXPECT_TRUE(lifted.shell.top.row(i) == held.shell.top.row(i)) << i;
  }
  EXPECT_EQ(thin, lifted.guard.lift.candidates);
}

TEST(GuardedGeneration, LiftingAloneIsKeptWhereItEndsAtLowerEnergyThanTheRepair) {
  // Where repair_min_scale holds tops, the lifting also runs from the start with no repair, and
  // the result of lower shell energy E is kept: bit for bit the repaired-and-lifted top or the
  // top lifted alone (a run whose repair region is empty), whichever E says, and valid. At
  // the default threshold only tops pinned in tight creases are held (CGAL's
  // double-torus-example, where the lifting alone wins clearly); here the threshold is raised so
  // that the repair wins with half the region held (by 0.08% of E) and loses, narrowly, with
  // nearly all of it held.
  const TriMesh m = bumpy_sphere(3, 0.25);
  const int n = static_cast<int>(m.V.rows());
  const std::vector<int> base = test::vertex_range(0, n);
  GenerateOptions o = options_for(ShellMethod::Rigid, thickness_from_ratio(m.V, 0.05));
  ASSERT_TRUE(o.guard.try_lift_only) << "generation tries the lifting alone by default";
  const ShellSolver energy(prism_rest_tets(m.F, n, normal_prisms(m.V, m.F, o.thickness)), 2 * n, base);
  auto E = [&](const GenerateResult& r) {
    Eigen::MatrixXd X(2 * n, 3);
    X << m.V, r.shell.top;
    return energy.energy(X);
  };
  int kept_alone = 0, kept_repaired = 0;
  for (double min_scale : {0.5, 0.8}) {
    SCOPED_TRACE(min_scale);
    o.guard.repair_min_scale = min_scale;
    o.guard.try_lift_only = true;
    o.guard.repair_rings = GenerateOptions{}.guard.repair_rings;
    const GenerateResult both = generate_shell(m.V, m.F, o);
    o.guard.try_lift_only = false;
    const GenerateResult repaired = generate_shell(m.V, m.F, o);
    o.guard.repair_rings = 0; // every pulled-in top held: nothing to repair
    o.guard.repair_min_scale = 1 - 1e-9;
    const GenerateResult alone = generate_shell(m.V, m.F, o);
    ASSERT_GT(repaired.guard.held_vertices, 0);
    ASSERT_GT(repaired.guard.repaired_vertices, 0);
    ASSERT_EQ(alone.guard.repaired_vertices, 0);
    ASSERT_GT(alone.guard.lift.moves, 0);
    const bool alone_lower = E(alone) < E(repaired);
    (alone_lower ? kept_alone : kept_repaired) += 1;
    EXPECT_EQ(both.guard.lift_only, alone_lower);
    EXPECT_TRUE(both.shell.top == (alone_lower ? alone : repaired).shell.top);
    EXPECT_EQ(both.guard.repaired_vertices, alone_lower ? 0 : repaired.guard.repaired_vertices);
    expect_valid(both);
    // The report and the summary say which was kept.
    const nlohmann::json report = generate_report(both, "bumpy sphere", 0.05)["guard"];
    EXPECT_EQ(report["lift_only"], alone_lower);
    EXPECT_EQ(report["held_vertices"], repaired.guard.held_vertices);
    EXPECT_EQ(generate_summary(both, "bumpy sphere").find("lifting alone kept") != std::string::npos, alone_lower);
  }
  EXPECT_EQ(kept_alone, 1);
  EXPECT_EQ(kept_repaired, 1);
}

TEST(GuardedGeneration, LargeLocalSystemsTakeTheSupernodalFactorWithTheSameOutcome) {
  // Local systems of supernodal_rows rows and more are factored by CHOLMOD's supernodal
  // Cholesky instead of the simplicial LDLT (it keeps large repairs from taking minutes per
  // iteration). With the threshold at 0 every local system takes it: the repair must end valid at
  // the same energy as with the LDLT (both solve the same systems; only rounding and the
  // factor's ordering differ: after the first, systems over nearly the same vertices reuse the
  // first one's fill-reducing ordering).
  const TriMesh m = bumpy_sphere(3, 0.25);
  GenerateOptions o = options_for(ShellMethod::Rigid, thickness_from_ratio(m.V, 0.05));
  const GenerateResult simplicial = generate_shell(m.V, m.F, o);
  o.guard.supernodal_rows = 0;
  const GenerateResult supernodal = generate_shell(m.V, m.F, o);
  ASSERT_GT(simplicial.guard.repaired_vertices, 0);
  EXPECT_EQ(simplicial.guard.solve.supernodal_solves, 0);
  EXPECT_GT(supernodal.guard.solve.supernodal_solves, 1);
  EXPECT_GT(supernodal.guard.solve.reused_orderings, 0);
  EXPECT_LT(supernodal.guard.solve.reused_orderings, supernodal.guard.solve.supernodal_solves);
  expect_valid(simplicial);
  expect_valid(supernodal);
  const double e_simplicial = simplicial.guard.solve.final_energy, e_supernodal = supernodal.guard.solve.final_energy;
  EXPECT_NEAR(e_supernodal, e_simplicial, 1e-4 * e_simplicial);
  EXPECT_NEAR(supernodal.metrics.stretch.volume_mean, simplicial.metrics.stretch.volume_mean,
              1e-4 * simplicial.metrics.stretch.volume_mean);

  // Below supernodal_rows the LDLT's analysis decides: a system predicted to cost at least
  // supernodal_flops takes the supernodal factor too (parts coupled by contacts fill far more
  // than a surface's graph). At 0 every system does, with the same outcome.
  o.guard.supernodal_rows = GenerateOptions{}.guard.supernodal_rows;
  o.guard.supernodal_flops = 0;
  const GenerateResult by_flops = generate_shell(m.V, m.F, o);
  EXPECT_EQ(by_flops.guard.solve.supernodal_solves, supernodal.guard.solve.supernodal_solves);
  expect_valid(by_flops);
  EXPECT_NEAR(by_flops.guard.solve.final_energy, e_simplicial, 1e-4 * e_simplicial);
  o.guard.supernodal_flops = -1;
  EXPECT_THROW(generate_shell(m.V, m.F, o), InputError);
}

TEST(GuardedGeneration, SmallRepairRunsPastTheSolvesIterationCap) {
  // The repair's cap is the solve's max_iterations, extended while iterations x repaired vertices
  // stay within repair_budget: a small repair stopped unconverged by the cap (CGAL's mpi_triang at
  // 50) goes on to convergence, lowering its energy; without the budget it stops at the cap.
  const TriMesh m = bumpy_sphere(3, 0.25);
  GenerateOptions o = options_for(ShellMethod::Rigid, thickness_from_ratio(m.V, 0.05));
  o.solve.max_iterations = 3;
  ASSERT_GT(o.guard.repair_budget, 0) << "generation's default has the budget";
  const GenerateResult extended = generate_shell(m.V, m.F, o);
  o.guard.repair_budget = 0;
  const GenerateResult capped = generate_shell(m.V, m.F, o);
  ASSERT_GT(capped.guard.repaired_vertices, 0);
  EXPECT_EQ(capped.guard.solve.iterations, 3);
  EXPECT_FALSE(capped.guard.solve.converged);
  EXPECT_GT(extended.guard.solve.iterations, 3);
  EXPECT_LE(extended.guard.solve.iterations * extended.guard.repaired_vertices, GenerateOptions{}.guard.repair_budget);
  EXPECT_LT(extended.guard.solve.energy.back(), capped.guard.solve.energy.back());
  expect_valid(extended);
  expect_valid(capped);
}

TEST(GuardedGeneration, HoldingWhatCutsTheRepairsStepsKeepsItValidAndItsEnergyFalling) {
  // Where a few tets or pairs cut a repair step short, generation holds their vertices still for
  // that step and moves the rest further (GuardOptions::hold_rounds). Two sheets closer than
  // twice the layer: such steps happen (about two in three of the cut ones), the repair's E_guard
  // still never rises, and the result certifies, as does the repair whose steps are all cut.
  const TriMesh m = test::facing_sheets(8, 0.15);
  GenerateOptions o = options_for(ShellMethod::Rigid, thickness_from_ratio(m.V, 0.1));
  ASSERT_GT(o.guard.hold_rounds, 0) << "generation holds";
  o.guard.relax_rounds = 0;
  o.guard.lift_sweeps = 0;
  const GenerateResult held = generate_shell(m.V, m.F, o);
  o.guard.hold_rounds = 0;
  const GenerateResult cut = generate_shell(m.V, m.F, o);
  EXPECT_GT(held.guard.solve.held_steps, 0);
  EXPECT_EQ(cut.guard.solve.held_steps, 0);
  const std::vector<double>& E = held.guard.solve.energy;
  for (std::size_t k = 1; k < E.size(); ++k) EXPECT_LE(E[k], E[k - 1]) << "iteration " << k;
  expect_valid(held);
  expect_valid(cut);
}

TEST(GuardedGeneration, RelaxingTheBarriersLowersTheEnergyOfTheRepairedRegionOnly) {
  // The repair's barriers hold its top further from the validity limits than needed; a relaxation
  // round solves the same region again with weaker barriers and is kept only if it lowers the
  // shell energy E. The result stays valid, E does not rise, and only repaired tops move.
  const TriMesh m = bumpy_sphere(3, 0.25);
  GenerateOptions o = options_for(ShellMethod::Rigid, thickness_from_ratio(m.V, 0.05));
  ASSERT_EQ(o.guard.relax_rounds, 1) << "generation's default relaxes once";
  const GenerateResult relaxed = generate_shell(m.V, m.F, o);
  o.guard.relax_rounds = 0;
  const GenerateResult repaired = generate_shell(m.V, m.F, o);
  ASSERT_GT(repaired.guard.repaired_vertices, 0);
  EXPECT_EQ(repaired.guard.relax.iterations, 0);
  ASSERT_EQ(relaxed.guard.relax.kept_rounds, 1);
  EXPECT_GT(relaxed.guard.relax.iterations, 0);
  EXPECT_DOUBLE_EQ(relaxed.guard.relax.first_energy, repaired.guard.solve.final_energy);
  EXPECT_LT(relaxed.guard.solve.final_energy, repaired.guard.solve.final_energy);
  expect_valid(relaxed);
  expect_valid(repaired);
  // The shell energy E of each returned top, computed here from the shells themselves.
  const int n = static_cast<int>(m.V.rows());
  const std::vector<int> base = test::vertex_range(0, n);
  const ShellSolver energy(prism_rest_tets(m.F, n, normal_prisms(m.V, m.F, o.thickness)), 2 * n, base);
  auto E = [&](const GenerateResult& r) {
    Eigen::MatrixXd X(2 * m.V.rows(), 3);
    X << m.V, r.shell.top;
    return energy.energy(X);
  };
  EXPECT_LT(E(relaxed), E(repaired));
  int moved = 0;
  for (int i = 0; i < n; ++i) moved += relaxed.shell.top.row(i) != repaired.shell.top.row(i);
  EXPECT_GT(moved, 0);
  EXPECT_LE(moved, repaired.guard.repaired_vertices);
}

TEST(GuardedGeneration, ASphereInsideASphereKeepsItsTopInsideTheOuterBase) {
  // An eye in a head: a unit sphere inside one of radius 1.04, both facing out, eta 0.1. The
  // paper's inner top lies beyond the outer base everywhere, crossing no boundary triangle: only
  // the certificate's nesting test sees it. Guarded, the inner top stays inside the outer base,
  // filling most of the gap, and the outer top keeps its thickness (nothing is outside it).
  const TriMesh m = test::nested_spheres(3, 1.04);
  const int n = static_cast<int>(m.V.rows()), half = n / 2;
  const double eta = 0.1, gap = 0.04;
  const GenerateResult unguarded = generate_shell(m.V, m.F, options_for(ShellMethod::Rigid, eta, true));
  const ShellCertificate before = recertify(unguarded);
  EXPECT_EQ(before.top_self_intersections + before.top_base_intersections, 0);
  EXPECT_EQ(before.nested_parts, 2); // the inner top in the outer layer, the outer base in the inner one
  const GenerateResult g = generate_shell(m.V, m.F, options_for(ShellMethod::Rigid, eta));
  expect_valid(g);
  for (int i = 0; i < half; ++i) {
    const double r = g.shell.top.row(i).norm();
    EXPECT_LT(r, 1.04) << "inner top vertex " << i;
    EXPECT_GT(r - 1, 0.5 * gap) << "inner top vertex " << i;
  }
  for (int i = half; i < n; ++i) EXPECT_GT((g.shell.top.row(i) - m.V.row(i)).norm(), 0.9 * eta) << "outer " << i;
}

TEST(GuardedGeneration, APartTooSmallForTheThicknessKeepsTheValidStart) {
  // A unit sphere and, apart from it, a speck of radius 1e-3 (scan debris), eta 0.03: 30 times
  // the speck's size. Its prisms have no valid top near them; it keeps the valid start's layer
  // (repairing it put every pair of its boundary in contact range), the sphere is generated as
  // alone.
  const TriMesh m = test::sphere_with_speck(1e-3);
  const int nb = 642, ns = static_cast<int>(m.V.rows()) - nb;
  const double eta = 0.03;
  const GenerateResult g = generate_shell(m.V, m.F, options_for(ShellMethod::Rigid, eta));
  expect_valid(g);
  std::vector<int> speck_ids(ns);
  std::iota(speck_ids.begin(), speck_ids.end(), nb);
  EXPECT_EQ(g.guard.small_part_vertices, speck_ids);
  EXPECT_DOUBLE_EQ(g.guard.small_part_radius, eta / 10);
  for (int v : speck_ids) EXPECT_EQ(g.shell.top.row(v), g.guard.start.top.row(v)) << v;
  EXPECT_EQ(g.guard.repaired_vertices, 0); // the sphere's paper top is valid
  EXPECT_TRUE(g.guard.start.scale.tail(ns).minCoeff() < 1); // the start had to pull it in
  for (int v = 0; v < nb; ++v) EXPECT_GT((g.shell.top.row(v) - m.V.row(v)).norm(), 0.9 * eta) << v;
  auto small_part_warning = [](const GenerateResult& r) {
    const std::vector<std::string> warnings = generate_warnings(r);
    const auto w = std::find_if(warnings.begin(), warnings.end(), [](const std::string& line) {
      return line.find("thinner than asked on parts of the base smaller than the thickness allows") != std::string::npos;
    });
    return w == warnings.end() ? std::string() : *w;
  };
  int thinned = 0;
  for (int v : speck_ids) thinned += g.metrics.vertex_thickness[v] < kThinnedFraction;
  ASSERT_GT(thinned, 0);
  EXPECT_EQ(small_part_warning(g).find(std::to_string(thinned) + " top vertices (" + std::to_string(nb)), 0u)
      << small_part_warning(g);
  EXPECT_EQ(generate_report(g, "in.obj")["guard"]["small_part_vertices"], speck_ids);
  // A part held whose start keeps the whole thickness is not said to be thinner: one small
  // triangle (flat, its prism valid at any height).
  TriMesh with_triangle = test::sphere_with_speck(1e-3);
  with_triangle.V.conservativeResize(nb + 3, 3);
  with_triangle.V.bottomRows(3) << 3, 0, 0, 3.002, 0, 0, 3, 0.002, 0;
  with_triangle.F.conservativeResize(make_sphere(3, 1.0).F.rows() + 1, 3);
  with_triangle.F.bottomRows(1) << nb, nb + 1, nb + 2;
  const GenerateResult t = generate_shell(with_triangle.V, with_triangle.F, options_for(ShellMethod::Rigid, eta));
  EXPECT_EQ(t.guard.small_part_vertices, (std::vector<int>{nb, nb + 1, nb + 2}));
  EXPECT_EQ(small_part_warning(t), "");

  // Held only below eta / small_part_ratio; 0 holds nothing.
  GenerateOptions o = options_for(ShellMethod::Rigid, eta);
  o.guard.small_part_ratio = 20; // 0.03 / 20 = 1.5e-3 > 1e-3: held
  EXPECT_EQ(generate_shell(m.V, m.F, o).guard.small_part_vertices.size(), static_cast<std::size_t>(ns));
  o.guard.small_part_ratio = 40; // 0.03 / 40 = 7.5e-4 < 1e-3: not held, so repaired (slowly: a few
  o.guard.repair_iterations = 2;  // iterations show it, and that it stays valid)
  const GenerateResult free_speck = generate_shell(m.V, m.F, o);
  EXPECT_TRUE(free_speck.guard.small_part_vertices.empty());
  EXPECT_GT(free_speck.guard.repaired_vertices, 0);
  expect_valid(free_speck);
  o.guard.small_part_ratio = 0;
  EXPECT_TRUE(generate_shell(m.V, m.F, o).guard.small_part_vertices.empty());
}

TEST(GuardedGeneration, APartInsideAnotherLayerThinsThatLayerOnlyAroundIt) {
  // Scan debris just off a surface: a small sphere (radius 0.02, not held: 0.02 > eta / 10) 0.05
  // above a unit sphere, inside its layer (eta 0.1). The start pulls in the unit sphere's top
  // only over the prisms that reach the speck, not all of it.
  TriMesh m = test::sphere_with_speck(0.02);
  const int nb = 642;
  for (Eigen::Index v = nb; v < m.V.rows(); ++v) m.V.row(v) += Eigen::RowVector3d(1.07 - 3, 0, 0);
  const double eta = 0.1;
  const GenerateResult g = generate_shell(m.V, m.F, options_for(ShellMethod::Rigid, eta));
  expect_valid(g);
  EXPECT_TRUE(g.guard.small_part_vertices.empty());
  int pulled_on_sphere = 0;
  for (int v = 0; v < nb; ++v) pulled_on_sphere += g.guard.start.scale[v] < 1;
  EXPECT_GT(pulled_on_sphere, 0);
  EXPECT_LT(pulled_on_sphere, nb / 10);
  // Far from the speck the sphere keeps its whole thickness.
  for (int v = 0; v < nb; ++v)
    if (m.V(v, 0) < 0.5) EXPECT_GT((g.shell.top.row(v) - m.V.row(v)).norm(), 0.9 * eta) << v;
}
