// The curvature method of shell generation against the rigid one, library and CLI.
#include "shell_fixtures.h"
#include "test_support.h"

#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/shell/curvature_shell.h>
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
  const CurvatureShellResult c = generate_curvature_shell(plane.V, plane.F, generate_options(ShellMethod::Rigid, eta));
  EXPECT_EQ(curved.method, ShellMethod::Curvature);
  EXPECT_LT((curved.shell.top - rigid.shell.top).cwiseAbs().maxCoeff(), 1e-9 * eta);
  EXPECT_LT((c.result.shell.top - rigid.shell.top).cwiseAbs().maxCoeff(), 1e-9 * eta);
  EXPECT_EQ(c.prisms.clamped, 0);
  EXPECT_EQ(c.prisms.limited, 0);
}

TEST(CurvatureShell, SphereKeepsTheThicknessBetterThanRigid) {
  const double r = 1.0, eta = 0.15;
  const TriMesh sphere = make_sphere(3, r);
  const GenerateResult rigid = generate_shell(sphere.V, sphere.F, generate_options(ShellMethod::Rigid, eta));
  const CurvatureShellResult c = generate_curvature_shell(sphere.V, sphere.F, generate_options(ShellMethod::Curvature, eta));
  const Eigen::VectorXd rigid_radius = rigid.shell.top.rowwise().norm();
  const Eigen::VectorXd curved_radius = c.result.shell.top.rowwise().norm();
  const double rigid_error = std::abs(rigid_radius.mean() - r - eta);
  const double curved_error = std::abs(curved_radius.mean() - r - eta);
  EXPECT_LT(curved_error, 0.5 * rigid_error) << "rigid " << rigid_radius.mean() - r << " curvature "
                                             << curved_radius.mean() - r;
  EXPECT_LT(curved_error, 0.02 * eta);
  // Per vertex too: the thinnest point of the curvature shell is thicker than rigid's.
  EXPECT_GT(c.result.metrics.thickness_min, rigid.metrics.thickness_min);
  EXPECT_LT(curved_radius.maxCoeff() - curved_radius.minCoeff(), 0.02 * eta); // still concentric
  // It is near its own ideal prisms, much nearer than rigid gets to the normal prisms.
  EXPECT_LT(c.own_stretch.volume_mean, 0.25 * rigid.metrics.stretch.volume_mean);
  EXPECT_EQ(c.own_stretch.inverted, 0);
  EXPECT_EQ(c.result.metrics.stretch.inverted, 0);
  EXPECT_EQ(c.prisms.clamped, 0);
}

TEST(CurvatureShell, ReportCarriesClampsAndOwnStretch) {
  const TriMesh torus = make_torus(24);
  GenerateOptions options = generate_options(ShellMethod::Curvature, 0.3);
  options.s_min = 0.8; // the inner equator wants ~0.5 (1 - 0.3/0.6): clamped
  const CurvatureShellResult c = generate_curvature_shell(torus.V, torus.F, options);
  EXPECT_GT(c.prisms.clamped, 0);
  nlohmann::json report = generate_report(c.result, "builtin:torus:24");
  add_curvature_report(report, c);
  EXPECT_EQ(report["method"], "curvature");
  EXPECT_EQ(report["curvature"]["clamped_prisms"], c.prisms.clamped);
  EXPECT_DOUBLE_EQ(report["curvature"]["s_min"].get<double>(), 0.8);
  EXPECT_DOUBLE_EQ(report["curvature"]["s_max"].get<double>(), 2.0);
  for (const char* key : {"mean", "volume_mean", "max", "p99", "inverted_tets"})
    EXPECT_TRUE(report["curvature"]["stretch_own"].contains(key)) << key;
  EXPECT_TRUE(report["curvature"].contains("limited_prisms"));
  EXPECT_NE(curvature_summary(c).find("clamped"), std::string::npos);
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
  EXPECT_LT(report["curvature"]["stretch_own"]["volume_mean"].get<double>(),
            report["stretch"]["volume_mean"].get<double>());

  for (const std::string args : {"--s-min 0", "--s-min 1.2", "--s-max 0.5", "--s-max nan"}) {
    TempDir bad;
    const CliResult e = run_cli("generate builtin:sphere:1 -o '" + bad.file("shell") +
                                "' --thickness 0.1 --method curvature " + args);
    EXPECT_EQ(e.exit_code, 1) << args << "\n" << e.err;
    EXPECT_NE(e.err.find("s_min"), std::string::npos) << e.err;
    EXPECT_EQ(count_entries(bad.path()), 0) << args;
  }
}
