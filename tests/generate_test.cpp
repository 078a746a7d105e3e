// Shell generation: sphere analytic case, rigid vs offset on every builtin mesh, report fields.
#include "shell_fixtures.h"

#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/shell/generate_report.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/prism_tets.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <functional>
#include <limits>

using namespace gshell;
using gshell::test::generate_options;

namespace {

// Round-off of the energy sum: relative to the start energy, or to the shell's volume when the
// start is already (nearly) exact, as for a flat plane.
void expect_monotone(const std::vector<double>& E, double volume) {
  const double slack = 1e-12 * E[0] + 1e-14 * volume;
  for (std::size_t k = 1; k < E.size(); ++k) EXPECT_LE(E[k], E[k - 1] + slack) << "iteration " << k;
}

double shell_volume(const TriMesh& mesh, double eta) {
  return prism_rest_tets(mesh.F, mesh.num_vertices(), normal_prisms(mesh.V, mesh.F, eta)).volume.sum();
}

} // namespace

TEST(Generate, SphereGivesANearConcentricThinnerSphere) {
  const double r = 2.0, eta = 0.05;
  const TriMesh sphere = make_sphere(3, r);
  const GenerateResult rigid = generate_shell(sphere.V, sphere.F, generate_options(ShellMethod::Rigid, eta));
  const GenerateResult offset = generate_shell(sphere.V, sphere.F, generate_options(ShellMethod::Offset, eta));
  const Eigen::VectorXd radius = rigid.shell.top.rowwise().norm();
  const double spread = radius.maxCoeff() - radius.minCoeff();
  const double thickness = radius.mean() - r;
  EXPECT_LT(spread, 0.02 * eta) << "top is not concentric";
  // The normal prisms' tops are as large as their bases, smaller than a concentric sphere's
  // triangles at r + eta: the top sinks a little to shrink them (paper §4.1).
  EXPECT_LT(thickness, eta);
  EXPECT_GT(thickness, 0.95 * eta);
  EXPECT_LT(rigid.solve.energy.back(), offset.solve.energy.front());
  EXPECT_NEAR(rigid.solve.energy.front(), offset.solve.energy.front(), 1e-9 * offset.solve.energy.front());
  EXPECT_LT(rigid.metrics.stretch.volume_mean, offset.metrics.stretch.volume_mean);
  expect_monotone(rigid.solve.energy, shell_volume(sphere, eta));
  EXPECT_NEAR(rigid.metrics.thickness_mean, thickness / eta, 0.02); // distance to the polyhedral base
}

TEST(Generate, RigidBeatsOffsetOnEveryBuiltinMesh) {
  for (const char* spec : {"builtin:torus", "builtin:sphere", "builtin:torus:32", "builtin:plane", "builtin:cylinder",
                           "builtin:bowl"}) {
    SCOPED_TRACE(spec);
    const TriMesh mesh = make_builtin(spec);
    for (double ratio : {0.01, 0.05}) {
      const double eta = thickness_from_ratio(mesh.V, ratio);
      const GenerateResult rigid = generate_shell(mesh.V, mesh.F, generate_options(ShellMethod::Rigid, eta, 20));
      const GenerateResult offset = generate_shell(mesh.V, mesh.F, generate_options(ShellMethod::Offset, eta));
      // On the flat plane the offset shell is already exact (zero stretch): rigid can only tie.
      if (offset.metrics.stretch.volume_mean > 1e-12)
        EXPECT_LT(rigid.metrics.stretch.volume_mean, offset.metrics.stretch.volume_mean) << "ratio " << ratio;
      else
        EXPECT_LT(rigid.metrics.stretch.volume_mean, 1e-12) << "ratio " << ratio;
      EXPECT_LE(rigid.metrics.stretch.inverted, offset.metrics.stretch.inverted) << "ratio " << ratio;
      expect_monotone(rigid.solve.energy, shell_volume(mesh, eta));
      EXPECT_TRUE(rigid.shell.base == mesh.V);
      EXPECT_TRUE(rigid.shell.F == mesh.F);
      EXPECT_EQ(rigid.shell.top.rows(), mesh.V.rows());
    }
  }
}

