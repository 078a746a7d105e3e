// Handle files and `gshell pose`.
#include <gshell/deform/handles.h>
#include <gshell/deform/pose.h>
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/io/read_mesh.h>
#include <gshell/io/tet_mesh_io.h>
#include <gshell/io/write_mesh.h>
#include <gshell/render/image.h>
#include <gshell/render/scene.h>

#include "shell_fixtures.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <filesystem>

using namespace gshell;
using gshell::test::run_cli;
using gshell::test::TempDir;
namespace fs = std::filesystem;

namespace {

Shell small_bowl() { return gshell::test::offset_shell(make_bowl(8), 0.08); }

/// Expects parse_handles to throw an InputError whose one-line message names the file and
/// contains `fragment`.
void expect_error(const std::string& json, const std::string& fragment) {
  try {
    parse_handles(json, "H.json", small_bowl());
    ADD_FAILURE() << "no error for " << json;
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("H.json: ", 0), 0u) << what;
    EXPECT_NE(what.find(fragment), std::string::npos) << "'" << what << "' lacks '" << fragment << "'";
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

void write_shell_dir(const Shell& s, const fs::path& dir) {
  fs::create_directories(dir);
  TriMesh base, top;
  base.V = s.base;
  base.F = s.F;
  top.V = s.top;
  top.F = s.F;
  write_mesh((dir / "base.obj").string(), base);
  write_mesh((dir / "top.obj").string(), top);
  test::write_text((dir / "report.json").string(), nlohmann::json{{"thickness", s.thickness}}.dump());
}

const char* kPull = R"({"handles": [
  {"select": {"surface": "both", "box": [-2, -2, -0.2, -0.6, 2, 2]}},
  {"select": {"surface": "both", "box": [0.6, -2, -0.2, 2, 2, 2]}, "translate": [0.3, 0, 0.1]}]})";

} // namespace

// A handle set is checked against a shell, but targets() reads whatever matrix it is given: one
// without rows for the handle's top vertices (the base alone) must not be read past its end.
TEST(Handles, TargetsFromTooFewRestVerticesAreAnInputError) {
  const Shell s = small_bowl();
  const int n = s.num_base_vertices();
  const HandleSet h = parse_handles(R"({"handles": [{"vertices": [0, )" + std::to_string(n + 1) + "]}]}", "H.json", s);
  EXPECT_THROW(h.targets(s.base, 1.0), InputError);
  EXPECT_THROW(h.targets(s.vertices().leftCols(2), 1.0), InputError);
  EXPECT_EQ(h.targets(s.vertices(), 1.0).rows(), 2);
}

TEST(Handles, ExplicitVerticesAndTargets) {
  const Shell s = small_bowl();
  const int n = s.num_base_vertices();
  const std::string json = R"({"handles": [{"vertices": [0, 3, 3, )" + std::to_string(n + 1) +
                           R"(], "translate": [1, 2, 3], "rotate": {"axis": [0, 0, 2], "degrees": 90, "center": [0, 0, 0]}}]})";
  const HandleSet h = parse_handles(json, "H.json", s);
  EXPECT_EQ(h.mode, ConstraintMode::Hard);
  ASSERT_EQ(h.handles.size(), 1u);
  EXPECT_EQ(h.handles[0].vertices, (std::vector<int>{0, 3, n + 1})); // sorted, duplicates dropped
  const Eigen::MatrixXd X = s.vertices();
  const Eigen::MatrixXd full = h.targets(X, 1.0), half = h.targets(X, 0.5), none = h.targets(X, 0.0);
  for (int r = 0; r < 3; ++r) {
    const Eigen::Vector3d u = X.row(h.handles[0].vertices[r]).transpose();
    // 90 degrees about +z: (x, y, z) -> (-y, x, z); then the translation.
    EXPECT_NEAR((full.row(r).transpose() - (Eigen::Vector3d(-u.y(), u.x(), u.z()) + Eigen::Vector3d(1, 2, 3))).norm(), 0, 1e-12);
    const Eigen::Vector3d mid = Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitZ()) * u + Eigen::Vector3d(0.5, 1, 1.5);
    EXPECT_NEAR((half.row(r).transpose() - mid).norm(), 0, 1e-12);
    EXPECT_NEAR((none.row(r).transpose() - u).norm(), 0, 1e-15);
  }
}

