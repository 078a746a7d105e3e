// Uniform scaling: a shell problem scaled by s is the same problem, so everything without a unit
// (stretch, inverted tets, intersections, thickness relative to eta, positions relative to s)
// must come out the same at the smallest and the largest scale gshell accepts (validate_mesh.h:
// |x| < 1e50, size >= 1e-40) as at scale 1. This is what the coordinate limits promise: no
// product of lengths formed on the way (volumes, squared areas, determinants of moment matrices)
// overflows or underflows, and no tolerance is absolute.
#include <gshell/deform/handles.h>
#include <gshell/deform/pose.h>
#include <gshell/deform/shell_deformer.h>
#include <gshell/deform/synthetic_motion.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/run/pose_run.h>
#include <gshell/shell/generate_shell.h>

#include <gtest/gtest.h>

#include <cmath>
#include <string>

using namespace gshell;

namespace {

// Both extremes are inside the limits for meshes within [-1, 1]^3 with a diagonal above 0.1.
constexpr double kSmallest = 1e-40, kLargest = 9.9e49;
const double kScales[] = {kSmallest, kLargest};

/// Relative agreement of two dimensionless figures (absolute near 0).
void expect_same(double at_one, double scaled, const std::string& what, double tolerance = 1e-6) {
  EXPECT_NEAR(scaled, at_one, tolerance * std::max(1.0, std::abs(at_one))) << what;
}

void expect_same_stretch(const StretchStats& one, const StretchStats& scaled, const std::string& what) {
  expect_same(one.mean, scaled.mean, what + " mean stretch");
  expect_same(one.volume_mean, scaled.volume_mean, what + " volume-weighted stretch");
  expect_same(one.max, scaled.max, what + " max stretch");
  expect_same(one.p99, scaled.p99, what + " p99 stretch");
  EXPECT_EQ(one.inverted, scaled.inverted) << what;
}

GenerateResult generate(const TriMesh& mesh, double scale, ShellMethod method) {
  GenerateOptions options;
  options.method = method;
  const Eigen::MatrixXd V = mesh.V * scale;
  options.thickness = thickness_from_ratio(V, 0.05);
  return generate_shell(V, mesh.F, options);
}

} // namespace

TEST(ScaleInvariance, MeshesAtTheLimitsAreValid) {
  for (const double s : kScales) {
    TriMesh sphere = make_sphere(2);
    sphere.V *= s;
    EXPECT_NO_THROW(require_valid_mesh(sphere, "sphere")) << s;
    EXPECT_TRUE(validate_mesh(sphere).empty()) << s;
  }
}

TEST(ScaleInvariance, GeneratedShellsAreTheSameAtEveryScale) {
  const TriMesh sphere = make_sphere(2), bowl = make_bowl(8);
  for (const ShellMethod method : {ShellMethod::Offset, ShellMethod::Rigid, ShellMethod::Curvature})
    for (const TriMesh* mesh : {&sphere, &bowl}) {
      const GenerateResult one = generate(*mesh, 1.0, method);
      for (const double s : kScales) {
        const std::string what = to_string(method) + (mesh == &sphere ? " sphere" : " bowl") + " at scale " +
                                 std::to_string(s);
        const GenerateResult r = generate(*mesh, s, method);
        expect_same_stretch(one.metrics.stretch, r.metrics.stretch, what);
        // The exact certificate (orient3d and exact intersection tests) at every scale too.
        const ShellCertificate &c1 = one.metrics.certificate, &cs = r.metrics.certificate;
        EXPECT_EQ(c1.inverted_tets, cs.inverted_tets) << what;
        EXPECT_EQ(c1.top_self_intersections, cs.top_self_intersections) << what;
        EXPECT_EQ(c1.top_base_intersections, cs.top_base_intersections) << what;
        EXPECT_EQ(c1.wall_intersections, cs.wall_intersections) << what;
        expect_same(one.metrics.thickness_min, r.metrics.thickness_min, what + " thickness min");
        expect_same(one.metrics.thickness_mean, r.metrics.thickness_mean, what + " thickness mean");
        EXPECT_EQ(one.solve.converged, r.solve.converged) << what;
        EXPECT_LE((r.shell.top / s - one.shell.top).cwiseAbs().maxCoeff(), 1e-6) << what;
      }
    }
}