TEST(Generate, ThicknessFromRatioUsesTheBoundingSphere) {
  TriMesh box = make_sphere(1, 1.0);
  box.V.rowwise() += Eigen::RowVector3d(5, -3, 2); // the centre is the bounding-box centre
  EXPECT_NEAR(thickness_from_ratio(box.V, 0.1), 0.1, 1e-12);
  EXPECT_THROW(thickness_from_ratio(box.V, 0), InputError);
  EXPECT_THROW(thickness_from_ratio(box.V, -1), InputError);
  EXPECT_THROW(thickness_from_ratio(box.V, std::nan("")), InputError);
  // Over the vertices the faces use: a stray point left far away does not thicken the shell.
  TriMesh stray = box;
  stray.V.conservativeResize(box.V.rows() + 1, 3);
  stray.V.row(box.V.rows()) << 100, 100, 100;
  EXPECT_EQ(thickness_from_ratio(stray.V, stray.F, 0.1), thickness_from_ratio(box.V, 0.1));
  EXPECT_GT(thickness_from_ratio(stray.V, 0.1), 1.0);
}

TEST(Generate, AStrayVertexLeavesTheThicknessReportAsItWas) {
  // A vertex no face uses carries no layer: the report's thickness figures are over the others.
  const TriMesh sphere = make_sphere(2);
  TriMesh stray = sphere;
  stray.V.conservativeResize(sphere.V.rows() + 1, 3);
  stray.V.row(sphere.V.rows()) << 100, 100, 100;
  const double eta = 0.05;
  const GenerateResult a = generate_shell(sphere.V, sphere.F, generate_options(ShellMethod::Offset, eta));
  const GenerateResult b = generate_shell(stray.V, stray.F, generate_options(ShellMethod::Offset, eta));
  EXPECT_NEAR(b.metrics.thickness_mean, a.metrics.thickness_mean, 1e-12);
  EXPECT_NEAR(b.metrics.thickness_min, a.metrics.thickness_min, 1e-12);
  EXPECT_EQ(b.metrics.thinned_vertices, a.metrics.thinned_vertices);
}

namespace {

// The message generate_shell throws for these options, "" when it does not throw.
std::string refusal(const TriMesh& mesh, ShellMethod method, double eta) {
  try {
    generate_shell(mesh.V, mesh.F, generate_options(method, eta));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

} // namespace

TEST(Generate, AThicknessOutOfScaleWithTheMeshIsRefused) {
  // A layer over ten times the model's radius, or too thin for double precision to tell the top
  // from the base, is refused by every method with the reason (bounds in generate_shell.h).
  const TriMesh sphere = make_sphere(2); // radius 1 about the origin
  for (ShellMethod method : {ShellMethod::Rigid, ShellMethod::Curvature, ShellMethod::Offset}) {
    SCOPED_TRACE(to_string(method));
    EXPECT_EQ(refusal(sphere, method, 9.9), "");
    EXPECT_EQ(refusal(sphere, method, 1e-8), "");
    EXPECT_EQ(refusal(sphere, method, 10.5),
              "thickness 10.5 is 10.5 times the mesh's bounding radius (1); gshell builds layers up to 10 times it "
              "(thickness ratio 10)");
    EXPECT_NE(refusal(sphere, method, 1e20).find("gshell builds layers up to 10 times it"), std::string::npos);
    EXPECT_EQ(refusal(sphere, method, 1e-10),
              "thickness 1e-10 is 1e-10 times the mesh's bounding radius (1), below 1e-09 of the mesh's extent (1): "
              "double precision cannot tell a top that close from the base");
  }
  // Far from the origin the coordinates' own magnitude sets the limit: 1e-4 is a fine ratio of
  // the radius but only about 900 units in the last place at 1e6.
  TriMesh far = sphere;
  far.V.rowwise() += Eigen::RowVector3d(1e6, 0, 0);
  EXPECT_EQ(refusal(far, ShellMethod::Offset, 1e-2), "");
  const std::string far_refusal = refusal(far, ShellMethod::Offset, 1e-4);
  EXPECT_NE(far_refusal.find("below 1e-09 of the mesh's extent (1e+06, its largest coordinate)"), std::string::npos)
      << far_refusal;
  // There the distance, not the size, is the cause, and the message says what to do.
  EXPECT_NE(far_refusal.find("; move the mesh near the origin"), std::string::npos) << far_refusal;
}

TEST(Generate, MethodsAndBadOptions) {
  EXPECT_EQ(parse_shell_method("rigid"), ShellMethod::Rigid);
  EXPECT_EQ(parse_shell_method("offset"), ShellMethod::Offset);
  EXPECT_EQ(parse_shell_method("curvature"), ShellMethod::Curvature);
  EXPECT_THROW(parse_shell_method("fancy"), InputError);
  const TriMesh mesh = make_sphere(1);
  EXPECT_THROW(generate_shell(mesh.V, mesh.F, generate_options(ShellMethod::Rigid, 0)), InputError);
  EXPECT_THROW(generate_shell(mesh.V, mesh.F, generate_options(ShellMethod::Rigid, std::nan(""))), InputError);
  EXPECT_THROW(generate_shell(mesh.V, mesh.F, generate_options(ShellMethod::Rigid, 0.1, -1)), InputError);
  // A history long enough to exhaust memory (its Gram matrix alone) is refused up front.
  GenerateOptions deep = generate_options(ShellMethod::Rigid, 0.1);
  deep.solve.anderson_history = kMaxAndersonHistory + 1;
  EXPECT_THROW(generate_shell(mesh.V, mesh.F, deep), InputError);
  deep.solve.anderson_history = kMaxAndersonHistory;
  EXPECT_TRUE(generate_shell(mesh.V, mesh.F, deep).metrics.certificate.valid());
  // A non-finite vertex is named as such (it was "rest tet 0 has non-positive volume (nan)", or a
  // thickness "0 times" an infinite size), and a thickness ratio does not leave it out.
  for (const double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    Eigen::MatrixXd V = mesh.V;
    V(1, 2) = bad;
    for (const auto& run : std::vector<std::function<void()>>{
             [&] { generate_shell(V, mesh.F, generate_options(ShellMethod::Rigid, 0.1)); },
             [&] { thickness_from_ratio(V, 0.1); }, [&] { thickness_from_ratio(V, mesh.F, 0.1); }}) {
      try {
        run();
        ADD_FAILURE() << "accepted " << bad;
      } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("vertex 1 has a non-finite coordinate"), std::string::npos) << e.what();
      }
    }
  }
}