TEST(Handles, BoxSelectionPicksTheRightSurface) {
  const Shell s = small_bowl();
  const int n = s.num_base_vertices();
  const std::string box = R"("box": [-5, -5, -0.3, 5, 5, 5])";
  const HandleSet base = parse_handles(R"({"handles": [{"select": {"surface": "base", )" + box + "}}]}", "H", s);
  const HandleSet top = parse_handles(R"({"handles": [{"select": {"surface": "top", )" + box + "}}]}", "H", s);
  const HandleSet both = parse_handles(R"({"handles": [{"select": {)" + box + "}}]}", "H", s);
  for (int v : base.handles[0].vertices) {
    EXPECT_LT(v, n);
    EXPECT_GE(s.base(v, 2), -0.3);
  }
  for (int v : top.handles[0].vertices) {
    EXPECT_GE(v, n);
    EXPECT_GE(s.top(v - n, 2), -0.3);
  }
  int expected = 0;
  for (int i = 0; i < n; ++i) expected += (s.base(i, 2) >= -0.3) + (s.top(i, 2) >= -0.3);
  EXPECT_EQ(static_cast<int>(both.handles[0].vertices.size()), expected);
  EXPECT_EQ(both.handles[0].vertices.size(), base.handles[0].vertices.size() + top.handles[0].vertices.size());
  // Rotation center defaults to the handle's rest centroid.
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  const Eigen::MatrixXd X = s.vertices();
  for (int v : both.handles[0].vertices) c += X.row(v).transpose();
  EXPECT_NEAR((both.handles[0].center - c / expected).norm(), 0, 1e-12);
}

TEST(Handles, ModeAndWeight) {
  const Shell s = small_bowl();
  const std::string h = R"("handles": [{"vertices": [0]}])";
  EXPECT_EQ(parse_handles("{" + h + "}", "H", s).mode, ConstraintMode::Hard);
  const HandleSet w = parse_handles(R"({"weight": 50, )" + h + "}", "H", s);
  EXPECT_EQ(w.mode, ConstraintMode::Soft); // a weight asks for springs
  EXPECT_EQ(w.weight, 50);
  EXPECT_EQ(parse_handles(R"({"mode": "soft", )" + h + "}", "H", s).mode, ConstraintMode::Soft);
}