TEST(ScaleInvariance, FlatShellConvergesAtOnceAtEveryScale) {
  // The offset of a plane is already the optimum: the energy is rounding noise from the start and
  // has no relative change to wait for (it used to run to the iteration limit at most scales).
  const TriMesh plane = make_plane(6);
  for (const double s : {kSmallest, 3.0, kLargest}) {
    const GenerateResult r = generate(plane, s, ShellMethod::Rigid);
    EXPECT_TRUE(r.solve.converged) << s;
    EXPECT_LE(r.solve.iterations, 2) << s;
    EXPECT_LT(r.metrics.stretch.max, 1e-20) << s;
  }
}

TEST(ScaleInvariance, DeformedFramesAreTheSameAtEveryScale) {
  const TriMesh plane = make_plane(8);
  auto frames_at = [&](double s) {
    const GenerateResult shell = generate(plane, s, ShellMethod::Rigid);
    ShellDeformer deformer(shell.shell);
    const MotionFrame frame = motion_frame(shell.shell.base);
    std::vector<FrameResult> out;
    for (const double degrees : {45.0, 90.0}) out.push_back(deformer.solve(bend(shell.shell.base, frame, degrees)));
    return out;
  };
  const auto one = frames_at(1.0);
  for (const double s : kScales) {
    const auto scaled = frames_at(s);
    for (size_t k = 0; k < one.size(); ++k) {
      const std::string what = "frame " + std::to_string(k) + " at scale " + std::to_string(s);
      expect_same_stretch(one[k].stretch, scaled[k].stretch, what);
      EXPECT_LE((scaled[k].top / s - one[k].top).cwiseAbs().maxCoeff(), 1e-6) << what;
    }
  }
}

TEST(ScaleInvariance, PosesAreTheSameAtEveryScaleWithBothSolvers) {
  const TriMesh plane = make_plane(8);
  // Returns a matrix, not `X / s` as an Eigen expression: that would refer to the destroyed result.
  auto pose_at = [&](double s, PoseSolverKind kind) -> Eigen::MatrixXd {
    const Shell rest = generate(plane, s, ShellMethod::Rigid).shell;
    const int n = rest.num_base_vertices();
    Handle hold, pull;
    for (int v = 0; v < 2 * n; ++v) {
      const double x = (v < n ? rest.base(v, 0) : rest.top(v - n, 0)) / s;
      if (x < -0.7) hold.vertices.push_back(v);
      if (x > 0.7) pull.vertices.push_back(v);
    }
    pull.translate = Eigen::Vector3d(0, 0, 0.2) * s;
    pull.axis = Eigen::Vector3d::UnitY();
    pull.degrees = 10;
    pull.center = Eigen::Vector3d(1, 0, 0) * s;
    HandleSet handles;
    handles.handles = {hold, pull};
    PoseOptions options;
    options.solver = kind;
    options.steps = 2;
    // Tight: at the default tolerance the stopping point depends on rounding (8e-4 apart).
    options.solve.tolerance = 1e-12;
    options.solve.max_iterations = 1000;
    return run_pose(rest, handles, options).X / s;
  };
  for (const PoseSolverKind kind : {PoseSolverKind::Single, PoseSolverKind::Hierarchical}) {
    const Eigen::MatrixXd one = pose_at(1.0, kind);
    for (const double s : kScales)
      EXPECT_LE((pose_at(s, kind) - one).cwiseAbs().maxCoeff(), 1e-4)
          << (kind == PoseSolverKind::Single ? "single" : "hierarchical") << " at scale " << s;
  }
}
