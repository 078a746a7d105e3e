// The guarded solver (guard/guarded_solver.h) given other parameters after a solve, as
// generation's relaxation rounds do, or other tets and triangles to leave out, as a deformation
// frame whose base breaks more than the rest's: it must solve exactly as a solver made with them.
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/guard/guarded_solver.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/rest_tets.h>

#include <gtest/gtest.h>

#include <memory>

#include <Eigen/SparseCholesky>

#include "guard/shell_part.h"
#include "guard/vertex_amd_ordering.h"
#include "shell_fixtures.h"
#include "solver/hierarchy_levels.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <utility>
#include <vector>

using namespace gshell;

namespace {

// The shell of normal prisms of thickness eta over `base`, at rest: its top the offset surface.
struct NormalShell {
  TriMesh base;
  int n;
  double eta;
  RestTets rest;
  ShellBoundary boundary;
  Eigen::MatrixXd X;

  NormalShell(TriMesh b, double thickness)
      : base(std::move(b)), n(static_cast<int>(base.V.rows())), eta(thickness),
        rest(prism_rest_tets(base.F, n, normal_prisms(base.V, base.F, eta))), boundary(shell_boundary(base.F, n)),
        X(2 * n, 3) {
    X << base.V, offset_top(base.V, base.F, eta);
  }
};

// A sphere's shell started at a twentieth of its thickness (valid, every tet inside the volume
// barrier), with the tops of a cap around +z free and everything else held (a repaired region).
struct CapRepair {
  TriMesh base = make_sphere(3);
  int n = static_cast<int>(base.V.rows());
  double eta = 0.2;
  RestTets rest = prism_rest_tets(base.F, n, normal_prisms(base.V, base.F, eta));
  ShellBoundary boundary = shell_boundary(base.F, n);
  std::vector<int> fixed;
  Eigen::MatrixXd X;

  CapRepair() {
    for (int i = 0; i < n; ++i) fixed.push_back(i);
    for (int i = 0; i < n; ++i)
      if (base.V(i, 2) < 0.8) fixed.push_back(n + i);
    X.resize(2 * n, 3);
    X << base.V, offset_top(base.V, base.F, eta / 20);
  }

  GuardedSolverParameters parameters(double j_hat, double weight, double distance) const {
    GuardedSolverParameters p;
    p.j_hat = j_hat;
    p.volume_weight = weight;
    p.contact_distance = distance;
    p.contact_stiffness = weight;
    p.local_rings = 2;
    return p;
  }
};

// `kept` (given other parameters after construction) and `made` (constructed with them) take the
// same iterations from X, bit for bit.
void expect_solves_alike(GuardedSolver& kept, GuardedSolver& made, const Eigen::MatrixXd& X) {
  GuardedSolveOptions options;
  options.max_iterations = 8;
  Eigen::MatrixXd Y = X, Z = X;
  const GuardedSolveResult a = kept.solve(Y, options), b = made.solve(Z, options);
  EXPECT_GT(a.iterations, 0);
  EXPECT_EQ(a.energy, b.energy);
  EXPECT_EQ(Y, Z);
  EXPECT_EQ(kept.energy(Y), made.energy(Z));
}

} // namespace

TEST(GuardedSolver, OtherParametersSolveAsASolverMadeWithThem) {
  const CapRepair c;
  const GuardedSolverParameters strong = c.parameters(0.1, 1.0, 0.02), weak = c.parameters(0.03, 0.1, 0.01);
  GuardedSolveOptions options;
  options.max_iterations = 8;
  GuardedSolver solver(c.rest, 2 * c.n, c.fixed, c.boundary, strong);
  Eigen::MatrixXd X = c.X;
  const GuardedSolveResult first = solver.solve(X, options);
  ASSERT_GT(first.iterations, 0);
  ASSERT_GT(first.active_tets, 0);
  ASSERT_GT(first.active_contacts, 0);
  ASSERT_NE(X, c.X);

  solver.set_parameters(weak);
  EXPECT_EQ(solver.volume_barrier().j_hat(), weak.j_hat);
  GuardedSolver made(c.rest, 2 * c.n, c.fixed, c.boundary, weak);
  expect_solves_alike(solver, made, X);
}

