// `gshell info`: right figures for the built-in meshes, problems listed, exit codes 0/1.
#include "test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <regex>
#include <string>

using gshell::test::run_cli;
using gshell::test::TempDir;
using gshell::test::write_text;

namespace {

int lines_in(const std::string& text) {
  return static_cast<int>(std::count(text.begin(), text.end(), '\n')) + (!text.empty() && text.back() != '\n');
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

struct Expected {
  std::string spec;
  int vertices, faces, edges, boundary_loops, chi;
  double genus;
};

} // namespace

class InfoOnBuiltins : public ::testing::TestWithParam<Expected> {};

TEST_P(InfoOnBuiltins, ReportsTheAnalyticCounts) {
  const Expected& e = GetParam();
  const auto r = run_cli("info " + e.spec + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["vertices"], e.vertices);
  EXPECT_EQ(j["faces"], e.faces);
  EXPECT_EQ(j["edges"], e.edges);
  EXPECT_EQ(j["boundary_loops"], e.boundary_loops);
  EXPECT_EQ(j["components"], 1);
  EXPECT_EQ(j["euler_characteristic"], e.chi);
  EXPECT_EQ(j["genus"].get<double>(), e.genus);
  EXPECT_TRUE(j["genus"].is_number_integer()) << j["genus"]; // 1, not 1.0, for strict readers
  EXPECT_EQ(e.vertices - e.edges + e.faces, e.chi); // the expectations themselves are consistent
  for (const auto& p : j["problems"]) EXPECT_EQ(p["severity"], "info") << p["message"];
  EXPECT_EQ(j["problems"].size(), e.boundary_loops > 0 ? 1u : 0u);
}

// Counts from the documented formulas: sphere 10*4^l+2 vertices, torus n*(n/2), plane (n+1)^2,
// cylinder n*(round(n/pi)+1); edges = (3F + boundary edges)/2.
INSTANTIATE_TEST_SUITE_P(
    Builtins, InfoOnBuiltins,
    ::testing::Values(Expected{"builtin:sphere", 2562, 5120, 7680, 0, 2, 0},
                      Expected{"builtin:sphere:1", 42, 80, 120, 0, 2, 0},
                      Expected{"builtin:torus:16", 128, 256, 384, 0, 0, 1},
                      Expected{"builtin:plane:4", 25, 32, 56, 1, 1, 0},
                      Expected{"builtin:cylinder:12", 60, 96, 156, 2, 0, 0}),
    [](const auto& info) {
      std::string name = info.param.spec.substr(8);
      std::replace(name.begin(), name.end(), ':', '_');
      return name;
    });

TEST(InfoCli, TextOutputNamesEveryFigure) {
  const auto r = run_cli("info builtin:torus:16");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* key : {"vertices", "faces", "edges", "boundary loops", "components", "euler characteristic", "genus",
                          "bounding box", "mean edge length", "problems"})
    EXPECT_TRUE(std::regex_search(r.out, std::regex(std::string("(^|\n)") + key + ":"))) << key << "\n" << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex("\nvertices: +128\n"))) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex("\ngenus: +1\n"))) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex("\nproblems: +none\n"))) << r.out;
}

TEST(InfoCli, OpenSurfaceIsInformationNotAnError) {
  const auto r = run_cli("info builtin:bowl:10");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "info: open surface: 1 boundary loop")) << r.out;
}

TEST(InfoCli, NonManifoldEdgeExitsOneAndIsListed) {
  TempDir dir;
  const std::string path = dir.file("fin.off");
  // Three triangles on edge (0, 1).
  write_text(path, "OFF\n5 3 0\n0 0 0\n1 0 0\n0.5 1 0\n0.5 -1 0\n0.5 0 1\n3 0 1 2\n3 1 0 3\n3 0 1 4\n");
  const auto r = run_cli("info '" + path + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_TRUE(contains(r.out, "error: edge (0, 1) is non-manifold")) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex("\nvertices: +5\n"))) << r.out; // figures still printed
  EXPECT_EQ(lines_in(r.err), 1) << r.err;
  EXPECT_TRUE(contains(r.err, path)) << r.err;
}

