// Valid deformation frames (issue 14): every frame of a guarded ShellDeformer is certified valid
// (exact certificate: no inverted tet, no top/top, top/base or wall intersection), through bends
// to 150 degrees, a single far jump (sub-steps) and a fold that presses the top into itself; and
// allow_invalid reproduces the unguarded frames bit for bit; pose steps stay valid and stop at
// contact when the handles force a collision.
#include <gshell/deform/handles.h>
#include <gshell/deform/pose.h>
#include <gshell/error.h>
#include <gshell/deform/shell_deformer.h>
#include <gshell/run/deform_run.h>
#include <gshell/run/drag_session.h>
#include <gshell/run/pose_run.h>
#include <gshell/deform/synthetic_motion.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/geometry/mesh_topology.h>
#include <gshell/guard/extrusion_directions.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/quality/stretch.h>
#include <gshell/quality/shell_boundary.h>
#include <memory>
#include <gshell/quality/triangle_intersections.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/solver/shell_solver.h>

#include <gtest/gtest.h>
#include "deform/frame_guard.h"
#include "shell_fixtures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numeric>
#include <string>

namespace gshell {
namespace {

using test::flat_plane_shell;
using test::offset_shell;
using test::lifted_shell;

// The deformer's system: the n base vertices of a 2n-vertex shell kept, the tops free.
ShellSolver base_fixed_solver(const RestTets& rest_tets, int n) {
  return ShellSolver(rest_tets, 2 * n, test::vertex_range(0, n));
}

StretchStats offset_stretch(const ShellDeformer& deformer, const Eigen::MatrixXd& base) {
  const Shell& rest = deformer.rest_shell();
  Eigen::MatrixXd X(2 * base.rows(), 3);
  X << base, offset_top(base, rest.F, rest.thickness);
  return stretch_stats(deformer.rest_tets(), X);
}

// Certifies the frame independently of the deformer's own report.
void expect_valid_frame(const ShellDeformer& deformer, const FrameResult& r, const Eigen::MatrixXd& base) {
  const ShellCertificate c = certify_shell(base, r.top, deformer.rest_shell().F);
  EXPECT_EQ(c.inverted_tets, 0);
  EXPECT_EQ(c.top_self_intersections, 0);
  EXPECT_EQ(c.top_base_intersections, 0);
  EXPECT_EQ(c.wall_intersections, 0);
  EXPECT_TRUE(r.valid);
  EXPECT_TRUE(r.certificate.valid());
  EXPECT_EQ(r.certificate.inverted_tets, 0);
  EXPECT_EQ((deformer.current().topRows(base.rows()) - base).cwiseAbs().maxCoeff(), 0.0); // the frame's base, exactly
}

// Bends a thick shell to 150 degrees in `frames` frames: all valid, stretch below re-extruding.
void bend_to_150(const Shell& rest, int frames, double band, int* unguarded_invalid) {
  const MotionFrame frame = motion_frame(rest.base);
  ShellDeformer guarded(rest), unguarded(rest);
  DeformOptions loose;
  loose.allow_invalid = true;
  *unguarded_invalid = 0;
  for (int k = 1; k <= frames; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    const Eigen::MatrixXd base = bend(rest.base, frame, 150.0 * ramp(k, frames), band);
    const FrameResult r = guarded.solve(base);
    expect_valid_frame(guarded, r, base);
    const StretchStats offset = offset_stretch(guarded, base);
    EXPECT_LT(r.stretch.volume_mean, offset.volume_mean);
    *unguarded_invalid += unguarded.solve(base, loose).certificate.valid() ? 0 : 1;
  }
}

TEST(DeformGuard, PlaneBentTo150DegreesStaysValidAndStretchesLessThanOffset) {
  int unguarded_invalid = 0;
  bend_to_150(flat_plane_shell(16, 0.2), 6, 0.3, &unguarded_invalid);
  // The case is hard enough: the paper's frames break validity on their own.
  EXPECT_GT(unguarded_invalid, 0);
}

TEST(DeformGuard, CylinderBentTo150DegreesStaysValidAndStretchesLessThanOffset) {
  int unguarded_invalid = 0;
  bend_to_150(offset_shell(make_cylinder(16, 0.25, 3.0), 0.15), 6, 0.4, &unguarded_invalid);
}

// One handle: the base and top vertices of the shell's end where side * x > from (side -1 or 1).
Handle x_end_handle(const Shell& rest, int side, double from) {
  const int n = rest.num_base_vertices();
  Handle h;
  for (int i = 0; i < n; ++i)
    if (side * rest.base(i, 0) > from) h.vertices.insert(h.vertices.end(), {i, n + i});
  std::sort(h.vertices.begin(), h.vertices.end());
  return h;
}

// A plane's shell with the top of its middle vertex (an interior one; id in *v) pressed onto the
// base to 1e-13 of the thickness.
Shell plane_shell_with_a_pressed_top(int* v) {
  Shell rest = flat_plane_shell(16, 0.2);
  *v = 0;
  for (int i = 1; i < rest.num_base_vertices(); ++i)
    if (rest.base.row(i).head<2>().squaredNorm() < rest.base.row(*v).head<2>().squaredNorm()) *v = i;
  rest.top.row(*v) = rest.base.row(*v) + 1e-13 * (rest.top.row(*v) - rest.base.row(*v));
  return rest;
}

TEST(DeformGuard, TetsFlatToRoundingErrorAtRestDoNotHoldTheFramesStill) {
  // One top vertex pressed onto the base: its tets are positive but flat to rounding error, so no
  // floating-point step bound keeps their sign. They stay out of the guard; every frame is solved
  // (no internal error), and whatever the frames break is theirs.
  int v = 0;
  const Shell rest = plane_shell_with_a_pressed_top(&v);
  const int n = rest.num_base_vertices();
  const Eigen::MatrixXi T = build_prism_tets(rest.F, n);
  const MotionFrame frame = motion_frame(rest.base);
  ShellDeformer deformer(rest);
  for (int k = 1; k <= 4; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    const Eigen::MatrixXd base = bend(rest.base, frame, 120.0 * ramp(k, 4), 0.4);
    FrameResult r;
    ASSERT_NO_THROW(r = deformer.solve(base));
    EXPECT_NE(r.method, FrameMethod::Failed);
    const ShellCertificate c = certify_shell(base, r.top, rest.F);
    for (int t : c.inverted_tet_ids) EXPECT_TRUE((T.row(t).array() == n + v).any()) << "tet " << t;
  }
}

// DeformOptions whose refused frames are always dragged (no mend first), for the drag's own tests.
DeformOptions drag_only() {
  DeformOptions o;
  o.guard.mend_rings = -1;
  return o;
}

// The stages a solve named (DeformOptions::stage, SolveOptions::stage) and the progress calls
// within each, for tests of what a progress line says.
struct StageLog {
  std::vector<std::string> names;
  std::vector<int> iterations; ///< progress calls after each name