TEST(Generate, ReportHasEveryField) {
  const TriMesh mesh = make_builtin("builtin:torus:24");
  GenerateOptions o = generate_options(ShellMethod::Rigid, 0.05, 5);
  o.count_intersections = true;
  const GenerateResult r = generate_shell(mesh.V, mesh.F, o);
  const nlohmann::json j = generate_report(r, "builtin:torus:24", 0.02);
  for (const char* key : {"method", "thickness", "vertices", "faces", "tets", "iterations", "energy", "stretch", "valid",
                          "certificate", "base_self_intersections", "thinned_vertices", "seconds"})
    EXPECT_TRUE(j.contains(key)) << key;
  // One key for one thing: the certificate holds the exact counts.
  for (const char* key : {"inverted_tets", "top_self_intersections", "top_base_intersections"})
    EXPECT_FALSE(j.contains(key)) << key;
  EXPECT_EQ(j["method"], "rigid");
  EXPECT_EQ(j["vertices"], mesh.V.rows());
  EXPECT_EQ(j["faces"], mesh.F.rows());
  EXPECT_EQ(j["tets"], 3 * mesh.F.rows());
  EXPECT_EQ(j["energy"].size(), static_cast<std::size_t>(r.solve.iterations + 1));
  for (const char* key : {"mean", "volume_mean", "max", "p99"}) EXPECT_TRUE(j["stretch"].contains(key)) << key;
  for (const char* key : {"eta", "ratio", "min", "mean"}) EXPECT_TRUE(j["thickness"].contains(key)) << key;
  for (const char* key : {"total", "factor", "solve", "certificate", "metrics"}) EXPECT_TRUE(j["seconds"].contains(key)) << key;
  EXPECT_DOUBLE_EQ(j["thickness"]["eta"].get<double>(), 0.05);
  // A thin shell of a smooth torus is valid.
  EXPECT_EQ(j["valid"], true);
  EXPECT_EQ(j["certificate"], nlohmann::json({{"inverted_tets", 0},
                                               {"top_self_intersections", 0},
                                               {"top_base_intersections", 0},
                                               {"wall_intersections", 0},
                                               {"nested_parts", 0},
                                               {"exact", true}}));
  EXPECT_EQ(j["base_self_intersections"], 0);
  EXPECT_EQ(j["thinned_vertices"], (r.metrics.vertex_thickness.array() < 0.9).count());
  // Guarded: `converged` is the paper's iterations' and the repair's together (nothing to repair here).
  EXPECT_EQ(j["guard"]["paper_converged"], r.guard.paper.converged);
  EXPECT_EQ(j["guard"]["repair_converged"], true);
  EXPECT_EQ(j["converged"], r.guard.paper.converged);
  for (const char* key : {"paper", "repair", "relax", "lift"}) EXPECT_TRUE(j["guard"]["seconds"].contains(key)) << key;
  EXPECT_DOUBLE_EQ(j["guard"]["seconds"]["paper"].get<double>(), r.guard.paper.seconds);
  // The terminal summary says the same as the report.
  const std::string summary = generate_summary(r, "builtin:torus:24");
  const std::string faces = std::to_string(mesh.F.rows());
  for (const std::string& part :
       {std::string("input        builtin:torus:24"),
        "shell        " + std::to_string(mesh.V.rows()) + " vertices, " + faces + " faces, " +
            std::to_string(3 * mesh.F.rows()) + " tets, eta 0.05, method rigid",
        "after " + std::to_string(r.solve.iterations) + " paper iterations", // guarded: the repair's are on its line
        std::string("valid        yes (exact: 0 inverted tets; top/top 0, top/base 0, wall 0 intersecting face pairs)"),
        "(x eta), " + j["thinned_vertices"].dump() + " top vertices below 0.9 eta"})
    EXPECT_NE(summary.find(part), std::string::npos) << part << "\n" << summary;
  char stretch[64];
  std::snprintf(stretch, sizeof stretch, "volume-weighted %.4g", r.metrics.stretch.volume_mean);
  EXPECT_NE(summary.find(stretch), std::string::npos) << stretch << "\n" << summary;
}