TEST(Handles, BadFilesAreClearErrors) {
  expect_error(R"({"handles": [{"vertices": [0, 99999]}]})", "unknown vertex id 99999");
  expect_error(R"({"handles": [{"vertices": [-1]}]})", "unknown vertex id -1");
  expect_error(R"({"handles": [{"select": {"box": [5, 5, 5, 6, 6, 6]}}]})", "select matches no vertex");
  expect_error(R"({"handles": [{"vertices": [0], "translate": [NaN, 0, 0]}]})", "not valid JSON");
  expect_error(R"({"handles": [{"vertices": [0], "translate": [1e999, 0, 0]}]})", "number overflow");
  expect_error(R"({"handles": [{"vertices": [0], "translate": ["1", 0, 0]}]})", "expected a number");
  expect_error(R"({"handles": [{"vertices": [0.5]}]})", "is not an integer");
  expect_error(R"({"handles": [{"vertices": "all"}]})", "must be an array");
  expect_error(R"({"handles": [{"vertices": []}]})", "is empty");
  expect_error(R"({"handles": []})", "is empty");
  expect_error(R"({"handle": []})", "unknown key \"handle\"");
  expect_error(R"({"handles": [{"vertices": [0], "translation": [1, 0, 0]}]})", "unknown key \"translation\"");
  expect_error(R"({"handles": [{"vertices": [0], "select": {"box": [0, 0, 0, 1, 1, 1]}}]})", "exactly one of");
  expect_error(R"({"handles": [{"vertices": [0], "rotate": {"axis": [0, 0, 0], "degrees": 10}}]})", "axis is zero");
  expect_error(R"({"handles": [{"vertices": [0, 1]}, {"vertices": [1, 2]}]})", "vertex 1 is in handles 0 and 1");
  expect_error(R"({"weight": -1, "handles": [{"vertices": [0]}]})", "must be > 0");
  expect_error(R"({"weight": 1e17, "handles": [{"vertices": [0]}]})", "must be <= 1e12");
  expect_error(R"({"weight": 1e-300, "handles": [{"vertices": [0]}]})", "weight: must be >= 1e-12"); // was "singular"
  expect_error(R"({"mode": "rigid", "handles": [{"vertices": [0]}]})", "\"hard\" or \"soft\"");
  expect_error(R"({"handles": [{"select": {"surface": "middle", "box": [0, 0, 0, 1, 1, 1]}}]})", "\"base\", \"top\" or \"both\"");
  expect_error("[1, 2", "not valid JSON");
  // Ignored input is an error too: a weight that hard mode would not use, and a second key of
  // one name, of which JSON readers keep only one.
  expect_error(R"({"weight": 50, "mode": "hard", "handles": [{"vertices": [0]}]})", "weight: applies only to \"mode\": \"soft\"");
  expect_error(R"({"handles": [{"vertices": [0]}], "handles": [{"vertices": [1]}]})", "the key \"handles\" appears twice");
  expect_error(R"({"handles": [{"vertices": [0], "translate": [1, 0, 0], "translate": [0, 1, 0]}]})",
               "the key \"translate\" appears twice");
  // Deep nesting is refused before anything recursive walks it (an error message dumps the value).
  expect_error(R"({"handles": [{"vertices": [0], "translate": )" + std::string(100000, '[') + std::string(100000, ']') + "}]}",
               "nested deeper than 32 levels");
  // 2^63 and 2^64 - 1 are unsigned in JSON and named as written, not wrapped to negative ids.
  expect_error(R"({"handles": [{"vertices": [9223372036854775808]}]})", "unknown vertex id 9223372036854775808 ");
  expect_error(R"({"handles": [{"vertices": [18446744073709551615]}]})", "unknown vertex id 18446744073709551615 ");
  // Past 2^64 JSON readers hold it as a float: still an id out of range, not "not an integer".
  expect_error(R"({"handles": [{"vertices": [18446744073709551617]}]})", "unknown vertex id 1.8446744073709552e+19 ");
  expect_error(R"({"handles": [{"vertices": [-18446744073709551617]}]})", "unknown vertex id -1.8446744073709552e+19 ");
  expect_error(R"({"handles": [{"vertices": [1.0]}]})", "vertex id 1.0 is not an integer");
}

TEST(Handles, ExtremeButAcceptedNumbersGiveFiniteTargets) {
  // An axis whose squared length overflows ([1e200, 0, 0]) or underflows ([1e-200, 0, 0]) is
  // still an axis; a turn of 1e308 degrees still a rotation (degrees * pi overflowed to inf, so
  // targets were NaN); found by scripts/fuzz (handles).
  const Shell s = small_bowl();
  const Eigen::MatrixXd X = s.vertices();
  for (const std::string axis : {"[1e200, 0, 0]", "[0, 1e-200, 0]", "[1e308, 1e308, 1e308]"}) {
    const HandleSet h = parse_handles(R"({"handles": [{"vertices": [0, 1], "rotate": {"axis": )" + axis +
                                          R"(, "degrees": 90}}]})", "H", s);
    EXPECT_NEAR(h.handles[0].axis.norm(), 1, 1e-15) << axis;
    EXPECT_TRUE(h.targets(X, 1).allFinite()) << axis;
  }
  const HandleSet turn = parse_handles(R"({"handles": [{"vertices": [0, 1], "rotate": {"axis": [0, 0, 1], "degrees": 1e308}}]})", "H", s);
  for (const double t : {0.25, 1.0}) {
    const Eigen::MatrixXd P = turn.targets(X, t);
    ASSERT_TRUE(P.allFinite()) << t;
    // A rotation about z through the handle's centroid keeps z and the distance to the centroid.
    for (int r = 0; r < 2; ++r) {
      const Eigen::Vector3d u = X.row(r).transpose(), c = turn.handles[0].center;
      EXPECT_NEAR(P(r, 2), u.z(), 1e-12);
      EXPECT_NEAR((P.row(r).transpose() - c).head<2>().norm(), (u - c).head<2>().norm(), 1e-12);
    }
  }
  // 720 + 90 degrees is 90 degrees: whole turns are taken out exactly.
  const HandleSet a = parse_handles(R"({"handles": [{"vertices": [0], "rotate": {"axis": [0, 0, 1], "degrees": 810}}]})", "H", s);
  const HandleSet b = parse_handles(R"({"handles": [{"vertices": [0], "rotate": {"axis": [0, 0, 1], "degrees": 90}}]})", "H", s);
  EXPECT_NEAR((a.targets(X, 1) - b.targets(X, 1)).norm(), 0, 1e-12);
}

