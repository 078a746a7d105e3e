// `gshell generate` and `gshell metrics` end to end: outputs parse back, bad parameters exit 1
// and leave nothing behind.
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/io/read_mesh.h>
#include <gshell/io/tet_mesh_io.h>
#include <gshell/run/shell_folder.h>

#include "test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

using namespace gshell;
using namespace gshell::test;

namespace {

const Eigen::MatrixXd* find_array(const std::vector<std::pair<std::string, Eigen::MatrixXd>>& arrays,
                                  const std::string& name) {
  for (const auto& [n, a] : arrays)
    if (n == name) return &a;
  return nullptr;
}

} // namespace

TEST(GenerateCli, WritesAShellFolderThatParsesBack) {
  TempDir tmp;
  const std::string out = tmp.file("shell");
  const CliResult r = run_cli("generate builtin:torus:32 -o '" + out + "' --thickness-ratio 0.02 --iterations 10 --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err; // --quiet
  EXPECT_NE(r.out.find("inverted"), std::string::npos) << r.out;

  const TriMesh input = make_builtin("builtin:torus:32");
  const int n = input.num_vertices(), m = input.num_faces();
  const TriMesh top = read_mesh(out + "/top.obj"), base = read_mesh(out + "/base.obj");
  ASSERT_EQ(top.num_vertices(), n);
  EXPECT_TRUE(top.F == input.F);
  EXPECT_TRUE(base.F == input.F);
  EXPECT_LT((base.V - input.V).cwiseAbs().maxCoeff(), 1e-9);
  // Vertex order kept: top vertex i sits about eta above base vertex i.
  const nlohmann::json report = nlohmann::json::parse(read_text(out + "/report.json"));
  const double eta = report["thickness"]["eta"].get<double>();
  for (int i = 0; i < n; ++i) {
    const double d = (top.V.row(i) - input.V.row(i)).norm();
    EXPECT_GT(d, 0.8 * eta) << i;
    EXPECT_LT(d, 1.2 * eta) << i;
  }
  EXPECT_EQ(report["method"], "rigid");
  EXPECT_EQ(report["vertices"], n);
  EXPECT_EQ(report["tets"], 3 * m);
  EXPECT_LE(report["iterations"].get<int>(), 10);
  EXPECT_EQ(report["certificate"]["top_self_intersections"], 0);

  const TetMesh shell = read_tet_mesh(out + "/shell.vtu");
  EXPECT_EQ(shell.X.rows(), 2 * n);
  EXPECT_EQ(shell.T.rows(), 3 * m);
  for (const char* name : {"stretch", "inverted", "prism"}) {
    const Eigen::MatrixXd* a = find_array(shell.cell_data, name);
    ASSERT_NE(a, nullptr) << name;
    EXPECT_EQ(a->rows(), 3 * m) << name;
  }
  EXPECT_EQ((*find_array(shell.cell_data, "prism"))(3 * 7 + 2, 0), 7.0);
  EXPECT_LT((shell.X.bottomRows(n) - top.V).cwiseAbs().maxCoeff(), 1e-9);

  const Shell loaded = read_shell_folder(out).shell;
  EXPECT_EQ(loaded.num_base_vertices(), n);
  EXPECT_DOUBLE_EQ(loaded.thickness, eta);
  EXPECT_TRUE(loaded.F == input.F);

  // metrics on the written pair agrees with the report.
  const std::string json = tmp.file("metrics.json");
  const CliResult mr = run_cli("metrics '" + out + "/base.obj' '" + out + "/top.obj' --thickness " +
                               std::to_string(eta) + " -o '" + json + "'");
  ASSERT_EQ(mr.exit_code, 0) << mr.err;
  const nlohmann::json metrics = nlohmann::json::parse(read_text(json));
  for (const char* key : {"valid", "certificate", "base_self_intersections", "thinned_vertices", "gshell_version"})
    EXPECT_EQ(metrics[key], report[key]) << key;
  EXPECT_EQ(metrics["warnings"], nlohmann::json::array()); // a clean base: none
  EXPECT_NEAR(metrics["stretch"]["volume_mean"].get<double>(), report["stretch"]["volume_mean"].get<double>(),
              1e-6 * report["stretch"]["volume_mean"].get<double>() + 1e-12);
  EXPECT_NE(mr.out.find("valid        "), std::string::npos) << mr.out;
}

TEST(GenerateCli, OffsetMethodAndExistingFolder) {
  // The shell folder rule of every command that writes one: an earlier output is replaced, a folder
  // of other files is refused and left as it was.
  TempDir tmp;
  const std::string out = tmp.file("shell");
  std::filesystem::create_directory(out);
  write_text(out + "/notes.txt", "keep me");
  const CliResult refused = run_cli("generate builtin:sphere -o '" + out + "' --thickness 0.05 --method offset");
  EXPECT_EQ(refused.exit_code, 1) << refused.err;
  // The file in the way is named: a folder of gshell's files otherwise may well be an earlier output.
  EXPECT_NE(refused.err.find(out + ": exists and holds files gshell does not write there (notes.txt)"), std::string::npos)
      << refused.err;
  EXPECT_EQ(read_text(out + "/notes.txt"), "keep me");
  EXPECT_EQ(count_entries(out), 1);
  std::filesystem::remove(out + "/notes.txt");

  for (const char* method : {"rigid", "offset"}) {
    const CliResult r = run_cli("generate builtin:sphere -o '" + out + "' --thickness 0.05 --method " + method);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const nlohmann::json report = nlohmann::json::parse(read_text(out + "/report.json"));
    EXPECT_EQ(report["method"], method);
  }
  const nlohmann::json report = nlohmann::json::parse(read_text(out + "/report.json"));
  EXPECT_EQ(report["iterations"], 0);
  // The rigid method's iterations start from the offset method's surface with --start-smoothing 0,
  // and from another (along smoothed normals) by default.
  auto report_of = [&](const std::string& args) {
    const CliResult r = run_cli("generate builtin:torus:32 -o '" + out + "' --thickness 0.2 --quiet " + args);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return nlohmann::json::parse(read_text(out + "/report.json"));
  };
  const double offset_energy = report_of("--method offset")["energy"][0].get<double>();
  const nlohmann::json raw = report_of("--start-smoothing 0"), smoothed = report_of("");
  EXPECT_NEAR(raw["energy"][0].get<double>(), offset_energy, 1e-12 * offset_energy);
  EXPECT_EQ(raw["guard"]["start_smoothing_iterations"], 0);
  EXPECT_GT(smoothed["guard"]["start_smoothing_iterations"].get<int>(), 0);
  EXPECT_NE(smoothed["energy"][0].get<double>(), offset_energy);
  EXPECT_EQ(count_entries(out), 4);          // base.obj, top.obj, shell.vtu, report.json
  EXPECT_EQ(count_entries(tmp.path()), 1);   // no staging folder left beside it
}

TEST(GenerateCli, BadParametersExitOneWithoutOutput) {
  TempDir tmp;
  const std::string out = tmp.file("shell");
  for (const std::string args : {"--thickness 0", "--thickness -1", "--thickness nan", "--thickness-ratio 0",
                                 "--thickness 0.1 --thickness-ratio 0.1", "", "--thickness 0.1 --iterations -1",
                                 "--thickness 0.1 --tolerance -1", "--thickness 0.1 --method fancy",
                                 "--thickness 0.1 --method curvature --s-min 0",
                                 "--thickness 0.1 --method curvature --s-max 0.9", "--thickness 0.1 --start-smoothing -1",
                                 "--thickness 0.1 --start-smoothing inf"}) {
    const CliResult r = run_cli("generate builtin:sphere:1 -o '" + out + "' " + args);
    EXPECT_EQ(r.exit_code, 1) << args << "\n" << r.err;
    EXPECT_FALSE(r.err.empty()) << args;
    EXPECT_EQ(count_entries(tmp.path()), 0) << args;
  }
  const CliResult missing = run_cli("generate '" + tmp.file("nope.obj") + "' -o '" + out + "' --thickness 0.1");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_EQ(count_entries(tmp.path()), 0);
  const CliResult metrics = run_cli("metrics builtin:sphere builtin:torus --thickness 0.1");
  EXPECT_EQ(metrics.exit_code, 1) << metrics.err;
  const CliResult metrics_none = run_cli("metrics builtin:sphere builtin:sphere");
  EXPECT_EQ(metrics_none.exit_code, 1);
}

TEST(GenerateCli, ProgressNamesTheStageOfEveryIteration) {
  // Guarded generation solves in stages whose iteration counts each start at 1; a log must say
  // which stage a line belongs to (stderr is a file here: one line per update).
  TempDir tmp;
  const CliResult r = run_cli("generate builtin:torus:32 -o '" + tmp.file("shell") + "' --thickness-ratio 0.02");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = nlohmann::json::parse(read_text(tmp.file("shell") + "/report.json"));
  ASSERT_TRUE(report["guarded"].get<bool>());
  ASSERT_EQ(report["guard"]["repaired_vertices"], 0); // the paper's stage alone (the library test has all three)
  std::istringstream lines(r.err);
  std::string line;
  std::getline(lines, line); // the input line
  // Each phase is named when it begins, the ones without iterations too (at millions of faces
  // they take tens of seconds), in the order they run.
  int paper_lines = 0;
  std::vector<std::string> phases;
  while (std::getline(lines, line)) {
    if (line.size() > 3 && line.compare(line.size() - 3, 3, "...") == 0) {
      phases.push_back(line);
      continue;
    }
    const std::string paper = "gshell generate: paper: iteration " + std::to_string(paper_lines + 1) + "  energy ";
    EXPECT_EQ(line.rfind(paper, 0), 0u) << line;
    EXPECT_EQ(phases.back(), "gshell generate: paper...");
    ++paper_lines;
  }
  const std::vector<std::string> expected = {"gshell generate: setup...",       "gshell generate: factor...",
                                             "gshell generate: paper...",
                                             "gshell generate: start...",       "gshell generate: metrics...",
                                             "gshell generate: certificate...",
                                             "gshell generate: writing " + tmp.file("shell") + "..."};
  EXPECT_EQ(phases, expected);
  const int iterations = report["guard"]["paper_iterations"].get<int>();
  EXPECT_GT(iterations, 0);
  EXPECT_EQ(paper_lines, iterations);
  EXPECT_NE(r.out.find("after " + std::to_string(iterations) + " paper iterations"), std::string::npos) << r.out;
}