TEST(Generate, CurvatureRejectsBadClamps) {
  const TriMesh mesh = make_sphere(1);
  GenerateOptions options = generate_options(ShellMethod::Curvature, 0.1);
  options.s_min = 0;
  EXPECT_THROW(generate_shell(mesh.V, mesh.F, options), InputError);
}

TEST(Generate, ConjugateGradientPathGivesTheDirectReport) {
  // Forced through GenerateOptions::linear: the same shell and report figures as the factor, to
  // within the solver's tolerance, on a sphere and a torus at two thicknesses.
  for (const char* spec : {"builtin:sphere:3", "builtin:torus:48"}) {
    const TriMesh mesh = make_builtin(spec);
    for (double ratio : {0.01, 0.05}) {
      SCOPED_TRACE(std::string(spec) + " ratio " + std::to_string(ratio));
      GenerateOptions options = generate_options(ShellMethod::Rigid, thickness_from_ratio(mesh.V, ratio));
      options.linear.kind = LinearSolver::Direct;
      const GenerateResult direct = generate_shell(mesh.V, mesh.F, options);
      options.linear.kind = LinearSolver::ConjugateGradient;
      const GenerateResult cg = generate_shell(mesh.V, mesh.F, options);
      EXPECT_GT(cg.solve.linear_iterations, 0);
      EXPECT_EQ(cg.solve.iterations, direct.solve.iterations);
      EXPECT_NEAR(cg.solve.energy.back(), direct.solve.energy.back(), 1e-7 * direct.solve.energy.front());
      EXPECT_NEAR(cg.metrics.stretch.mean, direct.metrics.stretch.mean, 1e-6 * direct.metrics.stretch.mean);
      EXPECT_NEAR(cg.metrics.stretch.max, direct.metrics.stretch.max, 1e-6 * direct.metrics.stretch.max);
      EXPECT_NEAR(cg.metrics.thickness_min, direct.metrics.thickness_min, 1e-7);
      EXPECT_EQ(cg.metrics.stretch.inverted, direct.metrics.stretch.inverted);
      EXPECT_LT((cg.shell.top - direct.shell.top).cwiseAbs().maxCoeff(), 1e-6 * options.thickness);
    }
  }
}