TEST(Handles, TranslationsAndCentersBeyondTheCoordinateLimitAreErrors) {
  expect_error(R"({"handles": [{"vertices": [0], "translate": [0, 1e60, 0]}]})",
               "handle 0: translate: a coordinate of magnitude 1e+60; gshell needs |x| < 1e+50");
  expect_error(R"({"handles": [{"vertices": [0], "rotate": {"axis": [0, 0, 1], "degrees": 5, "center": [-1e300, 0, 0]}}]})",
               "rotate.center: a coordinate of magnitude 1e+300;");
}

// A handle set built in code is checked and turned as a file's: an axis of any length but zero
// gives a rotation (it scaled the handle by its length), and coordinates past the limit are
// refused (check_handles let 1e300 through).
TEST(Handles, HandlesBuiltInCodeAreCheckedAndTurnedAsAFilesAre) {
  const Shell s = small_bowl();
  const Eigen::MatrixXd X = s.vertices();
  Handle turn;
  turn.vertices = {0, 1, 2};
  turn.axis = Eigen::Vector3d(0, 0, 2);
  turn.degrees = 90;
  turn.center = Eigen::Vector3d::Zero();
  HandleSet code;
  code.handles = {turn};
  EXPECT_NO_THROW(check_handles(code, static_cast<int>(X.rows())));
  const HandleSet file = parse_handles(
      R"({"handles": [{"vertices": [0, 1, 2], "rotate": {"axis": [0, 0, 2], "degrees": 90, "center": [0, 0, 0]}}]})", "H", s);
  const Eigen::MatrixXd P = code.targets(X, 1);
  EXPECT_NEAR((P - file.targets(X, 1)).norm(), 0, 1e-15);
  for (int r = 0; r < 3; ++r) { // a quarter turn about z: (x, y, z) -> (-y, x, z)
    const Eigen::RowVector3d u = X.row(turn.vertices[r]);
    EXPECT_NEAR((P.row(r) - Eigen::RowVector3d(-u.y(), u.x(), u.z())).norm(), 0, 1e-14) << r;
  }
  for (const auto& [key, value] : {std::pair{"translate", Eigen::Vector3d(1e300, 0, 0)},
                                   std::pair{"center", Eigen::Vector3d(0, -1e60, 0)}}) {
    HandleSet far = code;
    (std::string(key) == "translate" ? far.handles[0].translate : far.handles[0].center) = value;
    try {
      check_handles(far, static_cast<int>(X.rows()));
      ADD_FAILURE() << key << ": no error";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("handle 0: ") + key + ": a coordinate of magnitude"),
                std::string::npos) << e.what();
    }
  }
}