TEST(InfoCli, FiguresOfMeshesOutsideTheRangeAreTheirOwn) {
  // A unit right tetrahedron scaled to 1e300 and 1e-300: gshell refuses both (an error listed),
  // but the figures info prints must still be right, not squared lengths' overflow or underflow.
  TempDir dir;
  const double edges_sum = 3 + 3 * std::sqrt(2.0); // 3 unit edges and 3 of length sqrt 2
  for (const double scale : {1e300, 1e-300}) {
    const std::string path = dir.file("scaled.off");
    char text[400];
    std::snprintf(text, sizeof text, "OFF\n4 4 0\n0 0 0\n%.17g 0 0\n0 %.17g 0\n0 0 %.17g\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n",
                  scale, scale, scale);
    write_text(path, text);
    const auto r = run_cli("info '" + path + "' --json");
    EXPECT_EQ(r.exit_code, 1) << scale;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_NEAR(j["mean_edge_length"].get<double>() / scale, edges_sum / 6, 1e-12) << scale;
    const auto t = run_cli("info '" + path + "'");
    char diagonal[64];
    std::snprintf(diagonal, sizeof diagonal, "(diagonal %.6g)", std::sqrt(3.0) * scale);
    EXPECT_TRUE(contains(t.out, diagonal)) << diagonal << "\n" << t.out;
  }
}

TEST(InfoCli, ASurfaceThatCrossesItselfIsAWarning) {
  // A non-convex pentagon, split as a fan from its first corner: the fan's middle triangle folds
  // over the other two (generate then found the crossing only after its run).
  TempDir dir;
  const std::string path = dir.file("nonconvex.obj");
  write_text(path, "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 1 0.5 0\nv 0 2 0\nf 1 2 3 4 5\n");
  const auto r = run_cli("info '" + path + "' --json");
  EXPECT_EQ(r.exit_code, 0) << r.err; // a shell can be built, just not a clean one there
  const auto j = nlohmann::json::parse(r.out);
  int crossings = 0;
  for (const auto& p : j["problems"])
    if (p["severity"] == "warning" && contains(p["message"].get<std::string>(), "the surface intersects itself"))
      crossings += p["count"].get<int>();
  EXPECT_GT(crossings, 0) << j["problems"];
  // A surface that does not cross itself gets no such warning.
  EXPECT_FALSE(contains(run_cli("info builtin:torus:16").out, "intersects itself"));
}

TEST(InfoCli, UnreferencedVertexIsOnlyAWarning) {
  TempDir dir;
  const std::string path = dir.file("extra.off");
  write_text(path, "OFF\n5 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n9 9 9\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n");
  const auto r = run_cli("info '" + path + "'");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "warning: vertex 4 is used by no face")) << r.out;
}

TEST(InfoCli, MissingFileExitsOneWithOneLineNamingIt) {
  TempDir dir;
  const std::string path = dir.file("no_such_mesh.off");
  const auto r = run_cli("info '" + path + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(lines_in(r.err), 1) << r.err;
  EXPECT_TRUE(contains(r.err, path)) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST(InfoCli, BadBuiltinSpecExitsOne) {
  for (const char* spec : {"builtin:cube", "builtin:sphere:x", "builtin:torus:2"}) {
    const auto r = run_cli(std::string("info ") + spec);
    EXPECT_EQ(r.exit_code, 1) << spec;
    EXPECT_EQ(lines_in(r.err), 1) << r.err;
    EXPECT_TRUE(contains(r.err, spec)) << r.err;
  }
}

TEST(InfoCli, HelpDocumentsTheExitCode) {
  const auto r = run_cli("info --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_TRUE(contains(r.out, "1 if it has validation errors")) << r.out;
}

// load_mesh is what every other subcommand uses: builtin or file, then validation that throws.
#include <gshell/error.h>
#include <gshell/io/load_mesh.h>

TEST(LoadMesh, BuiltinsLoadAndBrokenFilesThrowNamingTheFile) {
  EXPECT_EQ(gshell::load_mesh("builtin:torus:8").num_vertices(), 32);
  EXPECT_THROW(gshell::load_mesh("builtin:nothing"), gshell::InputError);
  TempDir dir;
  const std::string path = dir.file("fin.off");
  write_text(path, "OFF\n5 3 0\n0 0 0\n1 0 0\n0.5 1 0\n0.5 -1 0\n0.5 0 1\n3 0 1 2\n3 1 0 3\n3 0 1 4\n");
  try {
    gshell::load_mesh(path);
    FAIL() << "non-manifold mesh accepted";
  } catch (const gshell::InputError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind(path + ": edge (0, 1) is non-manifold", 0), 0u) << msg;
  }
  EXPECT_THROW(gshell::load_mesh(dir.file("missing.obj")), gshell::InputError);
}