TEST(Generate, ABaseWithItsFacesPointingInwardsIsNamedInAWarning) {
  // A mirrored export flips every face: the layer then grows into the solid, valid but likely
  // not what was meant. The same sphere the right way round gets no warning.
  TriMesh sphere = make_builtin("builtin:sphere:2");
  const GenerateResult outward = generate_shell(sphere.V, sphere.F, generate_options(ShellMethod::Rigid, 0.05, 5));
  for (const std::string& w : generate_warnings(outward)) ADD_FAILURE() << "unexpected warning: " << w;
  sphere.V.col(0) *= -1;
  const GenerateResult inward = generate_shell(sphere.V, sphere.F, generate_options(ShellMethod::Rigid, 0.05, 5));
  ASSERT_TRUE(inward.metrics.certificate.valid());
  EXPECT_LT((inward.shell.top.rowwise().norm().array() - 1).maxCoeff(), 0) << "not an inward shell: nothing tested";
  const std::vector<std::string> w = generate_warnings(inward);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].rfind("the base's 1 closed part has its faces pointing inwards (the part with vertex 0", 0), 0u) << w[0];
}

TEST(Generate, WarningNamesWhatTheValidStartCouldNotMend) {
  // A guarded result whose start left a tet and a boundary pair unmended (as on a base folded
  // flat onto itself at its rim, CGAL's cylinder_locally_refined): the warning names the base
  // vertices involved, narrowest extrusion cone first, and the invalid-shell warning gives that
  // as the cause instead of crossings or unextrudable vertices the base does not have.
  const TriMesh mesh = make_builtin("builtin:torus:24");
  GenerateResult r = generate_shell(mesh.V, mesh.F, generate_options(ShellMethod::Rigid, 0.05, 5));
  ASSERT_TRUE(r.guarded);
  ASSERT_TRUE(r.metrics.certificate.valid());
  for (const std::string& w : generate_warnings(r)) ADD_FAILURE() << "unexpected warning: " << w;
  const int f = 7;
  r.guard.start.inverted_tets = {3 * f + 1};
  r.guard.start.intersections = {{f, 2 * static_cast<int>(mesh.F.rows()) - 1}}; // a base row and a top row
  const int narrowest = mesh.F(f, 2);
  r.guard.directions.margin[narrowest] = 1e-5;
  r.metrics.certificate.inverted_tets = 1;
  const std::vector<std::string> w = generate_warnings(r);
  ASSERT_EQ(w.size(), 2u);
  const std::string opening =
      "the valid start could not mend 1 tets and 1 boundary triangle pairs around base vertices " +
      std::to_string(narrowest) + ", ";
  EXPECT_EQ(w[0].rfind(opening, 0), 0u) << w[0];
  EXPECT_NE(w[0].find("smallest extrusion margin 1e-05"), std::string::npos) << w[0];
  for (int k = 0; k < 3; ++k) {
    EXPECT_NE(w[0].find(std::to_string(mesh.F(f, k))), std::string::npos) << w[0];
    const int top_face_vertex = mesh.F(mesh.F.rows() - 1, k);
    EXPECT_NE(w[0].find(std::to_string(top_face_vertex)), std::string::npos) << "top row's base vertex " << w[0];
  }
  EXPECT_NE(w[1].find("(near what the start could not mend)"), std::string::npos) << w[1];
  EXPECT_EQ(generate_report(r, "builtin:torus:24", 0.02)["guard"]["start_unmended_tets"], 1);
  // Wide cones everywhere: nothing is folded, so the cause named is parts of the base nearly
  // touching (two spheres 1e-12 apart were said to have "faces folded nearly flat", margin 1).
  r.guard.directions.margin.setConstant(0.95);
  r.guard.start.rounds = 57;
  r.guard.start.scale.setOnes();
  r.guard.start.scale[narrowest] = std::ldexp(1.0, -39); // the thinnest of the vertices named
  r.guard.start.scale[100] = 1e-20;                      // not one of them
  const std::string touching = generate_warnings(r)[0];
  EXPECT_EQ(touching.find("folded nearly flat"), std::string::npos) << touching;
  EXPECT_NE(touching.find("parts of the base lie closer to each other than the start could thin the layer to "
                          "(1.8e-12 of it, after 57 rounds), nearly touching; their faces are not folded: smallest "
                          "extrusion margin 0.95"),
            std::string::npos)
      << touching;
}