// Targets where the layer (0.08 here) is below the spacing of doubles (1e-9 of the coordinates,
// generation's limit) are refused with the file: a guarded pose spent about 100 s on a bowl
// moved by 1e20 and ended "blocked by contact". Translated or turned about a far centre alike.
TEST(Handles, TargetsTooFarOutForTheLayerAreErrors) {
  expect_error(R"({"handles": [{"vertices": [0, 1], "translate": [1e15, 0, 0]}]})",
               "handle 0: moves its vertices to coordinates of 1e+15, where the shell's thickness 0.08 is below 1e-09");
  expect_error(R"({"handles": [{"vertices": [0], "rotate": {"axis": [0, 0, 1], "degrees": 90, "center": [1e12, 0, 0]}}]})",
               "double precision cannot tell a top that close from the base");
  // Within the limit (0.08 / 1e-9 = 8e7): accepted.
  EXPECT_NO_THROW(parse_handles(R"({"handles": [{"vertices": [0], "translate": [5e7, 0, 0]}]})", "H.json", small_bowl()));
}

TEST(Handles, MissingFileNamesIt) {
  try {
    read_handles("/nonexistent/h.json", small_bowl());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/h.json"), std::string::npos);
  }
  // A folder is named as one (it read as empty text: "not valid JSON ... unexpected end of input").
  gshell::test::TempDir tmp;
  try {
    read_handles(tmp.path().string(), small_bowl());
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), tmp.path().string() + ": is a directory, expected a handle file (JSON)");
  }
}

TEST(PoseCli, WritesTheDeformedShellAndAReport) {
  TempDir tmp;
  const Shell s = small_bowl();
  write_shell_dir(s, tmp.path() / "shell");
  test::write_text(tmp.file("pull.json"), kPull);
  const std::string out = tmp.file("out");
  const auto r = run_cli("pose --shell '" + tmp.file("shell") + "' --handles '" + tmp.file("pull.json") +
                         "' --steps 3 --levels 3 -o '" + out + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* f : {"top.obj", "base.obj", "shell.vtu", "report.json"}) EXPECT_TRUE(fs::exists(fs::path(out) / f)) << f;
  EXPECT_EQ(test::count_entries(tmp.path()), 3); // shell, pull.json, out: no temporaries left
  const TriMesh top = read_mesh(out + "/top.obj"), base = read_mesh(out + "/base.obj");
  EXPECT_EQ(top.num_vertices(), s.num_base_vertices());
  EXPECT_EQ(base.F, s.F);
  const auto report = nlohmann::json::parse(test::read_text(out + "/report.json"));
  ASSERT_EQ(report["steps"].size(), 3u);
  double last = 0;
  for (const auto& step : report["steps"]) {
    EXPECT_GT(step["iterations"].get<int>(), 0);
    EXPECT_GT(step["energy"].get<double>(), last); // the handles move further every step
    last = step["energy"].get<double>();
    EXPECT_GE(step["seconds"].get<double>(), 0);
  }
  // The shell written is the last step's, and so is the validity at the top of the report.
  EXPECT_EQ(report["valid"], report["steps"][2]["valid"]);
  EXPECT_EQ(report["certificate"], report["steps"][2]["certificate"]);
  EXPECT_TRUE(report["valid"].get<bool>());
  EXPECT_EQ(report["certificate"]["inverted_tets"].get<int>(), 0);
  EXPECT_EQ(report["solver"], "hierarchical");
  EXPECT_EQ(report["mode"], "hard");
  EXPECT_EQ(report["thickness"].get<double>(), s.thickness);
  const TetMesh vtu = read_tet_mesh(out + "/shell.vtu");
  EXPECT_EQ(vtu.X.rows(), 2 * s.num_base_vertices());
  ASSERT_FALSE(vtu.cell_data.empty());
  EXPECT_EQ(vtu.cell_data[0].first, "stretch");
  EXPECT_GT(vtu.cell_data[0].second.maxCoeff(), 1e-6);

  // The pulled rim moved by the handle's translation; the held rim stayed.
  const HandleSet h = parse_handles(kPull, "pull", s);
  const Eigen::MatrixXd targets = h.targets(s.vertices(), 1.0);
  const auto verts = h.constrained_vertices();
  const int n = s.num_base_vertices();
  for (size_t k = 0; k < verts.size(); ++k) {
    const int v = verts[k];
    const Eigen::RowVector3d p = v < n ? base.V.row(v) : top.V.row(v - n);
    EXPECT_LT((p - targets.row(k)).norm(), 1e-5);
  }

  // Same output folder again with the single-level solver: replaced, not merged.
  const auto again = run_cli("pose --shell '" + tmp.file("shell") + "' --handles '" + tmp.file("pull.json") +
                             "' --solver single -q -o '" + out + "'");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_TRUE(again.err.empty()) << again.err;
  EXPECT_EQ(nlohmann::json::parse(test::read_text(out + "/report.json"))["solver"], "single");
  EXPECT_EQ(test::count_entries(tmp.path()), 3);
}

