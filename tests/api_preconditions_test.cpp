// Library entry points given what they cannot use (hunt 18: a C++ caller, not the CLI): an
// InputError naming the argument, never an out-of-bounds access, a NaN result or a solve that
// runs anyway.
#include <gshell/deform/geometric_texture.h>
#include <gshell/deform/shell_deformer.h>
#include <gshell/deform/synthetic_motion.h>
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/geometry/mesh_topology.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/render/shell_render.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/shell/shell.h>
#include <gshell/solver/hierarchical_solver.h>
#include <gshell/solver/shell_solver.h>

#include "shell_fixtures.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

using namespace gshell;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Expects `call` to throw an InputError whose message contains `fragment`.
template <class Call>
void expect_input_error(Call call, const std::string& fragment) {
  try {
    call();
    ADD_FAILURE() << "no error; expected one with '" << fragment << "'";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << "'" << e.what() << "' lacks '" << fragment << "'";
  }
}

Shell small_shell() { return test::offset_shell(make_sphere(1), 0.1); }

} // namespace

TEST(ApiPreconditions, ARestShellFilledInByHandIsCheckedWhereItIsGiven) {
  Shell bad_face = small_shell();
  bad_face.F(4, 1) = 900; // was a SIGSEGV in the deformer's constructor
  expect_input_error([&] { ShellDeformer d(bad_face); }, "the rest shell: face 4 has vertex id 900 (the base has 42 vertices)");
  expect_input_error([&] { deformation_rest_tets(bad_face); }, "the rest shell: face 4 has vertex id 900");
  Shell short_top = small_shell();
  short_top.top.conservativeResize(20, 3); // was named by a certifier at the first frame
  expect_input_error([&] { ShellDeformer d(short_top); }, "the rest shell: base and top must both be n x 3");
  Shell nan_top = small_shell();
  nan_top.top(7, 2) = kNaN;
  expect_input_error([&] { ShellDeformer d(nan_top); }, "the rest shell: top vertex 7 is not finite");
  Shell no_thickness = small_shell();
  no_thickness.thickness = 0; // the first frame blamed "the new base"
  expect_input_error([&] { ShellDeformer d(no_thickness); }, "the rest shell: thickness must be positive and finite");
  EXPECT_NO_THROW(deformation_rest_tets(no_thickness)); // the mean offset stands in there
  EXPECT_NO_THROW(ShellDeformer{small_shell()});
}

TEST(ApiPreconditions, ArraysOfOtherSizesAreRefusedNotReadPast) {
  const Shell s = small_shell();
  expect_input_error([&] { count_thinned_vertices(s.base, s.top.topRows(5), s.base, s.top); }, "must have one shape");
  EXPECT_EQ(count_thinned_vertices(s.base, s.top, s.base, s.top), 0);

  Eigen::MatrixXi F = s.F;
  F(7, 2) = 100000; // grow_by_rings wrote a byte 100,000 past its flags
  std::vector<char> flags(s.num_base_vertices(), 0);
  flags[F(7, 0)] = 1;
  expect_input_error([&] { grow_by_rings(F, 1, flags); }, "grow_by_rings: F must be m x 3 with ids in [0, 42)");
  grow_by_rings(s.F, 1, flags); // the ring of vertex F(7, 0): itself and its neighbours
  EXPECT_GT(std::count(flags.begin(), flags.end(), 1), 3);

  expect_input_error([&] { motion_frame(Eigen::MatrixXd::Zero(3, 2)); }, "motion_frame: expected n x 3 positions");
  const MotionFrame frame = motion_frame(s.base);
  expect_input_error([&] { bend(s.base, frame, kNaN); }, "bend: the angle must be a finite number");
  expect_input_error([&] { twist(s.base, frame, std::numeric_limits<double>::infinity()); }, "twist: the angle");
  EXPECT_TRUE(bend(s.base, frame, 30).allFinite());
}