// A guarded solver on an ARAP solver built elsewhere (a guarded pose's full level) solves as one
// that builds its own, bit for bit, and both can share one (a guard's two solvers do).
TEST(GuardedSolver, ASharedArapSolverSolvesAsAnOwnOne) {
  const CapRepair c;
  const GuardedSolverParameters p = c.parameters(0.1, 1.0, 0.02);
  GuardedSolver own(c.rest, 2 * c.n, c.fixed, c.boundary, p);
  const auto arap = std::make_shared<const ShellSolver>(c.rest, 2 * c.n, c.fixed);
  GuardedSolver shared(arap, c.boundary, p);
  expect_solves_alike(own, shared, c.X);
  GuardedSolverParameters tets_only = p;
  tets_only.contact_distance = 0;
  tets_only.contact_stiffness = 0;
  GuardedSolver second(arap, c.boundary, tets_only), second_own(c.rest, 2 * c.n, c.fixed, c.boundary, tets_only);
  expect_solves_alike(second, second_own, c.X);
  EXPECT_THROW(GuardedSolver(std::shared_ptr<const ShellSolver>(), c.boundary, p), InputError);
}

// Tets left out after construction (a deformation frame whose base made a vertex unextrudable):
// a state that inverts them is then valid, and solves as with a solver made leaving them out.
TEST(GuardedSolver, OtherSkippedTetsSolveAsASolverMadeWithThem) {
  const CapRepair c;
  int apex = -1;
  for (int i = 0; i < c.n && apex < 0; ++i)
    if (c.base.V(i, 2) > 0.95) apex = i;
  ASSERT_GE(apex, 0);
  Eigen::MatrixXd X = c.X;
  X.row(c.n + apex) = c.base.V.row(apex) * 0.98; // the free top pushed below its base vertex
  GuardedSolverParameters p = c.parameters(0.1, 1.0, 0.02);
  GuardedSolver solver(c.rest, 2 * c.n, c.fixed, c.boundary, p);
  EXPECT_EQ(solver.energy(X), std::numeric_limits<double>::infinity());

  p.skip_tets.assign(c.rest.size(), 0);
  for (int f = 0; f < c.base.F.rows(); ++f)
    if (c.base.F(f, 0) == apex || c.base.F(f, 1) == apex || c.base.F(f, 2) == apex)
      p.skip_tets[3 * f] = p.skip_tets[3 * f + 1] = p.skip_tets[3 * f + 2] = 1;
  solver.set_skipped_tets(p.skip_tets);
  EXPECT_EQ(solver.parameters().skip_tets, p.skip_tets);
  EXPECT_EQ(solver.volume_barrier().skip(), p.skip_tets);
  GuardedSolver made(c.rest, 2 * c.n, c.fixed, c.boundary, p);
  ASSERT_LT(solver.energy(X), std::numeric_limits<double>::infinity());
  EXPECT_EQ(solver.energy(X), made.energy(X));
  expect_solves_alike(solver, made, X);
  EXPECT_THROW(solver.set_skipped_tets(std::vector<char>(3, 0)), InputError);
}

// Triangles left out of contacts after construction (around the crossings a moving base makes):
// the pairs they were in no longer act, and the solver solves as one made leaving them out.
TEST(GuardedSolver, OtherExcludedTrianglesSolveAsASolverMadeWithThem) {
  const CapRepair c;
  GuardedSolverParameters p = c.parameters(0.1, 1.0, 0.02);
  GuardedSolver solver(c.rest, 2 * c.n, c.fixed, c.boundary, p);
  const double before = solver.energy(c.X);
  p.excluded_triangles.assign(c.boundary.size(), 0);
  for (int r = 0; r < c.boundary.size(); ++r) { // every triangle over the cap's faces
    const int f = c.boundary.face[r];
    p.excluded_triangles[r] = c.base.V(c.base.F(f, 0), 2) > 0.8;
  }
  solver.set_excluded_triangles(c.boundary, p.excluded_triangles);
  EXPECT_EQ(solver.parameters().excluded_triangles, p.excluded_triangles);
  GuardedSolver made(c.rest, 2 * c.n, c.fixed, c.boundary, p);
  EXPECT_LT(solver.energy(c.X), before); // the tops sit 0.01 off the base, inside the 0.02 support
  EXPECT_EQ(solver.energy(c.X), made.energy(c.X));
  expect_solves_alike(solver, made, c.X);
  EXPECT_THROW(solver.set_excluded_triangles(c.boundary, std::vector<char>(3, 0)), InputError);
}

TEST(GuardedSolver, ParametersThatChangeWhatIsKeptAreInputErrors) {
  const CapRepair c;
  const GuardedSolverParameters p = c.parameters(0.1, 1.0, 0.02);
  GuardedSolver solver(c.rest, 2 * c.n, c.fixed, c.boundary, p);
  GuardedSolverParameters q = p;
  q.skip_tets.assign(c.rest.size(), 0);
  q.skip_tets[0] = 1;
  EXPECT_THROW(solver.set_parameters(q), InputError);
  q = p;
  q.excluded_triangles.assign(c.boundary.size(), 0);
  EXPECT_THROW(solver.set_parameters(q), InputError);
  q = p;
  q.contact_distance = 0;
  EXPECT_THROW(solver.set_parameters(q), InputError);
  q = p;
  q.j_hat = 2;
  EXPECT_THROW(solver.set_parameters(q), InputError);
  q = p;
  q.keep_fraction = 1;
  EXPECT_THROW(solver.set_parameters(q), InputError);
  EXPECT_EQ(solver.parameters().j_hat, p.j_hat); // left as it was
  EXPECT_EQ(solver.parameters().keep_fraction, p.keep_fraction);
}