// The README's flow: `gshell generate builtin:bowl --thickness-ratio 0.02`, then `gshell pose` with
// the example handle files (the half pull, a guarded drag of about 20 s, left out). The soft
// squeeze failed with "the shell system is singular": the guard built its drag solver, which
// holds the hard handles' vertices fixed, with no fixed vertex at all for springs.
TEST(PoseCli, TheExampleHandleFilesPoseTheGeneratedBowl) {
  TempDir tmp;
  const std::string shell = tmp.file("bowl");
  ASSERT_EQ(run_cli("generate builtin:bowl --thickness-ratio 0.02 -q -o '" + shell + "'").exit_code, 0);
  for (const char* example : {"bowl_pull", "bowl_twist", "bowl_squeeze_soft"}) {
    SCOPED_TRACE(example);
    const std::string out = tmp.file(example);
    const auto r = run_cli("pose --shell '" + shell + "' --handles '" + GSHELL_SOURCE_DIR + "/examples/" + example +
                           ".json' -q -o '" + out + "'");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto report = nlohmann::json::parse(test::read_text(out + "/report.json"));
    for (const auto& step : report["steps"]) EXPECT_TRUE(step["valid"].get<bool>());
  }
}

TEST(PoseCli, RenderWritesAPreviewOfRestAndPose) {
  if (!offscreen_rendering_available()) GTEST_SKIP() << "built without OSMesa";
  TempDir tmp;
  write_shell_dir(small_bowl(), tmp.path() / "shell");
  test::write_text(tmp.file("pull.json"), kPull);
  const std::string out = tmp.file("out");
  const auto r = run_cli("pose --shell '" + tmp.file("shell") + "' --handles '" + tmp.file("pull.json") +
                         "' --levels 3 --render -q -o '" + out + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(test::read_text(out + "/preview.png").substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  const Image preview = read_png(out + "/preview.png");
  EXPECT_EQ(preview.width, 1280);
  EXPECT_EQ(preview.height, 720);
  // Two panels (rest | posed) split at the middle: each holds a good part of the shell, the rest
  // one green (stretch 0 against itself), the posed one also shows stretch (non-green) colors.
  long covered[2] = {0, 0}, green[2] = {0, 0}, warm[2] = {0, 0};
  for (int y = 0; y < preview.height; ++y)
    for (int x = 0; x < preview.width; ++x) {
      const std::uint8_t* p = preview.at(x, y);
      const int half = x < preview.width / 2 ? 0 : 1;
      if (p[0] < 235 || p[1] < 235 || p[2] < 235) ++covered[half];
      if (p[1] > p[0] + 40 && p[1] > p[2] + 40) ++green[half];
      if (p[0] > p[1] + 20 && p[0] > p[2] + 40) ++warm[half];
    }
  const double half_pixels = double(preview.width / 2) * preview.height;
  for (int half : {0, 1}) EXPECT_GT(covered[half] / half_pixels, 0.05) << half;
  EXPECT_GT(green[0] / half_pixels, 0.03);
  EXPECT_LT(warm[0], green[0] / 50);
  EXPECT_GT(warm[1], warm[0]);
  EXPECT_EQ(test::count_entries(tmp.path()), 3); // shell, pull.json, out
}

TEST(PoseCli, ViewTurnsThePreview) {
  if (!offscreen_rendering_available()) GTEST_SKIP() << "built without OSMesa";
  TempDir tmp;
  write_shell_dir(small_bowl(), tmp.path() / "shell");
  test::write_text(tmp.file("pull.json"), kPull);
  const std::string base_args = "pose --shell '" + tmp.file("shell") + "' --handles '" + tmp.file("pull.json") +
                                "' --levels 3 --render -q";
  // Width / height of the rest bowl (left panel): seen from below its rim (the bowl axis is z,
  // views are y-up) it is a half-ellipse, much wider than tall; the iso view looks into it.
  auto rest_aspect = [&](const std::string& view, const std::string& out) {
    const auto r = run_cli(base_args + (view.empty() ? "" : " --view " + view) + " -o '" + out + "'");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const Image image = read_png(out + "/preview.png");
    int x0 = image.width, x1 = -1, y0 = image.height, y1 = -1;
    for (int y = 40; y < image.height * 9 / 10; ++y) // below the caption, above the color bar
      for (int x = 0; x < image.width / 2 - 4; ++x) {
        const std::uint8_t* p = image.at(x, y);
        if (p[0] < 200 || p[1] < 200 || p[2] < 200) {
          x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
        }
      }
    return x1 > x0 && y1 > y0 ? double(x1 - x0) / (y1 - y0) : 0.0;
  };
  const double iso = rest_aspect("", tmp.file("iso")), below = rest_aspect("0,-70", tmp.file("below"));
  EXPECT_GT(below, 1.3 * iso) << "iso " << iso << ", from below " << below;

  const auto bad = run_cli(base_args + " --view sideways -o '" + tmp.file("bad") + "'");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("--view sideways"), std::string::npos) << bad.err;
  const auto no_render = run_cli("pose --shell '" + tmp.file("shell") + "' --handles '" + tmp.file("pull.json") +
                                 "' --view top -o '" + tmp.file("bad") + "'");
  EXPECT_NE(no_render.exit_code, 0);
  EXPECT_NE(no_render.err.find("--render"), std::string::npos) << no_render.err;
  EXPECT_FALSE(fs::exists(tmp.file("bad")));
}

TEST(PoseCli, AFolderOfOtherFilesIsNotReplaced) {
  TempDir tmp;
  write_shell_dir(small_bowl(), tmp.path() / "shell");
  test::write_text(tmp.file("pull.json"), kPull);
  fs::create_directory(tmp.path() / "mine");
  test::write_text(tmp.file("mine/notes.txt"), "keep me");
  const auto r = run_cli("pose --shell '" + tmp.file("shell") + "' --handles '" + tmp.file("pull.json") +
                         "' --levels 3 -q -o '" + tmp.file("mine") + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("holds files gshell does not write there (notes.txt)"), std::string::npos) << r.err;
  EXPECT_EQ(test::read_text(tmp.file("mine/notes.txt")), "keep me");
  EXPECT_EQ(test::count_entries(tmp.path() / "mine"), 1);
  EXPECT_EQ(test::count_entries(tmp.path()), 3); // shell, pull.json, mine: no temporaries left
}

TEST(PoseCli, NeitherTheRestShellNorAnotherCommandsShellFolderIsReplaced) {
  TempDir tmp;
  write_shell_dir(small_bowl(), tmp.path() / "shell");
  test::write_text(tmp.file("pull.json"), kPull);
  const std::string before = test::read_text(tmp.file("shell/top.obj"));
  const auto pose_into = [&](const std::string& shell, const std::string& out) {
    return run_cli("pose --shell '" + tmp.file(shell) + "' --handles '" + tmp.file("pull.json") + "' --levels 3 -q -o '" +
                   tmp.file(out) + "'");
  };
  // A shell folder made by generate is not a pose's to replace, least of all the one it poses.
  const auto own = pose_into("shell", "shell");
  EXPECT_EQ(own.exit_code, 1);
  EXPECT_NE(own.err.find("rest shell"), std::string::npos) << own.err;
  EXPECT_EQ(test::read_text(tmp.file("shell/top.obj")), before);
  // A posed shell is a shell too, and posed again it may not replace itself either...
  ASSERT_EQ(pose_into("shell", "posed").exit_code, 0);
  const std::string posed = test::read_text(tmp.file("posed/top.obj"));
  const auto again = pose_into("posed", "posed");
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_EQ(test::read_text(tmp.file("posed/top.obj")), posed);
  // ... while an earlier pose output elsewhere is replaced, and generate does not take it over.
  EXPECT_EQ(pose_into("posed", "posed2").exit_code, 0);
  EXPECT_EQ(pose_into("shell", "posed2").exit_code, 0);
  const auto generate = run_cli("generate builtin:sphere:1 --thickness-ratio 0.05 -q -o '" + tmp.file("posed") + "'");
  EXPECT_EQ(generate.exit_code, 1);
  EXPECT_NE(generate.err.find("not an earlier output"), std::string::npos) << generate.err;
  EXPECT_EQ(test::read_text(tmp.file("posed/top.obj")), posed);
  EXPECT_EQ(test::count_entries(tmp.path()), 4); // shell, pull.json, posed, posed2: no temporaries left
}

TEST(PoseCli, BadHandleFilesExitOneAndWriteNothing) {
  TempDir tmp;
  write_shell_dir(small_bowl(), tmp.path() / "shell");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"({"handles": [{"vertices": [123456]}]})", "unknown vertex id"},
      {R"({"handles": [{"select": {"box": [9, 9, 9, 10, 10, 10]}}]})", "select matches no vertex"},
      {R"({"handles": [{"vertices": [0], "translate": [NaN, 0, 0]}]})", "not valid JSON"},
  };
  for (const auto& [json, message] : cases) {
    test::write_text(tmp.file("bad.json"), json);
    const auto r = run_cli("pose --shell '" + tmp.file("shell") + "' --handles '" + tmp.file("bad.json") + "' -o '" +
                           tmp.file("out") + "'");
    EXPECT_EQ(r.exit_code, 1) << json;
    EXPECT_NE(r.err.find(message), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("bad.json"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(tmp.file("out")));
    EXPECT_EQ(test::count_entries(tmp.path()), 2); // shell, bad.json
  }
  const auto missing = run_cli("pose --shell '" + tmp.file("nope") + "' --handles '" + tmp.file("bad.json") + "' -o '" +
                               tmp.file("out") + "'");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_FALSE(fs::exists(tmp.file("out")));
}

