// Base-driven shell deformation (paper §4.2): rigid motions, folds vs the offset baseline, the
// warm start, and the synthetic motions that drive the demos.
#include <gshell/deform/shell_deformer.h>
#include <gshell/deform/synthetic_motion.h>
#include <gshell/error.h>
#include <gshell/format_number.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/quality/stretch.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include "shell_fixtures.h"

#include <cmath>
#include <numbers>
#include <set>

namespace gshell {
namespace {

using test::flat_plane_shell;
using test::sphere_shell;

Eigen::MatrixXd rigidly_moved(const Eigen::MatrixXd& X, const Eigen::Matrix3d& R, const Eigen::RowVector3d& t) {
  return (X * R.transpose()).rowwise() + t;
}

void expect_energy_never_increases(const FrameResult& r) {
  for (std::size_t k = 1; k < r.energy.size(); ++k) EXPECT_LE(r.energy[k], r.energy[k - 1] * (1 + 1e-12) + 1e-15);
}

TEST(ShellDeformer, RigidMotionOfTheBaseMovesTheTopRigidly) {
  const Shell rest = sphere_shell(1, 0.15);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -0.5).normalized()).toRotationMatrix();
  const Eigen::RowVector3d t(0.4, -1.2, 2.0);
  for (WarmStart warm :
       {WarmStart::Extrapolated, WarmStart::RotatedOffset, WarmStart::Translated, WarmStart::PreviousTop}) {
    ShellDeformer deformer(rest);
    DeformOptions options;
    options.warm_start = warm;
    options.tolerance = 1e-12;
    options.max_iterations = 400;
    const FrameResult r = deformer.solve(rigidly_moved(rest.base, R, t), options);
    SCOPED_TRACE(warm_start_name(warm));
    expect_energy_never_increases(r);
    EXPECT_LT((r.top - rigidly_moved(rest.top, R, t)).cwiseAbs().maxCoeff(), 1e-4);
    EXPECT_LT(r.stretch.max, 1e-8);
    EXPECT_EQ(r.stretch.inverted, 0);
  }
}

TEST(ShellDeformer, RotatedOffsetWarmStartIsExactForRigidMotions) {
  const Shell rest = sphere_shell(2, 0.15);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(2.5, Eigen::Vector3d(-0.3, 0.1, 0.9).normalized()).toRotationMatrix();
  const Eigen::RowVector3d t(3, 2, 1);
  const Eigen::MatrixXd top = rotated_offset_top(rest.base, rest.top, rigidly_moved(rest.base, R, t), rest.F,
                                                 vertex_rings(rest.F, rest.num_base_vertices()));
  EXPECT_LT((top - rigidly_moved(rest.top, R, t)).cwiseAbs().maxCoeff(), 1e-12);

  ShellDeformer deformer(rest);
  const FrameResult r = deformer.solve(rigidly_moved(rest.base, R, t));
  EXPECT_LT(r.energy.front(), 1e-20);
  EXPECT_LT((r.top - rigidly_moved(rest.top, R, t)).cwiseAbs().maxCoeff(), 1e-10);
}

TEST(ShellDeformer, FoldingAPlaneStretchesLessThanOffsetAndInvertsNothing) {
  // Paper Fig. 6: a plane shell folded by 90 degrees in a band narrower than the shell is thick:
  // re-extruding along vertex normals turns the tets in the fold's concave side inside out, the
  // solved top slides along and keeps every tet positive.
  const double eta = 0.2;
  const Shell rest = flat_plane_shell(24, eta);
  const MotionFrame frame = motion_frame(rest.base);
  ShellDeformer deformer(rest);
  const int frames = 3;
  for (int k = 1; k <= frames; ++k) {
    const Eigen::MatrixXd base = bend(rest.base, frame, 90.0 * ramp(k, frames), 0.1);
    const FrameResult r = deformer.solve(base);
    expect_energy_never_increases(r);
    Eigen::MatrixXd offset(2 * base.rows(), 3);
    offset << base, offset_top(base, rest.F, eta);
    const StretchStats o = stretch_stats(deformer.rest_tets(), offset);
    SCOPED_TRACE("frame " + std::to_string(k));
    EXPECT_LT(r.stretch.volume_mean, o.volume_mean);
    EXPECT_LT(r.stretch.max, o.max);
    EXPECT_EQ(r.stretch.inverted, 0);
    if (k == frames) EXPECT_GT(o.inverted, 0);
  }
}