TEST(GuardedSolver, ARestStateWithCloseContactsStaysPutWithCappedSupports) {
  // Two facing sheets 0.3 apart, each with its top 0.14 above it: the tops are 0.02 apart, within
  // the contact support 0.05. The shell is its own rest (the ARAP energy is zero there).
  const TriMesh sheets = test::facing_sheets(8, 0.3);
  const int n = static_cast<int>(sheets.V.rows()), half = n / 2;
  const Eigen::MatrixXi& F = sheets.F;
  Eigen::MatrixXd top = sheets.V;
  top.topRows(half).col(2).array() += 0.14;
  top.bottomRows(half).col(2).array() -= 0.14;
  Eigen::MatrixXd rest(2 * n, 3);
  rest << sheets.V, top;
  const RestTets tets = rest_tets_from_positions(rest, build_prism_tets(F, n));
  const std::vector<int> fixed = test::vertex_range(0, n);
  GuardedSolverParameters p;
  p.contact_distance = 0.05;
  p.contact_stiffness = 1;
  const ShellBoundary boundary = shell_boundary(F, n);
  for (bool cap : {false, true}) {
    SCOPED_TRACE(cap ? "capped" : "uncapped");
    GuardedSolver solver(tets, 2 * n, fixed, boundary, p);
    if (cap) solver.cap_contact_support(rest, 0.5);
    Eigen::MatrixXd X = rest;
    const GuardedSolveResult r = solver.solve(X);
    const double moved = (X - rest).cwiseAbs().maxCoeff();
    if (cap) {
      EXPECT_EQ(r.active_contacts, 0);
      EXPECT_LT(moved, 1e-9);
    } else { // the barrier pushes the tops apart: the rest is not where it settles
      EXPECT_GT(r.energy.front(), 0);
      EXPECT_GT(moved, 1e-3);
    }
  }
}

// Confined (confine), every free top stays within the radius of where it started although its
// prism pulls it 0.19 away; without the bound the same solve takes some top farther.
TEST(GuardedSolver, ConfinedFreeVerticesStayInTheirBalls) {
  const CapRepair c;
  const GuardedSolverParameters p = c.parameters(0.1, 1.0, 0.02);
  GuardedSolveOptions options;
  options.max_iterations = 200;
  const double radius = 0.05;
  double farthest[2] = {0, 0};
  for (bool confined : {false, true}) {
    SCOPED_TRACE(confined ? "confined" : "free");
    GuardedSolver solver(c.rest, 2 * c.n, c.fixed, c.boundary, p);
    if (confined) solver.confine(c.X, radius);
    Eigen::MatrixXd X = c.X;
    const GuardedSolveResult r = solver.solve(X, options);
    ASSERT_GT(r.iterations, 1);
    for (std::size_t k = 1; k < r.energy.size(); ++k) EXPECT_LE(r.energy[k], r.energy[k - 1]) << "iteration " << k;
    EXPECT_GT(r.min_relative_volume, 0);
    farthest[confined] = (X - c.X).rowwise().norm().maxCoeff();
  }
  EXPECT_GT(farthest[0], 2 * radius);
  EXPECT_LE(farthest[1], radius * (1 + 1e-12));
  EXPECT_GT(farthest[1], 0.9 * radius); // the bound, not the energy, stopped them

  GuardedSolver solver(c.rest, 2 * c.n, c.fixed, c.boundary, p);
  EXPECT_THROW(solver.confine(c.X.topRows(3), radius), InputError);
  EXPECT_THROW(solver.confine(c.X, 0), InputError);
}