TEST(PoseCli, AShellPartWithoutHandlesIsAnInputError) {
  // Two separate bowls, a handle on one only: the other could drift anywhere.
  TempDir tmp;
  Shell a = small_bowl(), two;
  const int n = a.num_base_vertices();
  two.base.resize(2 * n, 3);
  two.top.resize(2 * n, 3);
  two.base << a.base, a.base.rowwise() + Eigen::RowVector3d(5, 0, 0);
  two.top << a.top, a.top.rowwise() + Eigen::RowVector3d(5, 0, 0);
  two.F.resize(2 * a.F.rows(), 3);
  two.F << a.F, a.F.array() + n;
  two.thickness = a.thickness;
  write_shell_dir(two, tmp.path() / "shell");
  test::write_text(tmp.file("h.json"), R"({"handles": [{"vertices": [0, 1, 2]}]})");
  const auto r = run_cli("pose --shell '" + tmp.file("shell") + "' --handles '" + tmp.file("h.json") + "' -o '" +
                         tmp.file("out") + "'");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("free"), std::string::npos) << r.err;
  // Named as the file's problem, before the solver's setup says a word.
  EXPECT_EQ(r.err.rfind("gshell: error: " + tmp.file("h.json") + ": ", 0), 0u) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(tmp.file("out")));
  // A set built in code meets the same check in the solver.
  HandleSet one;
  one.handles.push_back(Handle{});
  one.handles[0].vertices = {0, 1, 2};
  EXPECT_THROW(PoseSolver(two, one, PoseSolverKind::Single), InputError);
}