TEST(ApiPreconditions, SizesBeyondWhatCanBeHeldAreInputErrorsNotBadAlloc) {
  expect_input_error([] { midpoint_subdivision(make_sphere(0), 40); }, "more faces than a mesh can hold");
  EXPECT_EQ(midpoint_subdivision(make_sphere(0), 2).F.rows(), 20 * 16);
  RenderSubject subject;
  subject.name = "sphere";
  subject.shell = small_shell();
  ShellRenderOptions o;
  o.figure.width = o.figure.height = 100000;
  expect_input_error([&] { render_subjects({subject}, {}, o); }, "is larger than 8192 pixels on a side");
}

TEST(ApiPreconditions, GuardOptionsOutOfRangeAreNamed) {
  GenerateOptions o;
  o.thickness = 0.1;
  o.guard.start_spread = kNaN; // the one guard field not checked
  expect_input_error([&] { o.check(); }, "start_spread");
  o.guard.start_spread = 0.5;
  expect_input_error([&] { o.check(); }, "start_spread");
  o.guard.start_spread = 2;
  EXPECT_NO_THROW(o.check());
}

TEST(ApiPreconditions, TilingCountsBelowOneOrBeyondAnIntAreRefused) {
  const TriMesh tile = make_builtin_tile("builtin:bumps");
  // -2 returned a mesh of -578 rows; 0 an empty one.
  for (const int repeat : {-2, 0})
    expect_input_error([&] { tile_texture_space(tile, repeat, 1, {0, 0}, {1, 1}); }, "repeat needs two counts >= 1");
  expect_input_error([&] { tile_texture_space(tile, 100000, 100000, {0, 0}, {1, 1}); }, "more than a mesh can hold");
  EXPECT_EQ(tile_texture_space(tile, 2, 3, {0, 0}, {1, 1}).V.rows(), 6 * tile.V.rows());
}

TEST(ApiPreconditions, SolverOptionsOutOfRangeAreNamed) {
  const Shell s = small_shell();
  const int n = s.num_base_vertices();
  std::vector<int> base(n);
  std::iota(base.begin(), base.end(), 0);
  const ShellSolver solver(normal_prism_rest_tets(s.base, s.F, s.thickness), 2 * n, base);
  Eigen::MatrixXd X = s.vertices();
  for (const double tolerance : {kNaN, -1.0}) { // a NaN tolerance never held: the solve ran on, "converged"
    SolveOptions o;
    o.tolerance = tolerance;
    expect_input_error([&] { solver.solve(X, o); }, "ShellSolver::solve: the tolerance must be a number >= 0");
  }

  PositionConstraints handles;
  handles.vertices = {0, 1, 2, n + 5};
  const RestTets rest = deformation_rest_tets(s);
  auto with = [&](auto change, const std::string& fragment) {
    HierarchyOptions o;
    change(o);
    expect_input_error([&] { HierarchicalSolver h(rest, s.vertices(), s.F, handles, o); }, fragment);
  };
  // A negative weight was std::runtime_error "not positive definite"; NaN an error from inside a step.
  with([](HierarchyOptions& o) { o.reduced_hard_weight = -100; }, "options.reduced_hard_weight must be positive");
  with([](HierarchyOptions& o) { o.reduced_hard_weight = kNaN; }, "options.reduced_hard_weight must be positive");
  with([](HierarchyOptions& o) { o.splits_per_level = 0; }, "options.splits_per_level must be >= 1 (got 0)");
  with([](HierarchyOptions& o) { o.coarse_period = -3; }, "options.coarse_period must be >= 1 (got -3)");
  with([](HierarchyOptions& o) { o.level_iterations = -1; }, "options.level_iterations must be >= 0 (got -1)");
  with([](HierarchyOptions& o) { o.min_cluster_size = 0; }, "options.min_cluster_size must be >= 1 (got 0)");
  with([](HierarchyOptions& o) { o.level_tolerance = 2; }, "options.level_tolerance must be in [0, 1]");
  EXPECT_NO_THROW(HierarchicalSolver(rest, s.vertices(), s.F, handles));
  HierarchicalSolver h(rest, s.vertices(), s.F, handles);
  SolveOptions o;
  o.tolerance = kNaN;
  Eigen::MatrixXd targets(4, 3);
  for (int r = 0; r < 4; ++r) targets.row(r) = X.row(handles.vertices[r]);
  expect_input_error([&] { h.solve(X, targets, o); }, "HierarchicalSolver::solve: the tolerance must be a number >= 0");
}