// A solver over the part of the shell a repair can reach (detail::shell_part, as generation's
// repair runs) takes the same iterations as one over the whole shell's vertices and boundary with
// the same tets, both confined alike.
TEST(GuardedSolver, ASolverOverTheShellPartSolvesAsOneOverTheWholeShell) {
  const CapRepair c;
  const GuardedSolverParameters p = c.parameters(0.1, 1.0, 0.02);
  std::vector<char> moving(2 * c.n, 1);
  for (int v : c.fixed) moving[v] = 0;
  const double travel = 0.3;
  const detail::ShellPart part = detail::shell_part(c.rest, c.boundary, c.X, moving, travel, 2 * p.contact_distance);
  ASSERT_LT(part.size(), 2 * c.n); // a part, not the whole
  ASSERT_LT(static_cast<int>(part.row.size()), c.boundary.size());

  // The whole shell's solver over the same tets (those with a moving vertex, as the repair's).
  RestTets moving_tets;
  moving_tets.T.resize(static_cast<int>(part.tet.size()), 4);
  moving_tets.volume.resize(moving_tets.T.rows());
  for (std::size_t k = 0; k < part.tet.size(); ++k) {
    moving_tets.T.row(static_cast<int>(k)) = c.rest.T.row(part.tet[k]);
    moving_tets.Dm_inv.push_back(c.rest.dm_inv(part.tet[k]));
    moving_tets.volume[static_cast<int>(k)] = c.rest.volume[part.tet[k]];
  }
  GuardedSolver whole(moving_tets, 2 * c.n, c.fixed, c.boundary, p);
  GuardedSolver over_part(part.tets, part.size(), part.held, part.boundary, p);
  whole.confine(c.X, travel);
  over_part.confine(part.X, travel);
  GuardedSolveOptions options;
  options.max_iterations = 30;
  Eigen::MatrixXd X = c.X, Y = part.X;
  const GuardedSolveResult a = whole.solve(X, options), b = over_part.solve(Y, options);
  ASSERT_GT(a.iterations, 1);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.active_contacts, b.active_contacts);
  ASSERT_EQ(a.energy.size(), b.energy.size());
  for (std::size_t k = 0; k < a.energy.size(); ++k) EXPECT_NEAR(b.energy[k], a.energy[k], 1e-12 * a.energy[0]);
  Eigen::MatrixXd Z = c.X;
  part.scatter_moving(Y, Z);
  EXPECT_LT((Z - X).cwiseAbs().maxCoeff(), 1e-12);
}

// The part: exactly the tets with a moving vertex; every boundary row left out lies beyond the
// reach of every row with a moving vertex (by boxes); the rows kept, renumbered, are the shell's.
TEST(GuardedSolver, AShellPartHoldsWhatTheMovingVerticesCanReach) {
  const NormalShell shell(make_sphere(4), 0.1);
  const auto& [base, n, eta, rest, boundary, X] = shell;
  std::vector<char> moving(2 * n, 0);
  for (int i = 0; i < n; ++i) moving[n + i] = base.V(i, 2) > 0.95;
  const double travel = 0.1, radius = 0.02;
  const detail::ShellPart part = detail::shell_part(rest, boundary, X, moving, travel, radius);

  auto has_moving = [&](const Eigen::MatrixXi& T, int r) {
    for (int k = 0; k < T.cols(); ++k)
      if (moving[T(r, k)]) return true;
    return false;
  };
  std::vector<int> tets;
  for (int t = 0; t < rest.size(); ++t)
    if (has_moving(rest.T, t)) tets.push_back(t);
  EXPECT_EQ(part.tet, tets);
  for (std::size_t k = 0; k < tets.size(); ++k)
    for (int j = 0; j < 4; ++j) EXPECT_EQ(part.vertex[part.tets.T(static_cast<int>(k), j)], rest.T(tets[k], j));

  auto box = [&](int r) {
    Eigen::AlignedBox3d b(X.row(boundary.F(r, 0)).transpose());
    return b.extend(X.row(boundary.F(r, 1)).transpose()).extend(X.row(boundary.F(r, 2)).transpose());
  };
  std::vector<char> kept(boundary.size(), 0);
  for (std::size_t k = 0; k < part.row.size(); ++k) {
    const int r = part.row[k];
    kept[r] = 1;
    for (int j = 0; j < 3; ++j) EXPECT_EQ(part.vertex[part.boundary.F(static_cast<int>(k), j)], boundary.F(r, j));
    EXPECT_EQ(part.boundary.face[k], boundary.face[r]);
  }
  int left_out = 0;
  for (int r = 0; r < boundary.size(); ++r) {
    if (kept[r]) continue;
    ++left_out;
    for (int s = 0; s < boundary.size(); ++s)
      if (has_moving(boundary.F, s)) EXPECT_GT(box(r).exteriorDistance(box(s)), travel + radius) << r << " " << s;
  }
  EXPECT_GT(left_out, boundary.size() / 2); // a small cap's part is small

  for (int i = 0; i < part.size(); ++i) {
    EXPECT_EQ(part.X.row(i), X.row(part.vertex[i]));
    EXPECT_EQ(std::count(part.held.begin(), part.held.end(), i) == 0, moving[part.vertex[i]] != 0);
  }
}