TEST(ShellDeformer, InvertedRestTetsTakeTheirIdealShape) {
  // A defective rest shell: one top vertex pushed below the base inverts its tets. They cannot be
  // rest shapes; with their normal prisms as rest shapes, solving at the rest base repairs them.
  Shell rest = flat_plane_shell(6, 0.1);
  const int v = 3 * 7 + 3; // an interior vertex
  rest.top(v, 2) = -0.05;
  int replaced = 0;
  const RestTets tets = deformation_rest_tets(rest, &replaced);
  EXPECT_GT(replaced, 0);
  EXPECT_GT(tets.volume.minCoeff(), 0);
  ShellDeformer deformer(rest);
  EXPECT_EQ(deformer.replaced_rest_tets(), replaced);
  DeformOptions options;
  options.tolerance = 1e-10;
  options.max_iterations = 200;
  const FrameResult r = deformer.solve(rest.base, options);
  EXPECT_EQ(r.stretch.inverted, 0);
  EXPECT_GT(r.top(v, 2), 0.05); // back above the base (tets it shares with sound neighbours keep it a bit low)
  // A sound shell keeps all of its own tets.
  deformation_rest_tets(flat_plane_shell(6, 0.1), &replaced);
  EXPECT_EQ(replaced, 0);
}

TEST(ShellDeformer, APartTooSmallForTheThicknessKeepsItsOwnThinRestTets) {
  // Generation leaves such a part (a speck of radius 1e-3 at eta 0.03) with the valid start's thin
  // layer, its tets far below kMinRestVolumeRatio of eta's prisms yet proper. Replaced by those
  // prisms, a frame as still as the rest would push its top out to eta, into itself.
  const TriMesh m = test::sphere_with_speck(1e-3);
  GenerateOptions o;
  o.thickness = 0.03;
  const GenerateResult g = generate_shell(m.V, m.F, o);
  ASSERT_FALSE(g.guard.small_part_vertices.empty());
  int replaced = -1;
  deformation_rest_tets(g.shell, &replaced);
  EXPECT_EQ(replaced, 0);
  ShellDeformer deformer(g.shell);
  const FrameResult still = deformer.solve(g.shell.base, DeformOptions{});
  EXPECT_TRUE(still.valid);
  EXPECT_EQ(still.guarded_iterations, 0);
  EXPECT_LT((still.top - g.shell.top).cwiseAbs().maxCoeff(), 1e-9 * o.thickness);
  // Its flat or inverted tets are still replaced: a speck's top vertex pushed through its base.
  Shell broken = g.shell;
  const int v = g.guard.small_part_vertices.front();
  broken.top.row(v) = broken.base.row(v) - 0.5 * (broken.top.row(v) - broken.base.row(v));
  deformation_rest_tets(broken, &replaced);
  EXPECT_GT(replaced, 0);
}