  template <class Options> void hook(Options& options) {
    options.stage = [this](const char* name) {
      names.emplace_back(name);
      iterations.push_back(0);
    };
    options.progress = [this](int, double, double) {
      ASSERT_FALSE(names.empty()) << "an iteration before any stage was named";
      ++iterations.back();
    };
  }
  // Every "drag K/N" named, in order: N the same throughout, K running 1..N (a retried sub-step
  // may be named again). Returns N (0: no drag).
  int drag_substeps() const {
    int last = 0, of = 0;
    for (const std::string& name : names) {
      int k = 0, n = 0;
      if (std::sscanf(name.c_str(), "drag %d/%d", &k, &n) != 2) continue;
      EXPECT_TRUE(of == 0 || n == of) << name;
      EXPECT_TRUE(k == last || k == last + 1) << name << " after drag " << last;
      last = k;
      of = n;
    }
    EXPECT_EQ(last, of);
    return of;
  }
};

TEST(DeformGuard, AFarJumpIsValidThroughSubsteps) {
  const Shell rest = flat_plane_shell(16, 0.2);
  ShellDeformer deformer(rest);
  const Eigen::MatrixXd base = bend(rest.base, motion_frame(rest.base), 150.0, 0.3);
  const FrameResult r = deformer.solve(base, drag_only());
  expect_valid_frame(deformer, r, base);
  EXPECT_EQ(r.method, FrameMethod::Guarded);
  EXPECT_GT(r.substeps, 1);
  // The reported energy is that of the frame returned, not of the solve the guard replaced.
  const double returned = base_fixed_solver(deformer.rest_tets(), rest.num_base_vertices()).energy(deformer.current());
  EXPECT_NEAR(r.energy.back(), returned, 1e-9 * returned);
}

// A frame that turns the whole shell by 180 degrees is solved exactly by the paper's solve (every
// prism keeps its shape), and that frame is valid, but the straight path to it flattens every tet
// half-way: it was dragged over 20 sub-steps (minutes on 10K vertices). The end is what counts.
TEST(DeformGuard, AShellTurnedHalfwayRoundIsTakenAsThePapersSolveMadeIt) {
  const Shell rest = test::sphere_shell(2, 0.1);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(M_PI, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  const Eigen::RowVector3d shift(0.3, -0.2, 0.5);
  const Eigen::MatrixXd base = (rest.base * R.transpose()).rowwise() + shift;
  ShellDeformer deformer(rest);
  const FrameResult r = deformer.solve(base);
  expect_valid_frame(deformer, r, base);
  EXPECT_EQ(r.method, FrameMethod::Bounded);
  EXPECT_EQ(r.guarded_iterations, 0);
  const Eigen::MatrixXd turned_top = (rest.top * R.transpose()).rowwise() + shift;
  EXPECT_LT((r.top - turned_top).cwiseAbs().maxCoeff(), 1e-6);
}

// The sub-steps before the last only keep the drag near the path of minima: solved to 1e-3 rather
// than the frame's 1e-6, the frame ends at the same energy (both run until converged).
TEST(DeformGuard, SubStepsSolvedLooselyEndWhereTightOnesDoInFewerIterations) {
  const Shell rest = flat_plane_shell(16, 0.2);
  const Eigen::MatrixXd base = bend(rest.base, motion_frame(rest.base), 150.0, 0.3);
  DeformOptions tight = drag_only(), loose = drag_only();
  tight.tolerance = loose.tolerance = 1e-6;
  tight.max_iterations = loose.max_iterations = 1000;
  tight.substep_tolerance = tight.tolerance; // every sub-step to the frame's tolerance
  ShellDeformer a(rest), b(rest);
  const FrameResult t = a.solve(base, tight), l = b.solve(base, loose);
  ASSERT_EQ(t.method, FrameMethod::Guarded);
  ASSERT_EQ(l.method, FrameMethod::Guarded);
  EXPECT_EQ(l.substeps, t.substeps);
  expect_valid_frame(b, l, base);
  EXPECT_LT(l.guarded_iterations, t.guarded_iterations);
  EXPECT_NEAR(l.energy.back(), t.energy.back(), 1e-5 * t.energy.back());
}

// Progress names each of a frame's solves, whose iteration counts each start from 1: a user
// watching a guarded frame sees which sub-step of how many it is in.
TEST(DeformGuard, EachSolveOfAGuardedFrameIsNamedForProgress) {
  const Shell rest = flat_plane_shell(16, 0.2);
  const Eigen::MatrixXd base = bend(rest.base, motion_frame(rest.base), 150.0, 0.3);
  {
    SCOPED_TRACE("dragged");
    StageLog log;
    DeformOptions options = drag_only();
    log.hook(options);
    ShellDeformer deformer(rest);
    const FrameResult r = deformer.solve(base, options);
    ASSERT_EQ(r.method, FrameMethod::Guarded);
    ASSERT_FALSE(log.names.empty());
    ASSERT_GE(log.names.size(), 3u);
    EXPECT_EQ(log.names[0], "paper");
    EXPECT_EQ(log.iterations[0], r.iterations);
    // The guard's setup (the first frame's) and test of the paper's frame: named, no iterations
    // of their own.
    EXPECT_EQ(log.names[1], "guard setup");
    EXPECT_EQ(log.iterations[1], 0);
    EXPECT_EQ(log.names[2], "guard");
    EXPECT_EQ(log.iterations[2], 0);
    EXPECT_EQ(log.drag_substeps(), r.substeps);
    int dragged = 0;
    for (std::size_t k = 1; k < log.names.size(); ++k) dragged += log.iterations[k];
    EXPECT_EQ(dragged, r.guarded_iterations);
  }
  {
    SCOPED_TRACE("mended");
    StageLog log;
    DeformOptions options;
    log.hook(options);
    ShellDeformer deformer(rest);
    const FrameResult r = deformer.solve(base, options);
    ASSERT_EQ(r.method, FrameMethod::Mended);
    EXPECT_EQ(log.names, (std::vector<std::string>{"paper", "guard setup", "guard", "mend"}));
    // A second frame has its guard built already.
    log = StageLog{};
    log.hook(options);
    deformer.solve(base, options);
    EXPECT_EQ(log.names.at(1), "guard");
  }
}

// Building the guard is setup, timed apart from the frame that builds it: the first guarded
// frame, and a frame whose guard options differ from those it was built with; never an
// unguarded frame.
TEST(DeformGuard, BuildingTheGuardIsTimedApartFromTheFrames) {
  const Shell rest = flat_plane_shell(16, 0.2);
  ShellDeformer deformer(rest);
  DeformOptions unguarded;
  unguarded.allow_invalid = true;
  const MotionFrame frame = motion_frame(rest.base);
  EXPECT_EQ(deformer.solve(bend(rest.base, frame, 10.0, 0.3), unguarded).guard_setup_seconds, 0);
  const FrameResult first = deformer.solve(bend(rest.base, frame, 20.0, 0.3));
  EXPECT_GT(first.guard_setup_seconds, 0);
  EXPECT_GE(first.seconds, 0); // the frame's own time, the setup taken out
  EXPECT_EQ(deformer.solve(bend(rest.base, frame, 30.0, 0.3)).guard_setup_seconds, 0);
  DeformOptions other;
  other.guard.contact_weight *= 2;
  EXPECT_GT(deformer.solve(bend(rest.base, frame, 40.0, 0.3), other).guard_setup_seconds, 0);
}

// The same far jump, refused, is mended where the paper's solve went wrong instead of dragged
// there in sub-steps: valid, with the drag's energy to 1 %, in fewer guarded iterations.
TEST(DeformGuard, AFarJumpRefusedIsMendedInPlaceNearTheDragsMinimum) {
  const Shell rest = flat_plane_shell(16, 0.2);
  const Eigen::MatrixXd base = bend(rest.base, motion_frame(rest.base), 150.0, 0.3);
  ShellDeformer mending(rest), dragging(rest);
  const FrameResult m = mending.solve(base), d = dragging.solve(base, drag_only());
  ASSERT_EQ(d.method, FrameMethod::Guarded);
  ASSERT_GT(d.substeps, 1);
  EXPECT_EQ(m.method, FrameMethod::Mended);
  expect_valid_frame(mending, m, base);
  EXPECT_EQ(m.substeps, 0);
  EXPECT_LT(m.guarded_iterations, d.guarded_iterations);
  EXPECT_NEAR(m.energy.back(), d.energy.back(), 0.01 * d.energy.back());
  const double returned = base_fixed_solver(mending.rest_tets(), rest.num_base_vertices()).energy(mending.current());
  EXPECT_NEAR(m.energy.back(), returned, 1e-9 * returned);
  // The next frame goes on from the mended one as from any valid frame.
  const FrameResult next = mending.solve(bend(rest.base, motion_frame(rest.base), 155.0, 0.3));
  expect_valid_frame(mending, next, bend(rest.base, motion_frame(rest.base), 155.0, 0.3));
}

// Allowed no rise above the paper's energy, the far jump's mend is kept aside, the drag runs too
// (its iterations counted) and the frame is whichever valid state is lower.
TEST(DeformGuard, AMendAboveThePapersEnergyIsComparedWithTheDrag) {
  const Shell rest = flat_plane_shell(16, 0.2);
  const Eigen::MatrixXd base = bend(rest.base, motion_frame(rest.base), 150.0, 0.3);
  DeformOptions strict;
  strict.guard.mend_max_rise = 0;
  ShellDeformer mending(rest), dragging(rest), both(rest);
  const FrameResult m = mending.solve(base), d = dragging.solve(base, drag_only()), s = both.solve(base, strict);
  ASSERT_EQ(m.method, FrameMethod::Mended);
  ASSERT_EQ(d.method, FrameMethod::Guarded);
  expect_valid_frame(both, s, base);
  EXPECT_GT(s.guarded_iterations, m.guarded_iterations);
  const bool mend_lower = m.energy.back() < d.energy.back();
  EXPECT_EQ(s.method, mend_lower ? FrameMethod::Mended : FrameMethod::Guarded);
  EXPECT_DOUBLE_EQ(s.energy.back(), std::min(m.energy.back(), d.energy.back()));
}

// A refused frame the drag reaches in one sub-step is dragged: from a frame that close, one
// guarded solve with the guard's own factor costs less than the mend's solver.
TEST(DeformGuard, ARefusedFrameOneSubStepAwayIsDraggedNotMended) {
  const Shell rest = flat_plane_shell(16, 0.2);
  const MotionFrame frame = motion_frame(rest.base);
  ShellDeformer deformer(rest);
  int refused = 0;
  for (int k = 1; k <= 30; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    const Eigen::MatrixXd base = bend(rest.base, frame, 150.0 * ramp(k, 30), 0.3);
    const FrameResult r = deformer.solve(base);
    expect_valid_frame(deformer, r, base);
    EXPECT_NE(r.method, FrameMethod::Mended);
    if (r.method == FrameMethod::Guarded) {
      ++refused;
      EXPECT_EQ(r.substeps, 1);
    }
  }
  EXPECT_GT(refused, 0); // else the rule was not exercised
}

TEST(DeformGuard, SubStepToleranceOutsideZeroToOneIsAnInputError) {
  const Shell rest = flat_plane_shell(4, 0.2);
  ShellDeformer deformer(rest);
  for (double bad : {0.0, 1.0, -1e-3, std::nan("")}) {
    DeformOptions options;
    options.substep_tolerance = bad;
    EXPECT_THROW(deformer.solve(rest.base, options), InputError) << bad;
  }
}

// Folds a plane (thickness 0.2) by `degrees` in a band whose arc radius R = 0.6 / angle is below
// the thickness (0.19 at 180 degrees): the top on the concave side must thin. Shut (180 degrees)
// the bases of the two halves stay 2R = 0.38 apart (the base never touches itself), but their
// tops, 0.2 above each base on the inner side, would overlap by 0.02: the top must thin along the
// whole fold, pressed against itself. In `frames` frames (1: a jump from rest).
void fold_plane(double degrees, int frames) {
  const double eta = 0.2;
  const Shell rest = flat_plane_shell(16, eta);
  const MotionFrame frame = motion_frame(rest.base);
  ShellDeformer deformer(rest), unguarded(rest);
  DeformOptions loose;
  loose.allow_invalid = true;
  int unguarded_invalid = 0;
  for (int k = 1; k <= frames; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    const Eigen::MatrixXd base = bend(rest.base, frame, degrees * ramp(k, frames), 0.3);
    const FrameResult r = deformer.solve(base);
    expect_valid_frame(deformer, r, base);
    EXPECT_NE(r.method, FrameMethod::TetsOnly);
    EXPECT_EQ(r.certificate.base_self_intersections, 0);
    unguarded_invalid += unguarded.solve(base, loose).certificate.valid() ? 0 : 1;
    if (k < frames) continue;
    EXPECT_GT(r.thinned_vertices, 20);
    if (degrees < 180) continue;
    // Shut: the halves' straight parts (beyond the band) lie in the planes x = -R and x = R,
    // tops inside; every top vertex there must be closer to its base across the gap than R.
    const int n = rest.num_base_vertices();
    const double R = 0.6 / M_PI;
    int straight = 0;
    double widest = 0;
    for (int i = 0; i < n; ++i) {
      if (std::abs(rest.base(i, 0)) < 0.35) continue;
      ++straight;
      EXPECT_NEAR(std::abs(base(i, 0)), R, 1e-9);
      widest = std::max(widest, -std::copysign(1.0, base(i, 0)) * (r.top(i, 0) - base(i, 0)));
    }
    EXPECT_GT(straight, 0);
    EXPECT_LT(widest, R);
    EXPECT_GT(widest, 0.5 * R); // thinned where it must, not flattened
  }
  EXPECT_GT(unguarded_invalid, 0);
}

TEST(DeformGuard, FoldingAPlaneNearlyShutThinsTheTopAndKeepsItClean) { fold_plane(170.0, 7); }

TEST(DeformGuard, FoldingAPlaneShutThinsTheTopAndKeepsItClean) { fold_plane(180.0, 8); }

TEST(DeformGuard, AJumpFromRestToAShutFoldIsValid) { fold_plane(180.0, 1); }

// A sliver base face (CGAL's triceratops has two) turns its normal sideways under a base motion
// far smaller than the shell, and the top over it must swing across to keep its tets positive:
// the drag from the previous frame stalls there, but the frame itself has valid shells. Here a
// plane's interior vertex sits 1e-6 from the opposite edge of one of its faces, then rises 1e-5
// and moves 1.1e-5 across that edge's line: that face turns by 135 degrees (never flat on the
// way), every other face by less than 0.01; the tops (0.1 above) must tilt by at least 45 degrees.
TEST(DeformGuard, ASliverWhoseNormalTurnsSidewaysStillGivesAValidFrame) {
  TriMesh plane = make_plane(6);
  int face = -1, apex = -1;
  for (int f = 0; f < plane.F.rows() && face < 0; ++f)
    for (int k = 0; k < 3 && face < 0; ++k) {
      const Eigen::RowVector3d v = plane.V.row(plane.F(f, k));
      if (std::abs(v(0)) < 0.5 && std::abs(v(1)) < 0.5) face = f, apex = k; // an interior vertex
    }
  ASSERT_GE(face, 0);
  const int v = plane.F(face, apex), a = plane.F(face, (apex + 1) % 3), b = plane.F(face, (apex + 2) % 3);
  const Eigen::RowVector3d mid = 0.5 * (plane.V.row(a) + plane.V.row(b));
  const Eigen::RowVector3d inward = (plane.V.row(v) - mid).normalized();
  plane.V.row(v) = mid + 1e-6 * inward; // the face (v, a, b) is now a sliver of height 1e-6
  const Shell rest = lifted_shell(plane, 0.1);
  ASSERT_TRUE(certify_shell(rest.base, rest.top, rest.F).valid());
  Eigen::MatrixXd base = rest.base;
  base.row(v) += -1.1e-5 * inward + Eigen::RowVector3d(0, 0, 1e-5);
  ShellDeformer deformer(rest);
  const FrameResult r = deformer.solve(base);
  expect_valid_frame(deformer, r, base);
  // Made afresh as soon as the drag first stalled: within one attempt's iterations, not after the
  // retry and the tets-only drag (143 iterations here when they came first).
  EXPECT_EQ(r.method, FrameMethod::Regenerated);
  EXPECT_TRUE(r.fresh_top);
  EXPECT_LE(r.guarded_iterations, DeformOptions{}.max_iterations * r.substeps);
}

// A motion can make a vertex unextrudable that was not at rest (CGAL's anchor under a twist): its
// faces then point every way, one tet of its prisms must invert, and a guard that keeps them all
// positive holds the frame back (the anchor's frame failed with 84 inverted tets). Here a flat fan
// of six faces rises into a cone whose rim, seen from the apex, is a hexagon no point sees whole
// (found by a random search over hexagons that stay simple on the way): the apex is unextrudable
// in the last frame up. The base never crosses itself; every frame stays clean and may invert only
// the tets the apex forces.
TEST(DeformGuard, AVertexTheMotionMakesUnextrudableKeepsTheFramesGuarded) {
  TriMesh fan;
  fan.V.resize(7, 3);
  fan.F.resize(6, 3);
  // The apex has the largest id, so that each prism's tet over its whole base face has the apex's
  // top (build_prism_tets): with the apex unextrudable, one of them must invert.
  constexpr int kApex = 6;
  fan.V.row(kApex).setZero();
  for (int k = 0; k < 6; ++k) {
    fan.V.row(k) << std::cos(k * M_PI / 3), std::sin(k * M_PI / 3), 0;
    fan.F.row(k) << k, (k + 1) % 6, kApex;
  }
  const Shell rest = lifted_shell(fan, 0.02);
  const double rim[6][2] = {{1.16, -1.36}, {0.47, 0.74}, {0.4, -0.4}, {-0.08, 0.23}, {-0.6, -1.42}, {-0.37, -0.91}};
  const auto frame_base = [&](double t) {
    Eigen::MatrixXd base = rest.base;
    base(kApex, 2) = t; // the apex rises to 1 above the rim's plane
    for (int k = 0; k < 6; ++k)
      for (int c = 0; c < 2; ++c) base(k, c) += t * (rim[k][c] - rest.base(k, c));
    return base;
  };
  ASSERT_EQ(extrusion_directions(frame_base(1.0), rest.F).unextrudable, std::vector<int>{kApex});
  const int n = rest.num_base_vertices();
  const Eigen::MatrixXi tets = build_prism_tets(rest.F, n);
  ShellDeformer deformer(rest);
  constexpr int kFrames = 8;
  // Up to the cone, and back down (a skinned base's moment of trouble): a frame after the apex
  // is extrudable again must not keep the tet it inverted (left out for good, it stayed inverted
  // in every later frame).
  for (int i = 1; i <= 2 * kFrames - 2; ++i) {
    const Eigen::MatrixXd base = frame_base(static_cast<double>(i <= kFrames ? i : 2 * kFrames - i) / kFrames);
    const FrameResult r = deformer.solve(base);
    const ShellCertificate c = certify_shell(base, r.top, rest.F);
    const bool unextrudable = !extrusion_directions(base, rest.F).unextrudable.empty();
    EXPECT_NE(r.method, FrameMethod::Failed) << "frame " << i;
    EXPECT_TRUE(c.intersections.empty()) << "frame " << i;
    if (!unextrudable) EXPECT_EQ(c.inverted_tets, 0) << "frame " << i;
    // The frame names the vertex that makes it invalid (and nothing while it is valid).
    EXPECT_EQ(r.unextrudable_vertices, r.valid ? std::vector<int>{} : std::vector<int>{kApex}) << "frame " << i;
    EXPECT_EQ(r.valid, c.valid()) << "frame " << i;
    // The first frame down starts from the last clean one, not from the cone, whose inverted
    // tet it would otherwise leave out as the cone's frame did (on CGAL's homer that kept one
    // inverted tet through every later frame).
    if (i == kFrames + 1) EXPECT_TRUE(r.resumed);
    // Only tets over a whole base face with the apex's top, those the apex forces (without the
    // apex left out: 3-4 inverted tets elsewhere too and 12 intersecting pairs, frames failed).
    for (int t : c.inverted_tet_ids) {
      const int f = t / 3;
      int corners = 0;
      for (int k = 0; k < 4; ++k)
        for (int v : {rest.F(f, 0), rest.F(f, 1), rest.F(f, 2), n + kApex}) corners += tets(t, k) == v;
      EXPECT_EQ(corners, 4) << "frame " << i << ": tet " << t << " inverted";
    }
  }
}

// A base that crosses itself has no clean top near its crossings, but everywhere else it has
// (as guarded generation keeps it): of two facing sheets 0.1 apart, the upper one is dented
// through the lower one at one vertex. The frame is one the guard stands by (guarded or made
// afresh: every tet positive, and each intersecting pair of its certificate has a triangle over
// a face next to the base's crossings). Before, the drag stalled against the crossing, the fresh
// top was refused for the pairs there, and the frame was the tets-only drag's.
TEST(DeformGuard, ABaseCrossingItselfLeavesTheTopCleanAwayFromItsCrossings) {
  const Shell rest = offset_shell(test::facing_sheets(8, 0.1), 0.03);
  const int n = rest.num_base_vertices();
  int dent = -1;
  for (int v = n / 2; v < n && dent < 0; ++v)
    if (rest.base.row(v).head<2>().norm() < 1e-9) dent = v; // the upper sheet's centre
  ASSERT_GE(dent, 0);
  Eigen::MatrixXd crossed = rest.base;
  crossed(dent, 2) = -0.05;
  ShellDeformer deformer(rest);
  const FrameResult r = deformer.solve(crossed);
  const ShellCertificate c = certify_shell(crossed, r.top, rest.F);
  ASSERT_GT(c.base_self_intersections, 0);
  EXPECT_FALSE(r.valid);
  EXPECT_TRUE(r.method == FrameMethod::Guarded || r.method == FrameMethod::Regenerated)
      << frame_method_name(r.method);
  EXPECT_EQ(c.inverted_tets, 0);
  std::vector<char> near(n, 0);
  for (const auto& [f, g] : surface_self_intersections(crossed, rest.F))
    for (int k = 0; k < 3; ++k) near[rest.F(f, k)] = near[rest.F(g, k)] = 1;
  const ShellBoundary boundary = shell_boundary(rest.F, n);
  const auto next_to_crossing = [&](int row) {
    const int f = boundary.face[row];
    return near[rest.F(f, 0)] || near[rest.F(f, 1)] || near[rest.F(f, 2)];
  };
  int away = 0;
  for (const BoundaryIntersection& pair : c.intersections)
    away += !next_to_crossing(pair.a) && !next_to_crossing(pair.b);
  EXPECT_EQ(away, 0) << "of " << c.intersections.size() << " intersecting pairs";
}

// Two sheets 0.1 apart with layers 0.08 thick: each top passes through the other layer's side
// walls, a rest shell that is not valid (as `--allow-invalid` or `offset` make). The guard leaves
// those faults out; a frame that only carries them along (the whole shell translated) keeps them
// and says they are the rest shell's, where a valid rest shell's frame has no such flag.
TEST(DeformGuard, AFrameInvalidOnlyWhereTheRestShellIsSaysSo) {
  const Shell rest = offset_shell(test::facing_sheets(8, 0.1), 0.08);
  const ShellCertificate at_rest = certify_shell(rest.base, rest.top, rest.F);
  ASSERT_FALSE(at_rest.valid());
  ASSERT_EQ(at_rest.inverted_tets, 0);
  Eigen::MatrixXd moved = rest.base;
  moved.col(0).array() += 0.3;
  ShellDeformer deformer(rest);
  const FrameResult r = deformer.solve(moved);
  EXPECT_FALSE(r.valid);
  EXPECT_FALSE(r.certificate.intersections.empty());
  EXPECT_TRUE(r.rest_faults_only) << frame_method_name(r.method);
  DeformRun run;
  run.frames.push_back({1, "moved.obj", r, {}});
  ASSERT_EQ(run.warnings().size(), 1u);
  EXPECT_EQ(run.warnings()[0], "1 of 1 frames is not valid: frame 1 keeps the rest shell's own faults (report.json "
                               "has each frame's certificate)");

  const Shell clean = offset_shell(test::facing_sheets(8, 0.1), 0.03);
  ShellDeformer clean_deformer(clean);
  const FrameResult c = clean_deformer.solve(moved);
  EXPECT_TRUE(c.valid);
  EXPECT_FALSE(c.rest_faults_only);
}

// The prisms around the rest shell's own intersections are left out of the guard with their
// triangles: guarding their tets, between sheets that cross there, held drags back (CGAL's
// mannequin-devil posed: not done in 600 s, 2-3 minutes now). Two sheets 0.1 apart with
// layers 0.08 thick cross at their borders only. A top pushed through its base at a vertex of an
// intersecting pair inverts tets the guard leaves out, and the frame is accepted; the same at a
// vertex far from the crossings, or at that vertex of the same sheets with a clean layer (0.03),
// is refused.
TEST(FrameGuardStart, PrismsAroundTheRestShellsIntersectionsAreLeftOut) {
  const TriMesh sheets = test::facing_sheets(8, 0.1);
  const Shell thick = offset_shell(sheets, 0.08);
  const int n = thick.num_base_vertices();
  const ShellBoundary boundary = shell_boundary(thick.F, n);
  std::vector<char> crossing(n, 0);
  for (const BoundaryIntersection& pair : certify_shell(thick.base, thick.top, thick.F).intersections)
    for (int row : {pair.a, pair.b})
      for (int k = 0; k < 3; ++k) crossing[boundary.F(row, k) % n] = 1;
  // On the lower sheet (z = 0, its layer above it): a vertex of a crossing pair, and the centre.
  int at = -1, away = -1;
  for (int i = 0; i < n / 2; ++i) {
    if (at < 0 && crossing[i]) at = i;
    if (away < 0 && thick.base.row(i).head<2>().norm() < 1e-9) away = i;
  }
  ASSERT_GE(at, 0);
  ASSERT_GE(away, 0);
  ASSERT_FALSE(crossing[away]);
  const auto pushed_through_accepted = [&](double eta, int v) {
    const Shell rest = offset_shell(sheets, eta);
    const RestTets tets = deformation_rest_tets(rest);
    FrameGuard guard(rest, std::make_shared<const RestTets>(tets), frame_guard_options(), test::vertex_range(0, n), false);
    const Eigen::MatrixXd X0 = rest.vertices();
    Eigen::MatrixXd X1 = X0;
    X1(n + v, 2) = -0.1;
    ShellCertificate c;
    const bool accepted = guard.accepts(X0, X1, true, &c);
    EXPECT_GT(c.inverted_tets, 0);
    return accepted;
  };
  EXPECT_TRUE(pushed_through_accepted(0.08, at));
  EXPECT_FALSE(pushed_through_accepted(0.08, away));
  EXPECT_FALSE(pushed_through_accepted(0.03, at));
}

// Rolled up by 900 degrees in one frame within a band of 0.3, the plane's base winds through
// itself two and a half times: no drag reaches it, not even with the tets alone, and the paper's
// solve inverts tets on the straight path to it. The frame fails either way; what it returns is
// the one of the paper's solve and the top made afresh over the new base that has fewer inverted
// tets (here the fresh top, with none).
TEST(DeformGuard, AFrameNothingValidReachesReturnsTheStateWithFewerInvertedTets) {
  const Shell rest = flat_plane_shell(12, 0.2);
  const Eigen::MatrixXd rolled = bend(rest.base, motion_frame(rest.base), 900.0, 0.3);
  ShellDeformer guarded(rest), unguarded(rest);
  DeformOptions loose;
  loose.allow_invalid = true;
  const FrameResult r = guarded.solve(rolled), paper = unguarded.solve(rolled, loose);
  ASSERT_EQ(r.method, FrameMethod::Failed);
  EXPECT_FALSE(r.valid);
  const ShellCertificate returned = certify_shell(rolled, r.top, rest.F), solved = certify_shell(rolled, paper.top, rest.F);
  EXPECT_GT(solved.inverted_tets, 0);
  EXPECT_LT(returned.inverted_tets, solved.inverted_tets);
  EXPECT_EQ(returned.inverted_tets, r.certificate.inverted_tets) // the report describes what is returned
      << "paper's solve: " << solved.inverted_tets;
  EXPECT_TRUE(r.fresh_top); // and says which state it is
  EXPECT_FALSE(paper.fresh_top);
}

TEST(DeformGuard, AFrameAfterAnInvalidOneStartsFromTheLastValidState) {
  // Folded on to 240 degrees, the plane's base crosses itself: no valid frame exists, the guard
  // keeps the tets alone. Folded back to 180 degrees (shut, the base clear of itself, the top
  // pressed against itself), a valid frame exists again; it must be dragged from the last valid
  // state, not from the invalid frame before it, whose tops already pass through each other.
  const Shell rest = flat_plane_shell(16, 0.2);
  const MotionFrame frame = motion_frame(rest.base);
  ShellDeformer deformer(rest);
  const Eigen::MatrixXd crossed = bend(rest.base, frame, 240.0, 0.3);
  const FrameResult first = deformer.solve(crossed);
  EXPECT_FALSE(first.valid);
  EXPECT_FALSE(first.resumed);
  EXPECT_GT(first.certificate.base_self_intersections, 0);
  EXPECT_EQ(first.certificate.inverted_tets, 0);
  const Eigen::MatrixXd shut = bend(rest.base, frame, 180.0, 0.3);
  const FrameResult second = deformer.solve(shut);
  EXPECT_TRUE(second.resumed);
  expect_valid_frame(deformer, second, shut);
}

TEST(DeformGuard, ABaseCrossingItselfNearlyEverywhereIsThePapersSolveAtOnce) {
  // A plane collapsed onto a line (an animation's glitch, or a squash to zero): its faces cross
  // their neighbours everywhere, no valid shell exists, and the guard has nothing to keep clean.
  // The frame is the paper's solve, reported not valid, with no guarded iteration spent (they ran
  // for 14 s here, for minutes on bunny00 squashed flat); the next frame starts from the last
  // valid one and is valid. (A fold through itself is still guarded: the test below.)
  const Shell rest = flat_plane_shell(16, 0.2);
  ShellDeformer deformer(rest);
  Eigen::MatrixXd collapsed = rest.base;
  collapsed.col(1).setZero();
  const FrameResult r = deformer.solve(collapsed);
  EXPECT_EQ(r.method, FrameMethod::Failed);
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(r.guarded_iterations, 0);
  EXPECT_GT(r.certificate.base_self_intersections, rest.F.rows());
  const FrameResult back = deformer.solve(rest.base);
  EXPECT_TRUE(back.resumed);
  expect_valid_frame(deformer, back, rest.base);
}

TEST(DeformGuard, AllowInvalidReproducesTheUnguardedFramesBitForBit) {
  // The unguarded frame rebuilt by hand: the rotated-offset warm start, then the paper's solve.
  const Shell rest = flat_plane_shell(12, 0.2);
  const int n = rest.num_base_vertices();
  const MotionFrame frame = motion_frame(rest.base);
  ShellDeformer deformer(rest);
  const ShellSolver solver = base_fixed_solver(deformation_rest_tets(rest), n);
  const VertexRings rings = vertex_rings(rest.F, n);
  DeformOptions options;
  options.allow_invalid = true;
  options.warm_start = WarmStart::RotatedOffset;
  SolveOptions solve;
  solve.max_iterations = options.max_iterations;
  solve.tolerance = options.tolerance;
  Eigen::MatrixXd X = rest.vertices();
  int invalid = 0;
  for (int k = 1; k <= 4; ++k) {
    const Eigen::MatrixXd base = bend(rest.base, frame, 150.0 * ramp(k, 4), 0.15);
    Eigen::MatrixXd Y(2 * n, 3);
    Y << base, rotated_offset_top(X.topRows(n), X.bottomRows(n), base, rest.F, rings);
    solver.solve(Y, solve);
    const FrameResult r = deformer.solve(base, options);
    EXPECT_EQ(r.method, FrameMethod::Unguarded);
    EXPECT_EQ(r.substeps, 0);
    EXPECT_TRUE((r.top.array() == Y.bottomRows(n).array()).all()) << "frame " << k;
    invalid += r.valid ? 0 : 1;
    X = Y;
  }
  EXPECT_GT(invalid, 0); // the guard would have changed these frames
}

// Two handles at opposite sides of the bowl's rim driven through each other.
HandleSet squeeze_handles(const Shell& rest) {
  const int n = rest.num_base_vertices();
  HandleSet handles;
  for (int side : {1, -1}) {
    Handle h;
    for (int v = 0; v < 2 * n; ++v) {
      const Eigen::RowVector3d p = v < n ? rest.base.row(v) : rest.top.row(v - n);
      if (side * p.x() > 0.8) h.vertices.push_back(v);
    }
    h.translate = Eigen::Vector3d(-side * 2.4, 0, 0);
    handles.handles.push_back(h);
  }
  return handles;
}

// A bowl squeezed shut: two handles at opposite sides of the rim driven through each other.
// `progress_calls[step - 1]`: how often the step reported progress.
PoseResult squeeze_bowl(PoseSolverKind kind, bool allow_invalid, std::vector<int>* progress_calls = nullptr) {
  const Shell rest = offset_shell(make_bowl(8), 0.08);
  const HandleSet handles = squeeze_handles(rest);
  PoseOptions options;
  options.solver = kind;
  options.steps = 4;
  options.allow_invalid = allow_invalid;
  options.solve.max_iterations = 100;
  options.solve.tolerance = 1e-5;
  if (progress_calls) {
    progress_calls->assign(options.steps, 0);
    options.step_progress = [progress_calls](int step, int, double, double) { ++(*progress_calls)[step - 1]; };
  }
  return run_pose(rest, handles, options);
}

// The viewer's mode: drag events are unguarded previews, the settle makes the state valid again.
TEST(PoseGuard, UnguardedDragPreviewsSettleIntoAValidState) {
  const Shell rest = offset_shell(make_bowl(8), 0.08);
  const int n = rest.num_base_vertices();
  const HandleSet handles = squeeze_handles(rest);
  PoseOptions options;
  options.guard_drag_steps = false;
  options.solve.max_iterations = 100;
  options.solve.tolerance = 1e-5;
  DragSession session(rest, options);
  session.set_handles(handles);
  bool preview_invalid = false;
  for (double fraction : {0.25, 0.5, 0.75, 1.0}) {
    const PoseStepReport step = session.drag(fraction);
    EXPECT_FALSE(step.guarded);
    const Eigen::MatrixXd& X = session.vertices();
    const ShellCertificate c = certify_shell(X.topRows(n), X.bottomRows(n), rest.F);
    preview_invalid = preview_invalid || !c.valid() || c.base_self_intersections > 0;
  }
  EXPECT_TRUE(preview_invalid); // the squeeze passes the previews through themselves
  const PoseStepReport settled = session.settle();
  EXPECT_TRUE(settled.guarded);
  EXPECT_TRUE(settled.valid);
  const Eigen::MatrixXd& X = session.vertices();
  const ShellCertificate c = certify_shell(X.topRows(n), X.bottomRows(n), rest.F);
  EXPECT_TRUE(c.valid());
  EXPECT_EQ(c.base_self_intersections, 0);
}

void expect_squeeze_stops_at_contact(PoseSolverKind kind) {
  std::vector<int> progress_calls;
  const PoseResult guarded = squeeze_bowl(kind, false, &progress_calls);
  bool blocked = false, started_along = false;
  ASSERT_EQ(guarded.steps.size(), progress_calls.size());
  for (std::size_t k = 0; k < guarded.steps.size(); ++k) {
    const PoseStepReport& s = guarded.steps[k];
    SCOPED_TRACE("step at fraction " + std::to_string(s.fraction));
    // Progress goes on while the guard drags: one report per solver and per guarded iteration.
    EXPECT_EQ(progress_calls[k], s.iterations + s.guarded_iterations);
    EXPECT_TRUE(s.guarded);
    EXPECT_GE(s.drag_start, 0.0);
    EXPECT_LT(s.drag_start, 1.0);
    started_along = started_along || s.drag_start > 0;
    EXPECT_TRUE(s.valid);
    EXPECT_EQ(s.inverted_tets, 0);
    EXPECT_EQ(s.intersections, 0);
    blocked = blocked || s.blocked_by_contact;
  }
  EXPECT_TRUE(blocked);
  // Where the solver's step pressed the rim together only late, its drag began part of the way
  // there (FrameGuard::accepted_fraction), and ended valid all the same.
  EXPECT_TRUE(started_along);
  const int n = static_cast<int>(guarded.X.rows()) / 2;
  const Eigen::MatrixXi F = offset_shell(make_bowl(8), 0.08).F;
  const ShellCertificate c = certify_shell(guarded.X.topRows(n), guarded.X.bottomRows(n), F);
  EXPECT_TRUE(c.valid());
  EXPECT_EQ(c.base_self_intersections, 0);
  // The step's reported energy is that of the state it returned, not of the solver's rejected one.
  const Shell rest = offset_shell(make_bowl(8), 0.08);
  const PoseSolver solver(rest, squeeze_handles(rest), kind);
  const double returned = solver.energy(guarded.X, 1.0);
  EXPECT_NEAR(guarded.steps.back().energy, returned, 1e-9 * returned);
  // Unguarded, the same squeeze passes the shell through itself.
  const PoseResult loose = squeeze_bowl(kind, true);
  const ShellCertificate l = certify_shell(loose.X.topRows(n), loose.X.bottomRows(n), F);
  EXPECT_FALSE(l.valid() && l.base_self_intersections == 0);
}

TEST(PoseGuard, SqueezingABowlShutStopsAtContactValidSingleSolver) {
  expect_squeeze_stops_at_contact(PoseSolverKind::Single);
}

TEST(PoseGuard, SqueezingABowlShutStopsAtContactValidHierarchicalSolver) {
  expect_squeeze_stops_at_contact(PoseSolverKind::Hierarchical);
}

// Soft handles (springs) driven through each other: no guarded solver holds springs, so a refused
// step is cut back along its straight path to the largest part the guard accepts (it used to be
// halved from 0.5 on). The step from rest to half the squeeze: the solver's own result passes the
// rim through itself; the step returned lies on the straight path to it, valid, short of it.
TEST(PoseGuard, SoftHandlesPressedTogetherAreCutBackAlongTheirStep) {
  const Shell rest = offset_shell(make_bowl(8), 0.08);
  const int n = rest.num_base_vertices();
  HandleSet handles = squeeze_handles(rest);
  handles.mode = ConstraintMode::Soft;
  const Eigen::MatrixXd from = rest.vertices();
  // At 0.4 of the squeeze the rims meet; from 0.5 on the solver can find the shell passed
  // through itself into a valid minimum, where nothing would need cutting back.
  const Eigen::MatrixXd P = handles.targets(from, 0.4);
  SolveOptions options;
  options.max_iterations = 100;
  options.tolerance = 1e-5;
  Eigen::MatrixXd solved = from;
  PoseSolver(rest, handles, PoseSolverKind::Hierarchical).solve(solved, P, options);
  const ShellCertificate s = certify_shell(solved.topRows(n), solved.bottomRows(n), rest.F);
  ASSERT_FALSE(s.valid() && s.base_self_intersections == 0);

  PoseSolver guarded(rest, handles, PoseSolverKind::Hierarchical);
  Eigen::MatrixXd X = from;
  ValidStep step;
  guarded.solve_valid(from, X, P, options, PoseOptions{}.guard, &step);
  EXPECT_EQ(step.method, FrameMethod::Bounded);
  EXPECT_TRUE(step.blocked_by_contact);
  EXPECT_TRUE(step.valid);
  // Where X lies along the path, and that it lies on it.
  const Eigen::MatrixXd D = solved - from;
  const double t = (X - from).cwiseProduct(D).sum() / D.squaredNorm();
  EXPECT_LT((X - (from + t * D)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(step.drag_start, t, 1e-12);
  // The tets allow a third of the way here, and nothing intersects there; halving kept a quarter.
  EXPECT_GT(t, 0.25);
  EXPECT_LT(t, 1.0);
  const ShellCertificate c = certify_shell(X.topRows(n), X.bottomRows(n), rest.F);
  EXPECT_TRUE(c.valid());
  EXPECT_EQ(c.base_self_intersections, 0);
}

TEST(PoseGuard, APairTouchingToRoundingAtRestDoesNotHoldThePoseStill) {
  // One top vertex pressed onto the base: the base vertex under it then touches the top triangles
  // around it as far as floating point can tell, so no step that moves them is certified. Guarding
  // them held every step where it began (blocked by contact, as CGAL's mannequin-devil posed);
  // they are left out like the rest shell's own faults, and the pose reaches its targets with
  // every other tet and pair guarded.
  int v = 0;
  const Shell rest = plane_shell_with_a_pressed_top(&v);
  const int n = rest.num_base_vertices();
  HandleSet handles;
  handles.handles = {x_end_handle(rest, -1, 0.8), x_end_handle(rest, 1, 0.8)};
  Handle& turned = handles.handles[1];
  turned.axis = Eigen::Vector3d(0, 1, 0);
  turned.degrees = 190; // the solver's step ends refused (at 170 degrees only its path was)
  turned.center = Eigen::Vector3d(0.5, 0, 0);
  PoseOptions options;
  options.steps = 1;
  options.solve.max_iterations = 100;
  options.solve.tolerance = 1e-5;
  const PoseResult r = run_pose(rest, handles, options);
  for (const PoseStepReport& s : r.steps) {
    SCOPED_TRACE("step at fraction " + std::to_string(s.fraction));
    EXPECT_EQ(s.method, FrameMethod::Guarded); // the solver's step refused: the guard drags
    EXPECT_FALSE(s.blocked_by_contact);
    EXPECT_NE(s.method, FrameMethod::Failed);
  }
  const Eigen::MatrixXd targets = handles.targets(rest.vertices(), 1.0);
  const std::vector<int> constrained = handles.constrained_vertices();
  for (std::size_t k = 0; k < constrained.size(); ++k)
    EXPECT_LT((r.X.row(constrained[k]) - targets.row(static_cast<Eigen::Index>(k))).norm(), 1e-12);
  // What the certificate finds wrong is at the pressed vertex.
  const Eigen::MatrixXi T = build_prism_tets(rest.F, n);
  const ShellCertificate c = certify_shell(r.X.topRows(n), r.X.bottomRows(n), rest.F);
  for (int t : c.inverted_tet_ids) EXPECT_TRUE((T.row(t).array() == n + v).any()) << "tet " << t;
}

// A pose step the guard drags names its sub-steps for progress, where the iteration count goes on
// from the solver's and the energy (with the barriers) climbs as the handles move.
TEST(PoseGuard, EachSolveOfAGuardedStepIsNamedForProgress) {
  const Shell rest = flat_plane_shell(16, 0.2);
  HandleSet handles;
  handles.handles = {x_end_handle(rest, -1, 0.8), x_end_handle(rest, 1, 0.8)};
  Handle& turned = handles.handles[1];
  turned.axis = Eigen::Vector3d(0, 1, 0);
  turned.degrees = 190;
  turned.center = Eigen::Vector3d(0.5, 0, 0);
  PoseOptions options;
  options.steps = 1;
  options.solve.max_iterations = 100;
  options.solve.tolerance = 1e-5;
  StageLog log;
  log.hook(options.solve);
  int calls = 0;
  options.step_progress = [&](int, int, double, double) {
    ++calls;
    ASSERT_FALSE(log.iterations.empty());
    ++log.iterations.back();
  };
  const PoseResult r = run_pose(rest, handles, options);
  ASSERT_EQ(r.steps.size(), 1u);
  ASSERT_EQ(r.steps[0].method, FrameMethod::Guarded);
  ASSERT_GE(log.names.size(), 2u);
  EXPECT_EQ(log.names[0], "guard setup"); // the first guarded step builds the guard, then solves
  EXPECT_EQ(log.iterations[0], 0);
  EXPECT_EQ(log.names[1], "paper");
  EXPECT_EQ(log.iterations[1], r.steps[0].iterations);
  EXPECT_GT(log.drag_substeps(), 1);
  EXPECT_EQ(calls - log.iterations[1], r.steps[0].guarded_iterations);
}

// As for deformation frames: the first guarded step builds the guard, and its report keeps that
// time apart from the step's.
TEST(PoseGuard, BuildingTheGuardIsTimedApartFromTheSteps) {
  const Shell rest = flat_plane_shell(16, 0.2);
  HandleSet handles;
  handles.handles = {x_end_handle(rest, -1, 0.8), x_end_handle(rest, 1, 0.8)};
  handles.handles[1].translate = Eigen::Vector3d(0, 0, 0.2);
  PoseOptions options;
  options.steps = 2;
  const PoseResult r = run_pose(rest, handles, options);
  ASSERT_EQ(r.steps.size(), 2u);
  ASSERT_TRUE(r.steps[0].guarded);
  EXPECT_GT(r.steps[0].guard_setup_seconds, 0);
  EXPECT_EQ(r.steps[1].guard_setup_seconds, 0);
  EXPECT_EQ(r.to_json()["steps"][0]["guard_setup_seconds"].get<double>(), r.steps[0].guard_setup_seconds);
}

// FrameGuard::accepted_fraction, where a refused pose step's drag begins. A flat plane's shell
// (thickness 0.2) whose middle top vertex is pushed 0.6 down, through its base: its tets keep 0.1
// of their volume (the keep fraction) until the top is 0.02 above the base, at 0.3 of the way, and
// nothing intersects before; so the fraction is the tets' step bound, just below 0.3.
TEST(FrameGuardStart, AFractionCutByTheTetsIsTheirStepBound) {
  const Shell rest = flat_plane_shell(16, 0.2);
  const int n = rest.num_base_vertices();
  int v = 0;
  for (int i = 1; i < n; ++i)
    if (rest.base.row(i).squaredNorm() < rest.base.row(v).squaredNorm()) v = i;
  const RestTets tets = deformation_rest_tets(rest);
  FrameGuard guard(rest, std::make_shared<const RestTets>(tets), frame_guard_options(), test::vertex_range(0, n), true);
  const Eigen::MatrixXd X0 = rest.vertices();
  Eigen::MatrixXd X1 = X0;
  X1(n + v, 2) -= 0.6;
  Eigen::MatrixXd Y;
  const double t = guard.accepted_fraction(X0, X1, true, 0.05, Y);
  EXPECT_GT(t, 0.3 - 1e-6);
  EXPECT_LT(t, 0.3);
  EXPECT_TRUE(Y.isApprox(X0 + t * (X1 - X0), 0.0));
  const ShellCertificate c = certify_shell(Y.topRows(n), Y.bottomRows(n), rest.F);
  EXPECT_TRUE(c.valid());
}

// Two facing sheets 0.5 apart, shells 0.1 thick, the upper sheet moved down by 0.5 onto the
// lower: nothing turns (the tets' bound is 1), so the tries are 0.7, 0.49, ... of the way. At 0.7
// the upper top (0.05 above the lower base) has passed the lower top (0.1): refused; at 0.49 it is
// 0.155 above: taken. Below the smallest fraction allowed nothing is tried and Y stays as it was.
TEST(FrameGuardStart, AFractionCutByContactsIsTheLargestCleanTry) {
  const Shell rest = offset_shell(test::facing_sheets(6, 0.5), 0.1);
  const int n = rest.num_base_vertices();
  const RestTets tets = deformation_rest_tets(rest);
  FrameGuard guard(rest, std::make_shared<const RestTets>(tets), frame_guard_options(), test::vertex_range(0, 2 * n), true);
  const Eigen::MatrixXd X0 = rest.vertices();
  Eigen::MatrixXd X1 = X0;
  for (int i = 0; i < 2 * n; ++i)
    if (X0(i, 2) > 0.25) X1(i, 2) -= 0.5; // the upper sheet, base and top
  const auto clean = [&](const Eigen::MatrixXd& X) {
    const ShellCertificate c = certify_shell(X.topRows(n), X.bottomRows(n), rest.F);
    return c.valid() && c.base_self_intersections == 0;
  };
  ASSERT_FALSE(clean(X1));
  ASSERT_FALSE(clean(X0 + 0.7 * (X1 - X0)));
  Eigen::MatrixXd Y;
  const double t = guard.accepted_fraction(X0, X1, true, 0.05, Y);
  EXPECT_DOUBLE_EQ(t, 0.7 * 0.7);
  EXPECT_TRUE(Y.isApprox(X0 + t * (X1 - X0), 0.0));
  EXPECT_TRUE(clean(Y));
  Eigen::MatrixXd untouched = X0;
  EXPECT_EQ(guard.accepted_fraction(X0, X1, true, 0.6, untouched), 0.0);
  EXPECT_TRUE(untouched.isApprox(X0, 0.0));
}

// Hard handles are the caller's: the guard moves them exactly along their path, so a pair of
// primitives whose four vertices are all handle vertices can only be kept apart by stopping the
// path. A box (2 x 0.5 x 2) whose every vertex is a handle vertex, one end held and the other
// turned by 45 degrees about the long axis and shifted sideways: half way its faces start to cross
// (pairs among handle vertices only, which the guard used to leave out: the steps from there were
// returned INVALID). Guarded, every step stays valid and the motion stops at contact.
TEST(PoseGuard, HandlesFoldingAShellOntoItselfStopAtContact) {
  TriMesh box;
  box.V.resize(8, 3);
  box.V << -1, -0.25, -1, -1, 0.25, -1, 1, 0.25, -1, 1, -0.25, -1, -1, -0.25, 1, -1, 0.25, 1, 1, 0.25, 1, 1, -0.25, 1;
  box.F.resize(12, 3);
  box.F << 0, 1, 3, 3, 1, 2, 0, 4, 1, 1, 4, 5, 3, 2, 7, 7, 2, 6, 4, 0, 3, 7, 4, 3, 6, 4, 7, 6, 5, 4, 1, 5, 6, 2, 1, 6;
  const Shell rest = offset_shell(box, 0.05);
  const int n = rest.num_base_vertices();
  HandleSet handles;
  handles.handles = {x_end_handle(rest, -1, 0), x_end_handle(rest, 1, 0)};
  Handle& turned = handles.handles[1];
  turned.axis = Eigen::Vector3d::UnitX();
  turned.degrees = 45;
  turned.center = Eigen::Vector3d(1, 0, 0);
  turned.translate = Eigen::Vector3d(0, 0.6, 0);
  PoseOptions options;
  options.steps = 4;
  const PoseResult r = run_pose(rest, handles, options);
  bool blocked = false;
  for (const PoseStepReport& s : r.steps) {
    SCOPED_TRACE("step at fraction " + std::to_string(s.fraction));
    EXPECT_TRUE(s.valid);
    EXPECT_EQ(s.inverted_tets, 0);
    EXPECT_EQ(s.intersections, 0);
    EXPECT_EQ(s.base_self_intersections, 0); // the box's faces crossed here
    blocked = blocked || s.blocked_by_contact;
  }
  EXPECT_TRUE(blocked);
  const ShellCertificate c = certify_shell(r.X.topRows(n), r.X.bottomRows(n), rest.F);
  EXPECT_TRUE(c.valid());
  EXPECT_EQ(c.base_self_intersections, 0);
  // Unguarded, the box reaches its targets, where it crosses itself.
  options.allow_invalid = true;
  const PoseResult loose = run_pose(rest, handles, options);
  const ShellCertificate l = certify_shell(loose.X.topRows(n), loose.X.bottomRows(n), rest.F);
  EXPECT_FALSE(l.valid() && l.base_self_intersections == 0);
}

TEST(PoseSolver, EveryPartNeedsAHandleVertexAndTheFreeOneIsNamed) {
  // Two spheres apart: handles on the first only leave the second free (its system singular).
  const TriMesh m = test::nested_spheres(1, 3.0);
  const int half = static_cast<int>(m.V.rows()) / 2;
  const Shell rest = offset_shell(m, 0.05);
  HandleSet handles;
  Handle first;
  first.vertices = {0, 1};
  handles.handles = {first};
  try {
    PoseSolver solver(rest, handles, PoseSolverKind::Single);
    ADD_FAILURE() << "a free part was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("the part with base vertex " + std::to_string(half) + ")"), std::string::npos)
        << e.what();
  }
  Handle second; // a top vertex of the second part anchors it as well
  second.vertices = {2 * half + half};
  handles.handles = {first, second};
  EXPECT_NO_THROW(PoseSolver(rest, handles, PoseSolverKind::Single));
  // A set built in code is checked as a file is: an id past the shell's 2n vertices crashed.
  for (const int bad : {4 * half, 100000, -1}) {
    second.vertices = {bad};
    handles.handles = {first, second};
    for (const PoseSolverKind kind : {PoseSolverKind::Single, PoseSolverKind::Hierarchical})
      EXPECT_THROW(PoseSolver(rest, handles, kind), InputError) << bad;
  }
}

TEST(PoseGuard, APartMovedWholeIntoAnotherPartsLayerIsRefused) {
  // A bead (base radius 0.01, top 0.02) beside a ball (base 1, top 1.1), moved by its handle in one
  // step to the middle of the ball's layer: the state there crosses no triangle, so every pair
  // test passes and the step used to be taken as the solver made it, the bead jumped through the
  // ball's top. The certificate's nesting test refuses it; the drag then stops at contact.
  const TriMesh ball = make_sphere(2), bead = make_sphere(1, 0.01);
  const int nb = static_cast<int>(ball.V.rows()), ns = static_cast<int>(bead.V.rows()), n = nb + ns;
  const Eigen::RowVector3d centre(1.3, 0, 0);
  Shell rest;
  rest.base.resize(n, 3);
  rest.base << ball.V, bead.V.rowwise() + centre;
  rest.top.resize(n, 3);
  rest.top << 1.1 * ball.V, (2 * bead.V).rowwise() + centre;
  rest.F.resize(ball.F.rows() + bead.F.rows(), 3);
  rest.F << ball.F, (bead.F.array() + nb).matrix();
  rest.thickness = 0.1;
  ASSERT_TRUE(certify_shell(rest.base, rest.top, rest.F).valid());
  HandleSet handles;
  Handle held, moved;
  for (int i = 0; i < nb; ++i) held.vertices.insert(held.vertices.end(), {i, n + i});
  for (int i = nb; i < n; ++i) moved.vertices.insert(moved.vertices.end(), {i, n + i});
  std::sort(held.vertices.begin(), held.vertices.end());
  std::sort(moved.vertices.begin(), moved.vertices.end());
  moved.translate = Eigen::Vector3d(-0.25, 0, 0); // the bead's layer ends in [1.03, 1.07] of x
  handles.handles = {held, moved};
  PoseOptions options;
  options.allow_invalid = true;
  const PoseResult jumped = run_pose(rest, handles, options);
  const ShellCertificate j = certify_shell(jumped.X.topRows(n), jumped.X.bottomRows(n), rest.F);
  EXPECT_TRUE(j.intersections.empty());
  EXPECT_EQ(j.nested_parts, 2);
  options.allow_invalid = false;
  const PoseResult r = run_pose(rest, handles, options);
  ASSERT_EQ(r.steps.size(), 1u);
  EXPECT_TRUE(r.steps[0].valid);
  EXPECT_TRUE(r.steps[0].blocked_by_contact);
  EXPECT_NE(r.steps[0].method, FrameMethod::Bounded);
  EXPECT_EQ(r.steps[0].nested_parts, 0);
  const ShellCertificate c = certify_shell(r.X.topRows(n), r.X.bottomRows(n), rest.F);
  EXPECT_TRUE(c.valid());
  for (int i = nb; i < n; ++i) EXPECT_GT(r.X(n + i, 0), 1.1) << "the bead's top stays outside the ball's";
}

// FrameGuard::mend, a refused pose step mended where it is wrong. A flat plane's shell (thickness
// 0.2) held by both x-ends (base and top), its middle top vertex pushed 0.6 down, through the base:
// refused. Mended over 2 rings, the state is certified valid, the pushed top is back above its
// base at nearly the full thickness (nothing around it keeps it thin), and every vertex farther
// than those rings around the tops the start pulled in (the pushed one's ring: they share its
// inverted tets), the handles included, is where the refused state had it.
Shell mend_plane(HandleSet& handles, int* middle) {
  Shell rest = flat_plane_shell(16, 0.2);
  handles.handles = {x_end_handle(rest, -1, 0.8), x_end_handle(rest, 1, 0.8)};
  *middle = 0;
  for (int i = 1; i < rest.num_base_vertices(); ++i)
    if (rest.base.row(i).squaredNorm() < rest.base.row(*middle).squaredNorm()) *middle = i;
  return rest;
}

TEST(FrameGuardMend, ATopPushedThroughItsBaseIsPulledBackInPlace) {
  HandleSet handles;
  int v = 0;
  const Shell rest = mend_plane(handles, &v);
  const int n = rest.num_base_vertices();
  const RestTets tets = deformation_rest_tets(rest);
  FrameGuard guard(rest, std::make_shared<const RestTets>(tets), frame_guard_options(), handles.constrained_vertices(), true);
  const Eigen::MatrixXd X0 = rest.vertices();
  Eigen::MatrixXd X = X0;
  X(n + v, 2) -= 0.6;
  ShellCertificate refused;
  ASSERT_FALSE(guard.accepts(X0, X, true, &refused));
  GuardedSolveOptions solve;
  solve.max_iterations = 200;
  solve.tolerance = 1e-8;
  Eigen::MatrixXd M = X;
  ShellCertificate c;
  int iterations = 0;
  ASSERT_TRUE(guard.mend(M, 2, solve, &refused, &c, &iterations));
  EXPECT_GT(iterations, 0);
  EXPECT_TRUE(c.valid());
  const ShellCertificate exact = certify_shell(M.topRows(n), M.bottomRows(n), rest.F);
  EXPECT_TRUE(exact.valid());
  EXPECT_EQ(exact.base_self_intersections, 0);
  EXPECT_GT(M(n + v, 2) - M(v, 2), 0.9 * 0.2);
  std::vector<char> near(n, 0);
  near[v] = 1;
  grow_by_rings(rest.F, 1 + 2, near); // the start thins v's prisms (its ring's tops too), then 2 rings
  for (int i = 0; i < n; ++i)
    if (!near[i]) {
      EXPECT_TRUE(M.row(i) == X.row(i)) << "base vertex " << i;
      EXPECT_TRUE(M.row(n + i) == X.row(n + i)) << "top vertex " << i;
    }
  for (int h : handles.constrained_vertices()) EXPECT_TRUE(M.row(h) == X.row(h)) << "handle vertex " << h;
}

void expect_mend_declines(FrameGuard& guard, const Eigen::MatrixXd& X) {
  Eigen::MatrixXd M = X;
  EXPECT_FALSE(guard.mend(M, 10, GuardedSolveOptions{}, nullptr, nullptr, nullptr));
  EXPECT_TRUE(M == X);
}

// What only a drag can do is left to it: a handle's own top pushed through its base (the start
// would pull a vertex the caller placed), and a base that crosses itself (no thinning mends it):
// mend declines and leaves the state as it was.
TEST(FrameGuardMend, AHandlePushedThroughItsBaseIsLeftToTheDrag) {
  HandleSet handles;
  int v = 0;
  const Shell rest = mend_plane(handles, &v);
  const int n = rest.num_base_vertices();
  const std::vector<int> fixed = handles.constrained_vertices();
  int h = -1; // a top vertex of a handle inside its end
  for (int u : fixed)
    if (u >= n && rest.top(u - n, 0) > 0.9 && std::abs(rest.top(u - n, 1)) < 0.5) h = u;
  ASSERT_GE(h, 0);
  const RestTets tets = deformation_rest_tets(rest);
  FrameGuard guard(rest, std::make_shared<const RestTets>(tets), frame_guard_options(), fixed, true);
  Eigen::MatrixXd X = rest.vertices();
  X(h, 2) -= 0.6;
  ASSERT_FALSE(guard.accepts(rest.vertices(), X, true, nullptr));
  expect_mend_declines(guard, X);
}

TEST(FrameGuardMend, ABaseCrossingItselfIsLeftToTheDrag) {
  const Shell rest = offset_shell(test::facing_sheets(6, 0.5), 0.1);
  const int n = rest.num_base_vertices();
  int v = -1; // an interior vertex of the upper sheet
  for (int i = 0; i < n; ++i)
    if (rest.base(i, 2) > 0.25 && rest.base.row(i).head<2>().norm() < 0.3) v = i;
  ASSERT_GE(v, 0);
  const RestTets tets = deformation_rest_tets(rest);
  FrameGuard guard(rest, std::make_shared<const RestTets>(tets), frame_guard_options(), {}, true);
  Eigen::MatrixXd X = rest.vertices();
  X(v, 2) -= 0.8; // through the lower sheet, its top with it
  X(n + v, 2) -= 0.8;
  ASSERT_GT(certify_shell(X.topRows(n), X.bottomRows(n), rest.F).base_self_intersections, 0);
  expect_mend_declines(guard, X);
}

// A pose step refused where the solver's result is wrong in one spot away from the handles is
// mended there (GuardOptions::mend_rings) and lands where the drag from the last pose does. A V
// of opening 120 degrees (offset shell 0.15 thick, its tops crossing at the apex at rest, which
// the guard leaves out), its right arm turned about the apex by 70 degrees in one step: the
// solver's state is refused, mended, exactly certified valid, handles on their targets, and its
// energy within 1e-4 of the drag's (0.0076176427 against 0.0076176369 when written, in 11
// guarded iterations against 43).
// The folded plane's ends held, one turned back by 70 degrees: the solver's step inverts tets.
HandleSet folded_plane_turn(const Shell& rest) {
  HandleSet handles;
  handles.handles = {x_end_handle(rest, -1, 0.7), x_end_handle(rest, 1, 0.7)};
  Handle& turned = handles.handles[1];
  turned.axis = Eigen::Vector3d::UnitY();
  turned.degrees = -70;
  turned.center = Eigen::Vector3d::Zero();
  return handles;
}

TEST(PoseGuard, ARefusedStepIsMendedInPlaceToTheDragsMinimum) {
  const Shell rest = offset_shell(test::folded_plane(16, 120), 0.15);
  const int n = rest.num_base_vertices();
  const HandleSet handles = folded_plane_turn(rest);
  PoseOptions options;
  options.steps = 1;
  ASSERT_GE(options.guard.mend_rings, 0);
  const PoseResult mended = run_pose(rest, handles, options);
  options.guard.mend_rings = -1;
  const PoseResult dragged = run_pose(rest, handles, options);
  ASSERT_EQ(mended.steps.size(), 1u);
  ASSERT_EQ(dragged.steps.size(), 1u);
  EXPECT_EQ(mended.steps[0].method, FrameMethod::Mended);
  EXPECT_EQ(dragged.steps[0].method, FrameMethod::Guarded);
  EXPECT_TRUE(mended.steps[0].valid);
  const ShellCertificate c = certify_shell(mended.X.topRows(n), mended.X.bottomRows(n), rest.F);
  EXPECT_TRUE(c.valid());
  EXPECT_EQ(c.base_self_intersections, 0);
  const Eigen::MatrixXd targets = handles.targets(rest.vertices(), 1.0);
  const std::vector<int> constrained = handles.constrained_vertices();
  for (std::size_t k = 0; k < constrained.size(); ++k)
    EXPECT_LT((mended.X.row(constrained[k]) - targets.row(static_cast<Eigen::Index>(k))).norm(), 1e-12);
  EXPECT_NEAR(mended.steps[0].energy, dragged.steps[0].energy, 1e-4 * dragged.steps[0].energy);
  // Allowed no rise above the solve's energy, the mend is kept aside, the drag runs too (its
  // iterations counted) and the step returns whichever valid state is lower.
  options.guard.mend_rings = 10;
  options.guard.mend_max_rise = 0;
  const PoseResult both = run_pose(rest, handles, options);
  ASSERT_EQ(both.steps.size(), 1u);
  EXPECT_TRUE(both.steps[0].valid);
  EXPECT_GT(both.steps[0].guarded_iterations, mended.steps[0].guarded_iterations);
  const bool mend_lower = mended.steps[0].energy < dragged.steps[0].energy;
  EXPECT_EQ(both.steps[0].method, mend_lower ? FrameMethod::Mended : FrameMethod::Guarded);
  EXPECT_DOUBLE_EQ(both.steps[0].energy, std::min(mended.steps[0].energy, dragged.steps[0].energy));
}

// The same turn pulled by soft handles: the refused step is mended with the handle vertices held
// where the solve put them. It was cut back along its straight path instead (soft handles are not
// dragged), which on CGAL's elephant kept 8 % and then 0.7 % of the steps of a plain pull that
// hard handles reach, with a warning blaming contact.
TEST(PoseGuard, ARefusedStepOfSoftHandlesIsMendedWhereTheSolvePutThem) {
  const Shell rest = offset_shell(test::folded_plane(16, 120), 0.15);
  const int n = rest.num_base_vertices();
  HandleSet handles = folded_plane_turn(rest);
  handles.mode = ConstraintMode::Soft;
  handles.weight = 1000;
  PoseOptions options;
  options.steps = 1;
  options.allow_invalid = true;
  const PoseResult unguarded = run_pose(rest, handles, options);
  ASSERT_FALSE(certify_shell(unguarded.X.topRows(n), unguarded.X.bottomRows(n), rest.F).valid());
  // Unguarded steps are certified all the same, and the report says they are not valid (it said
  // nothing: no `valid`, no certificate, no warning).
  const PoseStepReport& u = unguarded.steps.at(0);
  EXPECT_TRUE(u.certified && !u.guarded && !u.valid);
  EXPECT_GT(u.inverted_tets + u.intersections, 0);
  const nlohmann::ordered_json step_json = unguarded.to_json()["steps"][0];
  EXPECT_EQ(step_json["valid"], false);
  EXPECT_EQ(step_json["method"], "unguarded");
  EXPECT_EQ(step_json["certificate"]["inverted_tets"], u.inverted_tets);
  ASSERT_EQ(unguarded.warnings().size(), 1u);
  EXPECT_NE(unguarded.warnings()[0].find("pose step 1 unguarded (allow_invalid)"), std::string::npos)
      << unguarded.warnings()[0];
  options.allow_invalid = false;
  const PoseResult r = run_pose(rest, handles, options);
  ASSERT_EQ(r.steps.size(), 1u);
  EXPECT_EQ(r.steps[0].method, FrameMethod::Mended);
  EXPECT_FALSE(r.steps[0].blocked_by_contact);
  EXPECT_TRUE(r.warnings().empty());
  const ShellCertificate c = certify_shell(r.X.topRows(n), r.X.bottomRows(n), rest.F);
  EXPECT_TRUE(c.valid());
  EXPECT_EQ(c.base_self_intersections, 0);
  // The handle vertices stay where the (unguarded) solve put them, within the springs' reach.
  for (int v : handles.constrained_vertices()) EXPECT_EQ(r.X.row(v), unguarded.X.row(v)) << "vertex " << v;
  EXPECT_LT(r.steps[0].energy, 1.1 * unguarded.steps[0].energy);
}

TEST(PoseGuard, GuardOptionsOutOfRangeAreAnInputErrorNamingThem) {
  HandleSet handles;
  int v = 0;
  const Shell rest = mend_plane(handles, &v);
  const auto expect_named = [&](const char* name, const std::function<void(GuardOptions&)>& spoil) {
    PoseOptions options;
    spoil(options.guard);
    try {
      run_pose(rest, handles, options);
      ADD_FAILURE() << name << " out of range was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  expect_named("mend_rings", [](GuardOptions& g) { g.mend_rings = -2; });
  expect_named("mend_max_rise", [](GuardOptions& g) { g.mend_max_rise = -0.1; });
  expect_named("mend_max_rise", [](GuardOptions& g) { g.mend_max_rise = std::nan(""); });
}

// A plane folded through itself by 200 degrees in one frame (`gshell animate --bend 200 --band
// 0.2`): the drag stalls at the new crossings and the frame is invalid whatever is made of it.
// Finished by the tets-only drag, which guards no pair, it kept top/base and wall pairs across the
// fold's whole inner band (415 pairs more than a ring from the crossings); the fresh top, made as
// generation makes one and clean on generation's terms, keeps every pair next to them and is
// returned instead.
TEST(DeformGuard, AFoldThroughItselfKeepsItsFaultsNextToTheCrossings) {
  const Shell rest = flat_plane_shell(32, 0.0707);
  const int n = rest.num_base_vertices();
  const Eigen::MatrixXd folded = bend(rest.base, motion_frame(rest.base), 200, 0.2);
  ShellDeformer deformer(rest);
  const FrameResult r = deformer.solve(folded);
  const ShellCertificate c = certify_shell(folded, r.top, rest.F);
  ASSERT_GT(c.base_self_intersections, 0);
  EXPECT_FALSE(r.valid);
  EXPECT_EQ(c.inverted_tets, 0);
  EXPECT_TRUE(r.fresh_top) << frame_method_name(r.method);
  // Within a ring of the crossing faces' vertices, as generation over the same base keeps them.
  std::vector<char> near(n, 0);
  for (const auto& [f, g] : surface_self_intersections(folded, rest.F))
    for (int k = 0; k < 3; ++k) near[rest.F(f, k)] = near[rest.F(g, k)] = 1;
  std::vector<char> ring = near;
  for (int f = 0; f < rest.F.rows(); ++f)
    if (near[rest.F(f, 0)] || near[rest.F(f, 1)] || near[rest.F(f, 2)])
      for (int k = 0; k < 3; ++k) ring[rest.F(f, k)] = 1;
  const ShellBoundary boundary = shell_boundary(rest.F, n);
  const auto close = [&](int row) {
    const int f = boundary.face[row];
    return ring[rest.F(f, 0)] || ring[rest.F(f, 1)] || ring[rest.F(f, 2)];
  };
  int away = 0;
  for (const BoundaryIntersection& pair : c.intersections) away += !close(pair.a) && !close(pair.b);
  EXPECT_EQ(away, 0) << "of " << c.intersections.size() << " intersecting pairs";
}

// A plane bent by exactly 360 degrees: its two ends meet to rounding, which the exact test does not
// count as a crossing, and no layer fits between them. The frame is not valid and says why (the
// fresh top's valid start could not thin the layer enough there), rather than that the guard
// failed for no reason.
TEST(DeformGuard, ABaseWhoseEndsTouchIsNamedAsTouching) {
  const Shell rest = flat_plane_shell(16, 0.07);
  const Eigen::MatrixXd closed = bend(rest.base, motion_frame(rest.base), 360);
  ShellDeformer deformer(rest);
  const FrameResult r = deformer.solve(closed);
  const ShellCertificate c = certify_shell(closed, r.top, rest.F);
  ASSERT_EQ(c.base_self_intersections, 0) << "the ends cross: the case no longer touches";
  ASSERT_FALSE(r.valid) << frame_method_name(r.method);
  EXPECT_TRUE(r.base_nearly_touching);
  EXPECT_EQ(c.inverted_tets, 0);
  // A frame that does fit keeps no such flag.
  const FrameResult open = deformer.solve(bend(rest.base, motion_frame(rest.base), 300));
  EXPECT_TRUE(open.valid);
  EXPECT_FALSE(open.base_nearly_touching);
}

} // namespace
} // namespace gshell