namespace {

// Contacts guarded within contact_distance (stiffness 1), the given Anderson history.
GuardedSolverParameters contact_parameters(double contact_distance, int anderson_history) {
  GuardedSolverParameters p;
  p.contact_distance = contact_distance;
  p.contact_stiffness = 1;
  p.anderson_history = anderson_history;
  return p;
}

// With parameters p: drags the fixed vertices from X to `targets` (to tolerance 1e-3, within
// drag_iterations), then settles the shell to 1e-10: the settling's result, Y its state. The drag
// must complete, the settling converge without E_guard ever rising and leave every guarded tet
// positive.
GuardedSolveResult drag_then_settle(const RestTets& rest, const std::vector<int>& fixed, const ShellBoundary& boundary,
                                    const GuardedSolverParameters& p, int drag_iterations,
                                    const Eigen::MatrixXd& X, const Eigen::MatrixXd& targets, Eigen::MatrixXd& Y) {
  GuardedSolver solver(rest, static_cast<int>(X.rows()), fixed, boundary, p);
  GuardedSolveOptions drag;
  drag.max_iterations = drag_iterations;
  drag.tolerance = 1e-3;
  Y = X;
  EXPECT_EQ(solver.solve(Y, drag, targets).path_done, 1.0);
  GuardedSolveOptions settle;
  settle.max_iterations = 5000;
  settle.tolerance = 1e-10;
  const GuardedSolveResult r = solver.solve(Y, settle);
  EXPECT_TRUE(r.converged);
  for (std::size_t k = 1; k < r.energy.size(); ++k) EXPECT_LE(r.energy[k], r.energy[k - 1]) << "iteration " << k;
  EXPECT_GT(r.min_relative_volume, 0);
  return r;
}

} // namespace

// A drag that cannot finish: one base vertex of a plane's shell dragged up through its own top
// vertex, both held, so the tets between them must flatten on the way; the tet step bound lets the
// path approach that point only geometrically. With the tets alone guarded (no contact) the drag
// is given up once not even a hundred times its pace would finish it, long before its iteration
// budget, every tet still positive; with contacts guarded as well, by the contact drag's rule.
// The plane's base, held, with its centre vertex dragged past its own held top vertex.
struct BaseVertexThroughItsTop {
  NormalShell shell{make_plane(4), 0.1};
  std::vector<int> fixed;
  Eigen::MatrixXd targets = shell.X;

  BaseVertexThroughItsTop() {
    const int n = shell.n;
    int centre = 0;
    for (int i = 1; i < n; ++i)
      if (shell.base.V.row(i).norm() < shell.base.V.row(centre).norm()) centre = i;
    for (int i = 0; i < n; ++i) fixed.push_back(i);
    fixed.push_back(n + centre);
    targets(centre, 2) += 2 * shell.eta; // the base vertex past its top, which stays where it is
  }
  GuardedSolver solver(const GuardedSolverParameters& p) const {
    return GuardedSolver(shell.rest, 2 * shell.n, fixed, shell.boundary, p);
  }
};

TEST(GuardedSolver, ADragThatCannotFinishIsGivenUpEarlyAndLeftValid) {
  const BaseVertexThroughItsTop c;
  const Eigen::MatrixXd& targets = c.targets;
  GuardedSolveOptions options;
  options.max_iterations = 400;
  for (const double contact_distance : {0.0, 0.02}) {
    GuardedSolverParameters p;
    p.contact_distance = contact_distance;
    p.contact_stiffness = contact_distance > 0 ? 1 : 0;
    GuardedSolver solver = c.solver(p);
    Eigen::MatrixXd Y = c.shell.X;
    const GuardedSolveResult r = solver.solve(Y, options, targets);
    EXPECT_LT(r.path_done, 1) << "contact distance " << contact_distance;
    EXPECT_GT(r.path_done, 0.25) << "contact distance " << contact_distance; // it went most of the way it could
    EXPECT_LT(r.iterations, options.max_iterations / 4) << "contact distance " << contact_distance;
    EXPECT_GT(r.min_relative_volume, 0) << "contact distance " << contact_distance;
    EXPECT_TRUE(std::isfinite(solver.energy(Y)));
  }
}