TEST(ShellDeformer, RestTetsAreTheShellsOwnOrTheirNormalPrismsTet) {
  // Checked against the definitions: each rest tet is either the shell's own tet (its shape from
  // the shell's vertices) or, exactly when that one's volume is below kMinRestVolumeRatio of it,
  // the tet of the face's normal prism of thickness eta.
  Shell rest = flat_plane_shell(6, 0.1);
  rest.top(3 * 7 + 3, 2) = -0.05; // inverts the tets around an interior vertex
  rest.top(2 * 7 + 4, 2) = 0.00005; // flattens some: below the ratio
  rest.top(4 * 7 + 2, 2) = 0.02;    // thins some: above it
  const int n = rest.num_base_vertices();
  int replaced = 0;
  const RestTets tets = deformation_rest_tets(rest, &replaced);
  const Eigen::MatrixXi T = build_prism_tets(rest.F, n);
  const RestTets ideal = prism_rest_tets(rest.F, n, normal_prisms(rest.base, rest.F, rest.thickness));
  const Eigen::MatrixXd X = rest.vertices();
  ASSERT_EQ(tets.T, T);
  EXPECT_TRUE(tets.Dm_inv.empty()); // the positions form: a matrix only for the replaced tets
  int expected = 0;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    Eigen::Matrix3d D;
    for (int k = 0; k < 3; ++k) D.col(k) = (X.row(T(t, k + 1)) - X.row(T(t, 0))).transpose();
    const double own_volume = D.determinant() / 6;
    const bool replace = own_volume < kMinRestVolumeRatio * ideal.volume[t];
    expected += replace;
    const Eigen::Matrix3d want = replace ? ideal.dm_inv(t) : Eigen::Matrix3d(D.inverse());
    EXPECT_NEAR(tets.volume[t], replace ? ideal.volume[t] : own_volume, 1e-12) << "tet " << t;
    EXPECT_LT((tets.dm_inv(t) - want).cwiseAbs().maxCoeff(), 1e-9 * want.cwiseAbs().maxCoeff()) << "tet " << t;
  }
  EXPECT_GT(expected, 0);
  EXPECT_EQ(replaced, expected);
  EXPECT_EQ(tets.override_tets.size(), static_cast<std::size_t>(expected));
  // The per-tet form of the same shapes (pose's): every matrix and volume to the bit, the record
  // of which tets have shapes of their own kept.
  const RestTets per_tet = with_matrix_per_tet(tets);
  ASSERT_EQ(per_tet.Dm_inv.size(), static_cast<std::size_t>(T.rows()));
  EXPECT_TRUE(per_tet.rest_points.empty());
  EXPECT_TRUE(per_tet.complete());
  EXPECT_EQ(per_tet.override_tets, tets.override_tets);
  EXPECT_EQ(per_tet.volume, tets.volume);
  for (Eigen::Index t = 0; t < T.rows(); ++t) EXPECT_EQ(per_tet.dm_inv(t), tets.dm_inv(t)) << "tet " << t;
}

TEST(ShellDeformer, VertexRingsAreTheSortedEdgeNeighbours) {
  for (const Shell& shell : {flat_plane_shell(5, 0.1), sphere_shell(2, 0.1)}) {
    const int n = shell.num_base_vertices();
    std::vector<std::set<int>> want(n);
    for (Eigen::Index f = 0; f < shell.F.rows(); ++f)
      for (int c = 0; c < 3; ++c) {
        want[shell.F(f, c)].insert(shell.F(f, (c + 1) % 3));
        want[shell.F(f, (c + 1) % 3)].insert(shell.F(f, c));
      }
    const VertexRings rings = vertex_rings(shell.F, n);
    ASSERT_EQ(rings.start.size(), static_cast<std::size_t>(n + 1));
    for (int i = 0; i < n; ++i)
      EXPECT_EQ(std::vector<int>(rings.ids.begin() + rings.start[i], rings.ids.begin() + rings.start[i + 1]),
                std::vector<int>(want[i].begin(), want[i].end()))
          << "vertex " << i;
  }
}

