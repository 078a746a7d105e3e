// The curvature method of shell generation against the rigid one, library and CLI.
#include "shell_fixtures.h"
#include "test_support.h"

#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/shell/generate_report.h>
#include <gshell/shell/generate_shell.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

using namespace gshell;
using namespace gshell::test;

TEST(CurvatureShell, PlaneGivesTheRigidShell) {
  const TriMesh plane = make_plane(12, 1.0);
  const double eta = 0.2;
  const GenerateResult rigid = generate_shell(plane.V, plane.F, generate_options(ShellMethod::Rigid, eta));
  const GenerateResult curved = generate_shell(plane.V, plane.F, generate_options(ShellMethod::Curvature, eta));
  EXPECT_EQ(curved.method, ShellMethod::Curvature);
  EXPECT_FALSE(rigid.curvature.has_value());
  ASSERT_TRUE(curved.curvature.has_value());
  EXPECT_LT((curved.shell.top - rigid.shell.top).cwiseAbs().maxCoeff(), 1e-9 * eta);
  EXPECT_EQ(curved.curvature->prisms.clamped, 0);
  EXPECT_EQ(curved.curvature->prisms.limited, 0);
}

TEST(CurvatureShell, SphereKeepsTheThicknessBetterThanRigid) {
  const double r = 1.0, eta = 0.15;
  const TriMesh sphere = make_sphere(3, r);
  const GenerateResult rigid = generate_shell(sphere.V, sphere.F, generate_options(ShellMethod::Rigid, eta));
  const GenerateResult c = generate_shell(sphere.V, sphere.F, generate_options(ShellMethod::Curvature, eta));
  ASSERT_TRUE(c.curvature.has_value());
  const Eigen::VectorXd rigid_radius = rigid.shell.top.rowwise().norm();
  const Eigen::VectorXd curved_radius = c.shell.top.rowwise().norm();
  const double rigid_error = std::abs(rigid_radius.mean() - r - eta);
  const double curved_error = std::abs(curved_radius.mean() - r - eta);
  EXPECT_LT(curved_error, 0.5 * rigid_error) << "rigid " << rigid_radius.mean() - r << " curvature "
                                             << curved_radius.mean() - r;
  EXPECT_LT(curved_error, 0.02 * eta);
  // Per vertex too: the thinnest point of the curvature shell is thicker than rigid's.
  EXPECT_GT(c.metrics.thickness_min, rigid.metrics.thickness_min);
  EXPECT_LT(curved_radius.maxCoeff() - curved_radius.minCoeff(), 0.02 * eta); // still concentric
  // It is near its own ideal prisms, much nearer than rigid gets to the normal prisms.
  EXPECT_LT(c.curvature->own_stretch.volume_mean, 0.25 * rigid.metrics.stretch.volume_mean);
  EXPECT_EQ(c.curvature->own_stretch.inverted, 0);
  EXPECT_EQ(c.metrics.stretch.inverted, 0);
  EXPECT_EQ(c.curvature->prisms.clamped, 0);
}

TEST(CurvatureShell, ReportCarriesClampsAndOwnStretch) {
  const TriMesh torus = make_torus(24);
  GenerateOptions options = generate_options(ShellMethod::Curvature, 0.3);
  options.s_min = 0.8; // the inner equator wants ~0.5 (1 - 0.3/0.6): clamped
  const GenerateResult c = generate_shell(torus.V, torus.F, options);
  ASSERT_TRUE(c.curvature.has_value());
  EXPECT_GT(c.curvature->prisms.clamped, 0);
  const nlohmann::json report = generate_report(c, "builtin:torus:24");
  EXPECT_EQ(report["method"], "curvature");
  EXPECT_EQ(report["curvature"]["clamped_prisms"], c.curvature->prisms.clamped);
  EXPECT_EQ(report["curvature"]["limited_prisms"], c.curvature->prisms.limited);
  EXPECT_DOUBLE_EQ(report["curvature"]["s_min"].get<double>(), 0.8);
  EXPECT_DOUBLE_EQ(report["curvature"]["s_max"].get<double>(), 2.0);
  const nlohmann::json& own = report["curvature"]["own_prisms"];
  EXPECT_DOUBLE_EQ(own["stretch"]["volume_mean"].get<double>(), c.curvature->own_stretch.volume_mean);
  EXPECT_DOUBLE_EQ(own["stretch"]["max"].get<double>(), c.curvature->own_stretch.max);
  EXPECT_EQ(own["inverted_tets"], c.curvature->own_stretch.inverted);
  const std::string summary = generate_summary(c, "builtin:torus:24");
  EXPECT_NE(summary.find(std::to_string(c.curvature->prisms.clamped) + " of " + std::to_string(torus.num_faces()) +
                         " prisms clamped"),
            std::string::npos)
      << summary;
}

TEST(CurvatureShellCli, GenerateWithTheCurvatureMethod) {
  TempDir tmp;
  const std::string out = tmp.file("shell");
  const CliResult r = run_cli("generate builtin:sphere:2 -o '" + out +
                              "' --thickness 0.2 --method curvature --s-min 0.6 --s-max 1.5 --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("clamped"), std::string::npos) << r.out;
  const nlohmann::json report = nlohmann::json::parse(read_text(out + "/report.json"));
  EXPECT_EQ(report["method"], "curvature");
  EXPECT_EQ(report["curvature"]["clamped_prisms"], 0); // 1 + 0.2 * 1 = 1.2 is within [0.6, 1.5]
  EXPECT_DOUBLE_EQ(report["curvature"]["s_max"].get<double>(), 1.5);
  EXPECT_LT(report["curvature"]["own_prisms"]["stretch"]["volume_mean"].get<double>(),
            report["stretch"]["volume_mean"].get<double>());

  for (const std::string args : {"--s-min 0", "--s-min 1.2", "--s-max 0.5", "--s-max nan"}) {
    TempDir bad;
    const CliResult e = run_cli("generate builtin:sphere:1 -o '" + bad.file("shell") +
                                "' --thickness 0.1 --method curvature " + args);
    EXPECT_EQ(e.exit_code, 1) << args << "\n" << e.err;
    EXPECT_NE(e.err.find("--s-min"), std::string::npos) << e.err; // the library's s_min, named as the flag
    EXPECT_EQ(count_entries(bad.path()), 0) << args;
  }
}