// A drag that continues a longer motion (a stalled sub-step's retry, from where the first attempt
// stopped) is held to the pace of that whole motion, not of what is left of it
// (GuardedSolveOptions::path_scale): otherwise each retry may creep on at a thousandth of a
// smaller remainder per 20 iterations (a plane pressed into itself by its handles spent a fifth
// of its pose in such retries). The drag above, told that its path is a tenth of the motion,
// stops sooner, as far along as the bounds let it go and as valid.
TEST(GuardedSolver, AContactDragIsStalledAtThePaceOfTheWholeMotion) {
  const BaseVertexThroughItsTop c;
  const Eigen::MatrixXd& targets = c.targets;
  GuardedSolverParameters p;
  p.contact_distance = 0.02;
  p.contact_stiffness = 1;
  GuardedSolveOptions options;
  options.max_iterations = 400;
  GuardedSolveResult r[2];
  for (const int part : {0, 1}) {
    GuardedSolver solver = c.solver(p);
    Eigen::MatrixXd Y = c.shell.X;
    GuardedSolveOptions o = options;
    if (part == 1) o.path_scale = 0.1;
    r[part] = solver.solve(Y, o, targets);
    EXPECT_LT(r[part].path_done, 1);
    EXPECT_GT(r[part].min_relative_volume, 0);
  }
  EXPECT_LT(r[1].iterations, r[0].iterations);
  EXPECT_GT(r[1].path_done, 0.9 * r[0].path_done); // most of the way the whole pace went
  options.path_scale = 0;
  GuardedSolver solver = c.solver(p);
  Eigen::MatrixXd Y = c.shell.X;
  EXPECT_THROW(solver.solve(Y, options, targets), InputError);
}

// A plane's shell bent by dragging one edge's prisms up and over while the opposite edge's are
// held, the drag far from every barrier: the minimisation after it runs the model's plain
// local/global iterations, which creep along the bending mode.
struct BentPlane {
  NormalShell shell{make_plane(12), 0.1};
  std::vector<int> fixed;
  Eigen::MatrixXd targets = shell.X;

  BentPlane() {
    const int n = shell.n;
    for (int i = 0; i < n; ++i) {
      if (shell.base.V(i, 0) < -0.9) fixed.insert(fixed.end(), {i, n + i});
      if (shell.base.V(i, 0) > 0.9) {
        fixed.insert(fixed.end(), {i, n + i});
        for (int v : {i, n + i}) targets.row(v) += Eigen::RowVector3d(-0.6, 0, 0.9);
      }
    }
    std::sort(fixed.begin(), fixed.end());
  }

  GuardedSolveResult solve(const GuardedSolverParameters& p, Eigen::MatrixXd& Y) const {
    const GuardedSolveResult r = drag_then_settle(shell.rest, fixed, shell.boundary, p, 50, shell.X, targets, Y);
    EXPECT_EQ(r.active_tets, 0); // the case: no barrier acting
    EXPECT_EQ(r.active_contacts, 0);
    EXPECT_GT(r.min_relative_volume, 0.1);
    return r;
  }
};

// Anderson acceleration (anderson_history) combines the plain iterations of the bent plane. The
// combined iterates must reach the plain iterations' minimum, never raise E_guard, keep the shell
// valid and need fewer iterations (the reason for the option; a count, not a time).
TEST(GuardedSolver, AndersonReachesThePlainMinimumInFewerIterationsWhereNoBarrierActs) {
  const BentPlane plane;
  Eigen::MatrixXd plain_state, combined_state;
  const GuardedSolveResult plain = plane.solve(contact_parameters(0.01, 0), plain_state);
  const GuardedSolveResult combined = plane.solve(contact_parameters(0.01, 5), combined_state);
  EXPECT_NEAR(combined.final_energy, plain.final_energy, 1e-5 * plain.final_energy);
  EXPECT_LT((combined_state - plain_state).cwiseAbs().maxCoeff(), 0.01 * plane.shell.eta);
  EXPECT_LT(combined.iterations, plain.iterations / 2) << "plain " << plain.iterations << ", combined " << combined.iterations;
}

// The bent plane settled with plain steps taken longer where E_guard falls nearly linearly along
// them (max_step_multiple): the model, holding the rotations, takes the bending mode for stiff.
// The lengthened steps must reach the same minimum, never raise E_guard, keep the shell valid and,
// in a solve that creeps (no Anderson), need fewer iterations; a short solve (with Anderson, as
// frames and poses run) is not lengthened.
TEST(GuardedSolver, LengthenedStepsReachThePlainMinimumInFewerIterations) {
  const BentPlane plane;
  for (int history : {0, 5}) {
    SCOPED_TRACE("anderson_history " + std::to_string(history));
    GuardedSolverParameters p = contact_parameters(0.01, history);
    Eigen::MatrixXd plain_state, longer_state;
    const GuardedSolveResult plain = plane.solve(p, plain_state);
    p.max_step_multiple = 64;
    const GuardedSolveResult longer = plane.solve(p, longer_state);
    EXPECT_EQ(plain.lengthened_steps, 0);
    EXPECT_NEAR(longer.final_energy, plain.final_energy, 1e-5 * plain.final_energy);
    EXPECT_LT((longer_state - plain_state).cwiseAbs().maxCoeff(), 0.01 * plane.shell.eta);
    if (history == 0) { // the plain iterations creep (456 here)
      EXPECT_GT(longer.lengthened_steps, 0);
      EXPECT_LT(longer.iterations, plain.iterations / 2) << "plain " << plain.iterations << ", lengthened " << longer.iterations;
    } else { // Anderson's combined iterates cross this mode in a few dozen: too short a solve to lengthen
      EXPECT_LT(plain.iterations, 100);
      EXPECT_EQ(longer.lengthened_steps, 0);
    }
  }
}