TEST(ShellDeformer, BadFramesAreRejectedAndLeaveTheStateAlone) {
  const Shell rest = flat_plane_shell(4, 0.1);
  ShellDeformer deformer(rest);
  EXPECT_THROW(deformer.solve(rest.base.topRows(3)), InputError);
  try { // named by its columns (it said "has 25 vertices, the shell's base has 25")
    deformer.solve(rest.base.leftCols(2));
    ADD_FAILURE() << "two columns accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "the new base has 2 coordinates per vertex, not 3");
  }
  // vertex_rings checks its faces (an id past n wrote out of bounds).
  Eigen::MatrixXi bad_faces = rest.F;
  bad_faces(0, 0) = rest.num_base_vertices() + 100;
  EXPECT_THROW(vertex_rings(bad_faces, rest.num_base_vertices()), InputError);
  bad_faces(0, 0) = -1;
  EXPECT_THROW(vertex_rings(bad_faces, rest.num_base_vertices()), InputError);
  Eigen::MatrixXd bad = rest.base;
  bad(2, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(deformer.solve(bad), InputError);
  // Too small to measure (areas underflow; such a frame ran for minutes), or every vertex at one point.
  EXPECT_THROW(deformer.solve(rest.base * 1e-45), InputError);
  EXPECT_THROW(deformer.solve(rest.base * 0.0), InputError);
  EXPECT_THROW(deformer.solve(rest.base * 1e60), InputError); // beyond the coordinate limit
  // A frame in other units: the shell keeps its thickness, so a frame 1000 times larger stretched
  // every prism a thousandfold (a bowl ran for over a minute to a "valid" frame of stretch 2e6)
  // and one 1000 times smaller carried a layer 70 times its size (plane:8 ran for minutes).
  for (const double scale : {1e3, 1e-3, 10.5, 1 / 10.5}) {
    try {
      deformer.solve(rest.base * scale);
      ADD_FAILURE() << "frame accepted at scale " << scale;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("the new base: the frame is " + format_number(scale) +
                                                " times the size of the rest shell's base (other units?)", 0),
                0u)
          << e.what();
    }
  }
  // Moved 1e12 away, the size is the rest's, but a double cannot offset it by the thickness.
  try {
    deformer.solve(rest.base.array() + 1e12);
    ADD_FAILURE() << "frame accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("the new base: the shell's thickness does not fit this frame", 0), 0u) << e.what();
  }
  EXPECT_TRUE(deformer.current().isApprox(rest.vertices()));
  const FrameResult r = deformer.solve(rest.base);
  EXPECT_LT((r.top - rest.top).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(r.stretch.max, 1e-20);
  // Within 10 times either way: a growth or a shrink is carried.
  for (const double scale : {9.5, 1 / 9.5}) EXPECT_NO_THROW(ShellDeformer(rest).solve(rest.base * scale)) << scale;
}

TEST(ShellDeformer, FramesChainAndResetReturnsToTheRest) {
  const Shell rest = flat_plane_shell(8, 0.1);
  const MotionFrame frame = motion_frame(rest.base);
  ShellDeformer deformer(rest);
  deformer.solve(bend(rest.base, frame, 60));
  const FrameResult second = deformer.solve(bend(rest.base, frame, 60));
  // The same base again: the previous solution is already converged.
  EXPECT_LE(second.iterations, 1);
  EXPECT_LT((deformer.current().topRows(rest.base.rows()) - bend(rest.base, frame, 60)).norm(), 1e-14);
  deformer.reset();
  EXPECT_TRUE(deformer.current().isApprox(rest.vertices()));
  EXPECT_EQ(parse_warm_start("rotated"), WarmStart::RotatedOffset);
  EXPECT_EQ(parse_warm_start("extrapolated"), WarmStart::Extrapolated);
  EXPECT_THROW(parse_warm_start("sideways"), InputError);
}

// Back at the rest base after a fold, the frame's minimum is zero energy, which the iterations
// approach by a constant factor each: the relative change never falls below the tolerance, and
// the frame counted as cut off by the iteration cap (a false warning in `gshell deform`).
TEST(ShellDeformer, AFrameBackAtTheRestBaseConverges) {
  const Shell rest = flat_plane_shell(16, 0.3);
  const MotionFrame frame = motion_frame(rest.base);
  ShellDeformer deformer(rest);
  deformer.solve(bend(rest.base, frame, 120));
  const FrameResult back = deformer.solve(rest.base);
  expect_energy_never_increases(back);
  EXPECT_TRUE(back.converged);
  EXPECT_LT(back.iterations, DeformOptions{}.max_iterations);
  EXPECT_LT(back.stretch.max, 1e-6);
  EXPECT_LT((back.top - rest.top).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(SyntheticMotion, BendingAFlatMeshIsAnIsometryAndReachesTheAngle) {
  const TriMesh plane = make_plane(10);
  Eigen::MatrixXd V = plane.V;
  V.col(0) *= 2.0; // long axis x, length 4
  const MotionFrame frame = motion_frame(V);
  EXPECT_EQ(frame.long_axis, 0);
  EXPECT_EQ(frame.short_axis, 2);
  for (double band : {1.0, 0.3}) {
    const Eigen::MatrixXd B = bend(V, frame, 120, band);
    // Isometric: each edge's straight line becomes a curve of the same length and curvature
    // <= 1/R on the bent surface, so its chord is shorter by at most L^3 / (24 R^2) (Schur).
    const double R = band * frame.length / (120 * std::numbers::pi / 180);
    for (int f = 0; f < plane.num_faces(); ++f)
      for (int c = 0; c < 3; ++c) {
        const int a = plane.F(f, c), b = plane.F(f, (c + 1) % 3);
        const double L = (V.row(a) - V.row(b)).norm(), chord = (B.row(a) - B.row(b)).norm();
        EXPECT_LE(chord, L + 1e-12);
        EXPECT_GE(chord, L - L * L * L / (24 * R * R) - 1e-12);
      }
    // The end segments turn by the full 120 degrees when they are straight (band 0.3); on the
    // full arc they are chords, whose directions are those of the arc at their midpoints
    // (+-1.8 of +-2), hence 120 * 3.6 / 4 = 108 degrees apart.
    int left = 0, right = 0, left_in = 0, right_in = 0;
    for (int i = 0; i < V.rows(); ++i) {
      if (V(i, 1) != V(0, 1)) continue;
      if (V(i, 0) < V(left, 0)) left = i;
      if (V(i, 0) > V(right, 0)) right = i;
    }
    for (int i = 0; i < V.rows(); ++i)
      if (V(i, 1) == V(0, 1) && std::abs(V(i, 0) - (V(left, 0) + 0.4)) < 1e-12) left_in = i;
    for (int i = 0; i < V.rows(); ++i)
      if (V(i, 1) == V(0, 1) && std::abs(V(i, 0) - (V(right, 0) - 0.4)) < 1e-12) right_in = i;
    const Eigen::Vector3d tl = (B.row(left_in) - B.row(left)).normalized(), tr = (B.row(right) - B.row(right_in)).normalized();
    EXPECT_NEAR(std::acos(std::clamp(tl.dot(tr), -1.0, 1.0)) * 180 / std::numbers::pi, band == 1.0 ? 108.0 : 120.0,
                1e-9);
  }
  EXPECT_TRUE(bend(V, frame, 0).isApprox(V));
}

TEST(SyntheticMotion, TwistTurnsTheEndsByHalfTheAngle) {
  TriMesh cylinder = make_cylinder(16);
  cylinder.V.col(2) *= 2.0; // long axis z, length 4
  const MotionFrame frame = motion_frame(cylinder.V);
  EXPECT_EQ(frame.long_axis, 2);
  const Eigen::MatrixXd T = twist(cylinder.V, frame, 90);
  for (int i = 0; i < cylinder.num_vertices(); ++i) {
    const double z = cylinder.V(i, 2);
    const double turned = std::atan2(T(i, 1), T(i, 0)) - std::atan2(cylinder.V(i, 1), cylinder.V(i, 0));
    const double expected = 90.0 * (z - frame.center.z()) / frame.length * std::numbers::pi / 180;
    EXPECT_NEAR(std::remainder(std::abs(turned - expected), 2 * std::numbers::pi), 0.0, 1e-12);
    EXPECT_NEAR(T(i, 2), z, 1e-15);
  }
  EXPECT_DOUBLE_EQ(ramp(10, 10), 1.0);
  EXPECT_DOUBLE_EQ(ramp(0, 10), 0.0);
  for (int k = 1; k <= 10; ++k) EXPECT_GT(ramp(k, 10), ramp(k - 1, 10));
}

} // namespace
} // namespace gshell