// Two facing sheets, each held at its left edge only; the lower one's right edge is lifted into
// the upper one, which is pushed up and bends: the minimum has the two tops pressed together, the
// contact barrier acting.
struct PressedSheets {
  TriMesh sheets = test::facing_sheets(10, 0.3);
  int n = static_cast<int>(sheets.V.rows());
  double eta = 0.1;
  Eigen::MatrixXd X, targets;
  RestTets rest;
  ShellBoundary boundary = shell_boundary(sheets.F, n);
  std::vector<int> fixed;

  PressedSheets() {
    const int half = n / 2;
    X.resize(2 * n, 3);
    X << sheets.V, sheets.V;
    X.block(n, 2, half, 1).array() += eta;        // lower sheet's top, up
    X.block(n + half, 2, half, 1).array() -= eta; // upper sheet's top, down: the tops 0.1 apart
    rest = rest_tets_from_positions(X, build_prism_tets(sheets.F, n));
    targets = X;
    for (int i = 0; i < n; ++i) {
      if (sheets.V(i, 0) < -0.9) fixed.insert(fixed.end(), {i, n + i});
      if (i < half && sheets.V(i, 0) > 0.9) {
        fixed.insert(fixed.end(), {i, n + i});
        for (int v : {i, n + i}) targets(v, 2) += 0.2;
      }
    }
    std::sort(fixed.begin(), fixed.end());
  }

  GuardedSolveResult solve(const GuardedSolverParameters& p, Eigen::MatrixXd& Y) const {
    const GuardedSolveResult r = drag_then_settle(rest, fixed, boundary, p, 200, X, targets, Y);
    EXPECT_GT(r.active_contacts, 0); // the case: the tops pressed together
    return r;
  }
};

// Anderson acceleration also combines the iterations where barriers act (the map is the
// local/global step corrected near the barriers): the combined iterates must settle where the
// plain ones do, never raise E_guard, keep the layer apart and need fewer iterations.
TEST(GuardedSolver, AndersonReachesThePlainMinimumInFewerIterationsWhereTheContactBarrierActs) {
  const PressedSheets sheets;
  Eigen::MatrixXd plain_state, combined_state;
  const GuardedSolveResult plain = sheets.solve(contact_parameters(0.05, 0), plain_state);
  const GuardedSolveResult combined = sheets.solve(contact_parameters(0.05, 5), combined_state);
  EXPECT_NEAR(combined.energy.back(), plain.energy.back(), 1e-5 * plain.energy.back());
  EXPECT_LT((combined_state - plain_state).cwiseAbs().maxCoeff(), 0.01 * sheets.eta);
  EXPECT_LT(combined.iterations, plain.iterations / 2) << "plain " << plain.iterations << ", combined " << combined.iterations;
}

// Holding what cuts a step is for steps cut below hold_below only (a deformation's mend holds
// below 0.005, generation's repair below 0.05). Two sheets closer than twice the layer, their
// tops started at a twentieth of it and growing into each other, as a mend's pulled-in tops do:
// where every cut is above hold_below, a solver that may hold takes the same iterations as one
// that never does, bit for bit; where every cut is eligible, some steps are taken held, E_guard
// never rises and every tet stays positive.
TEST(GuardedSolver, OnlyStepsCutBelowHoldBelowAreTakenWithWhatCutsThemHeld) {
  const NormalShell s(test::facing_sheets(8, 0.15), 0.1);
  std::vector<int> fixed(s.n);
  std::iota(fixed.begin(), fixed.end(), 0);
  Eigen::MatrixXd start(2 * s.n, 3);
  start << s.base.V, offset_top(s.base.V, s.base.F, s.eta / 20);
  GuardedSolverParameters p = contact_parameters(0.02, 0);
  GuardedSolveOptions options;
  options.max_iterations = 40;
  auto solve = [&](Eigen::MatrixXd& X) {
    GuardedSolver solver(s.rest, 2 * s.n, fixed, s.boundary, p);
    X = start;
    return solver.solve(X, options);
  };
  Eigen::MatrixXd never_state, above_state, eligible_state;
  const GuardedSolveResult never = solve(never_state);
  ASSERT_GT(never.clamped_steps, 0);
  p.hold_rounds = 4;
  p.hold_below = 1e-12;
  const GuardedSolveResult above = solve(above_state);
  EXPECT_EQ(above.held_steps, 0);
  EXPECT_EQ(above.energy, never.energy);
  EXPECT_EQ(above_state, never_state);
  p.hold_below = 1;
  const GuardedSolveResult eligible = solve(eligible_state);
  EXPECT_GT(eligible.held_steps, 0);
  for (std::size_t k = 1; k < eligible.energy.size(); ++k)
    EXPECT_LE(eligible.energy[k], eligible.energy[k - 1]) << "iteration " << k;
  EXPECT_GT(eligible.min_relative_volume, 0);
}

// The exact directions (exact_direction_vertices, the Woodbury solve) are the Newton steps the CG
// directions approximate (here CG alone, no local solve first, so that CG has work to do): the
// same minimum, E_guard never rising, the layer kept apart, and no CG iteration (each one a solve
// with the whole shell's factor) once the path is done.
TEST(GuardedSolver, ExactDirectionsReachTheMinimumOfTheCgDirectionsWithoutCg) {
  const PressedSheets sheets;
  GuardedSolverParameters p = contact_parameters(0.05, 0);
  p.local_rings = -1;
  Eigen::MatrixXd cg_state, exact_state;
  const GuardedSolveResult cg = sheets.solve(p, cg_state);
  p.exact_direction_vertices = 256;
  const GuardedSolveResult exact = sheets.solve(p, exact_state);
  EXPECT_GT(cg.cg_iterations, 0);
  EXPECT_EQ(exact.cg_iterations, 0); // the settling solve: its path is done from the start
  EXPECT_NEAR(exact.energy.back(), cg.energy.back(), 1e-5 * cg.energy.back());
  EXPECT_LT((exact_state - cg_state).cwiseAbs().maxCoeff(), 0.01 * sheets.eta);
}

TEST(VertexAmdOrdering, EliminatesEachVertexsRowsTogetherAndSolvesAsScalarAmdDoes) {
  // A local system's shape: the stiffness of a shell's tets on each axis (x, y, z uncoupled), plus
  // positive semidefinite 3 x 3 blocks coupling the axes of vertex pairs, as the barriers do.
  const NormalShell s(make_sphere(2), 0.1);
  const int N = 2 * s.n;
  std::vector<Eigen::Triplet<double>> entries;
  const Eigen::SparseMatrix<double> L = detail::stiffness_matrix(s.rest, N);
  for (int k = 0; k < L.outerSize(); ++k)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, k); it; ++it)
      for (int d = 0; d < 3; ++d)
        entries.emplace_back(3 * static_cast<int>(it.row()) + d, 3 * static_cast<int>(it.col()) + d, it.value());
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> vertex(0, N - 1);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k = 0; k < N / 4; ++k) {
    const int i = vertex(rng), j = vertex(rng);
    Eigen::Vector3d w(u(rng), u(rng), u(rng));
    const int v[2] = {i, j};
    const double sign[2] = {1, -1};
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b)
        for (int p = 0; p < 3; ++p)
          for (int q = 0; q < 3; ++q) entries.emplace_back(3 * v[a] + p, 3 * v[b] + q, sign[a] * sign[b] * w[p] * w[q]);
  }
  for (int r = 0; r < 3 * N; ++r) entries.emplace_back(r, r, 1e-3); // the base is not held here
  Eigen::SparseMatrix<double> A(3 * N, 3 * N);
  A.setFromTriplets(entries.begin(), entries.end());

  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, detail::VertexAmdOrdering<int>> blocked(A);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> scalar(A);
  ASSERT_EQ(blocked.info(), Eigen::Success);
  ASSERT_EQ(scalar.info(), Eigen::Success);
  const Eigen::VectorXi order = blocked.permutationPinv().indices();
  ASSERT_EQ(order.size(), 3 * N);
  std::vector<char> seen(3 * N, 0);
  for (int k = 0; k < N; ++k)
    for (int d = 0; d < 3; ++d) {
      EXPECT_EQ(order[3 * k + d], order[3 * k] + d) << "vertex " << order[3 * k] / 3 << " split";
      ++seen[order[3 * k + d]];
    }
  EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](char c) { return c == 1; })) << "not a permutation";

  Eigen::VectorXd b(3 * N);
  for (int r = 0; r < b.size(); ++r) b[r] = u(rng);
  const Eigen::VectorXd x = blocked.solve(b), y = scalar.solve(b);
  EXPECT_LT((A * x - b).norm(), 1e-10 * b.norm());
  EXPECT_LT((x - y).norm(), 1e-9 * y.norm());
}
