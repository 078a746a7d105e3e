// gshell animate / deform / texture end to end: outputs, report fields, and bad input caught
// before anything is written.
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/io/read_mesh.h>
#include <gshell/io/write_mesh.h>
#include <gshell/render/image.h>
#include <gshell/render/scene.h>

#include "test_support.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>

namespace gshell {
namespace {

namespace fs = std::filesystem;
using test::run_cli;
using test::TempDir;

/// A shell folder as `gshell generate` writes it: flat plane base (with UVs), top eta above.
std::string write_plane_shell(const TempDir& tmp, int res, double eta) {
  const std::string dir = tmp.file("shell");
  fs::create_directory(dir);
  TriMesh plane = make_plane(res);
  write_mesh(dir + "/base.obj", plane);
  plane.V.col(2).array() += eta;
  write_mesh(dir + "/top.obj", plane);
  test::write_text(dir + "/report.json", "{\"thickness\": " + std::to_string(eta) + "}\n");
  return dir;
}

nlohmann::json read_json(const std::string& path) { return nlohmann::json::parse(test::read_text(path)); }

TEST(AnimateCli, WritesKFramesOfABendOrTwist) {
  TempDir tmp;
  const auto r = run_cli("animate builtin:plane:6 --bend 90 --frames 4 -o '" + tmp.file("bend") + "' --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(test::count_entries(tmp.file("bend")), 4);
  const TriMesh rest = make_plane(6), last = read_mesh(tmp.file("bend") + "/frame_0004.obj");
  ASSERT_EQ(last.num_vertices(), rest.num_vertices());
  EXPECT_TRUE((last.F.array() == rest.F.array()).all());
  EXPECT_TRUE(last.has_uv()); // UVs are kept for `gshell texture` on the frames
  // Full bend: the x = +-1 edges have turned by +-45 degrees.
  EXPECT_GT(last.V.col(2).maxCoeff(), 0.1);

  const auto t = run_cli("animate builtin:cylinder:12 --twist 60 --frames 2 -o '" + tmp.file("twist") + "' -q");
  ASSERT_EQ(t.exit_code, 0) << t.err;
  EXPECT_TRUE(fs::exists(tmp.file("twist") + "/frame_0002.obj"));

  // The built-in cylinder's box is a cube: the longest side ties, x is taken, and the tube is
  // wrung across. --axis z twists it about its own axis: every vertex keeps its height and its
  // distance from the axis.
  const auto z = run_cli("animate builtin:cylinder:12 --twist 60 --frames 1 --axis z -o '" + tmp.file("z") + "' -q");
  ASSERT_EQ(z.exit_code, 0) << z.err;
  const TriMesh tube = make_builtin("builtin:cylinder:12"), twisted = read_mesh(tmp.file("z") + "/frame_0001.obj");
  ASSERT_EQ(twisted.num_vertices(), tube.num_vertices());
  EXPECT_LT((twisted.V.col(2) - tube.V.col(2)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((twisted.V.leftCols(2).rowwise().norm() - tube.V.leftCols(2).rowwise().norm()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_GT((twisted.V - tube.V).cwiseAbs().maxCoeff(), 0.1);
  EXPECT_NE(run_cli("animate builtin:cylinder:12 --twist 60 --axis w -o '" + tmp.file("w") + "'").exit_code, 0);
}

TEST(AnimateCli, ProgressInALogIsOneLinePerUpdateAndThrottled) {
  // stderr is a file here, not a terminal: no carriage returns, one line per update, and updates
  // at most five a second (100,000 quick frames wrote 24,000 lines).
  TempDir tmp;
  const auto r = run_cli("animate builtin:plane:4 --twist 30 --frames 3 -o '" + tmp.file("twist") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find('\r'), std::string::npos) << r.err;
  EXPECT_EQ(r.err.rfind("gshell animate: frame 1/3\n", 0), 0u) << r.err;
  const std::string done =
      "gshell animate: wrote 3 frames of a twist to 30 degrees about the x axis to " + tmp.file("twist") + "\n";
  ASSERT_GE(r.err.size(), done.size());
  EXPECT_EQ(r.err.substr(r.err.size() - done.size()), done) << r.err;
  const auto many = run_cli("animate builtin:plane:1 --twist 30 --frames 3000 -o '" + tmp.file("many") + "'");
  ASSERT_EQ(many.exit_code, 0) << many.err;
  EXPECT_LT(std::count(many.err.begin(), many.err.end(), '\n'), 300) << "not throttled";
}

// Ten thousand frames: every name has five digits, so the names sort as text (the order a
// shell's frame_*.obj hands them to `gshell deform`) in the frames' order.
TEST(AnimateCli, NamesOfALongSequenceSortInFrameOrder) {
  TempDir tmp;
  const auto r = run_cli("animate builtin:plane:1 --twist 30 --frames 10000 -o '" + tmp.file("long") + "' -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(tmp.file("long"))) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  ASSERT_EQ(names.size(), 10000u);
  EXPECT_EQ(names.front(), "frame_00001.obj");
  EXPECT_EQ(names[9998], "frame_09999.obj");
  EXPECT_EQ(names.back(), "frame_10000.obj");
}

// A strip bent isometrically past a full turn lies on itself: the frame that does so is written
// and named in a warning (even with --quiet); one short of a full turn is not.
TEST(AnimateCli, WarnsWhenAFrameMakesTheBaseCrossItself) {
  TempDir tmp;
  const auto past = run_cli("animate builtin:plane:6 --bend 450 --frames 2 -o '" + tmp.file("past") + "' -q");
  ASSERT_EQ(past.exit_code, 0) << past.err;
  EXPECT_EQ(test::count_entries(tmp.file("past")), 2);
  EXPECT_NE(past.err.find("gshell animate: warning: 1 of 2 frames (the first frame_0002.obj) make the base cross "
                          "itself"),
            std::string::npos)
      << past.err;
  const auto short_of = run_cli("animate builtin:plane:6 --bend 300 --frames 2 -o '" + tmp.file("short") + "' -q");
  ASSERT_EQ(short_of.exit_code, 0) << short_of.err;
  EXPECT_EQ(short_of.err, "");
}

TEST(AnimateCli, RejectsBadArguments) {
  TempDir tmp;
  const std::string out = tmp.file("out");
  EXPECT_EQ(run_cli("animate builtin:plane --frames 3 -o '" + out + "'").exit_code, 1);
  EXPECT_EQ(run_cli("animate builtin:plane --bend 10 --twist 10 -o '" + out + "'").exit_code, 1);
  EXPECT_EQ(run_cli("animate builtin:plane --bend 10 --frames 0 -o '" + out + "'").exit_code, 1);
  EXPECT_EQ(run_cli("animate builtin:plane --bend 10 --band 0 -o '" + out + "'").exit_code, 1);
  EXPECT_EQ(run_cli("animate missing.obj --bend 10 -o '" + out + "'").exit_code, 1);
  for (const char* angle : {"--bend 1e300", "--twist -36001"}) {
    const auto r = run_cli("animate builtin:plane " + std::string(angle) + " -o '" + out + "' -q");
    EXPECT_EQ(r.exit_code, 1) << angle;
    EXPECT_NE(r.err.find("the angle must be within +-36000 degrees (100 turns; got "), std::string::npos) << r.err;
  }
  TempDir turns;
  EXPECT_EQ(run_cli("animate builtin:plane:4 --twist 36000 --frames 1 -o '" + turns.file("out") + "' -q").exit_code, 0);
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(test::count_entries(tmp.path()), 0); // no temporary folder left behind
}

TEST(DeformCli, WritesFramesReportAndCarriedDetail) {
  TempDir tmp;
  const std::string shell = write_plane_shell(tmp, 10, 0.2);
  const std::string frames = tmp.file("frames");
  ASSERT_EQ(run_cli("animate '" + shell + "/base.obj' --bend 90 --band 0.2 --frames 3 -o '" + frames + "' -q").exit_code, 0);
  // The detail: the base surface itself, so each carried detail must be that frame's base.
  const std::string out = tmp.file("out");
  const auto r = run_cli("deform --shell '" + shell + "' --base '" + frames + "/frame_0001.obj' '" + frames +
                         "/frame_0002.obj' '" + frames + "/frame_0003.obj' -o '" + out + "' --compare-offset --embed '" +
                         shell + "/base.obj'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("frame 3/3"), std::string::npos) << r.err; // progress on stderr

  const nlohmann::json report = read_json(out + "/report.json");
  ASSERT_EQ(report["frames"].size(), 3u);
  EXPECT_EQ(report["warm_start"], "extrapolated");
  EXPECT_DOUBLE_EQ(report["tolerance"].get<double>(), 1e-4);
  EXPECT_EQ(report["tets"], 3 * 200);
  EXPECT_EQ(report["embed"]["points"], 121);
  EXPECT_EQ(report["embed"]["outside"], 0);
  for (int k = 0; k < 3; ++k) {
    const auto& f = report["frames"][k];
    EXPECT_EQ(f["frame"], k + 1);
    EXPECT_GE(f["iterations"].get<int>(), 1);
    EXPECT_EQ(f["energy"].size(), f["iterations"].get<std::size_t>() + 1);
    for (const char* key : {"mean", "volume_mean", "max", "p99"}) EXPECT_TRUE(f["stretch"].contains(key)) << key;
    EXPECT_EQ(f["inverted_tets"], 0);
    EXPECT_GT(f["seconds"].get<double>(), 0);
    EXPECT_LT(f["stretch"]["volume_mean"].get<double>(), f["offset"]["stretch"]["volume_mean"].get<double>());
    char name[32];
    std::snprintf(name, sizeof name, "/frame_%04d", k + 1);
    const std::string dir = out + name;
    const TriMesh top = read_mesh(dir + "/top.obj"), detail = read_mesh(dir + "/detail.obj");
    const TriMesh base = read_mesh(frames + name + ".obj");
    EXPECT_EQ(top.num_vertices(), 121);
    EXPECT_LT((detail.V - base.V).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_TRUE(fs::exists(dir + "/shell.vtu"));
  }
  EXPECT_EQ(report["summary"]["frames"], 3);
  EXPECT_TRUE(report["summary"].contains("median_seconds"));
  EXPECT_TRUE(report["summary"]["offset"].contains("inverted_tets"));

  // Running again into the same folder replaces the earlier output.
  const auto again = run_cli("deform --shell '" + shell + "' --base '" + frames + "/frame_0001.obj' -o '" + out + "' -q");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(read_json(out + "/report.json")["frames"].size(), 1u);
  EXPECT_FALSE(fs::exists(out + "/frame_0002"));
}

TEST(DeformCli, RigidFrameMovesTheTopRigidly) {
  TempDir tmp;
  const std::string shell = write_plane_shell(tmp, 6, 0.1);
  TriMesh base = read_mesh(shell + "/base.obj"), top = read_mesh(shell + "/top.obj");
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.9, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  const Eigen::RowVector3d t(1, 2, 3);
  base.V = (base.V * R.transpose()).rowwise() + t;
  write_mesh(tmp.file("moved.obj"), base);
  const auto r = run_cli("deform --shell '" + shell + "' --base '" + tmp.file("moved.obj") + "' -o '" + tmp.file("out") + "' -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const TriMesh moved_top = read_mesh(tmp.file("out") + "/frame_0001/top.obj");
  const Eigen::MatrixXd expected = (top.V * R.transpose()).rowwise() + t;
  EXPECT_LT((moved_top.V - expected).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT(read_json(tmp.file("out") + "/report.json")["frames"][0]["stretch"]["max"].get<double>(), 1e-12);
}

TEST(DeformCli, FramesAndDetailMayBeBuiltinSpecs) {
  // "Wherever a surface is read, a built-in mesh can be named": deform's frames and detail said
  // "unknown mesh format '(no extension)'".
  TempDir tmp;
  const std::string shell = write_plane_shell(tmp, 4, 0.1), out = tmp.file("out");
  const auto r = run_cli("deform --shell '" + shell + "' --base builtin:plane:4 --embed builtin:plane:2 -q -o '" + out + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // The rest base again: the frame is the rest shell, and the detail (the plane itself) stays put.
  const TriMesh top = read_mesh(out + "/frame_0001/top.obj"), detail = read_mesh(out + "/frame_0001/detail.obj");
  EXPECT_LT((top.V - read_mesh(shell + "/top.obj").V).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((detail.V - make_plane(2).V).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(DeformCli, BadFramesFailBeforeAnythingIsWritten) {
  TempDir tmp;
  const std::string shell = write_plane_shell(tmp, 4, 0.1);
  const std::string good = shell + "/base.obj";
  write_mesh(tmp.file("small.obj"), make_plane(3));
  TriMesh flipped = make_plane(4);
  flipped.F.row(0) = flipped.F.row(0).reverse().eval();
  write_mesh(tmp.file("faces.obj"), flipped);
  std::string with_nan = test::read_text(good);
  with_nan.replace(with_nan.find("v "), 2, "v nan ");
  test::write_text(tmp.file("nan.obj"), with_nan);
  TriMesh tiny = make_plane(4);
  tiny.V *= 1e-45;
  write_mesh(tmp.file("tiny.obj"), tiny);
  TriMesh shrunk = make_plane(4); // the shell's thickness 0.1 is 70 times its bounding radius
  shrunk.V *= 1e-3;
  write_mesh(tmp.file("shrunk.obj"), shrunk);

  const std::string out = tmp.file("out");
  for (const std::string bad : {"small.obj", "faces.obj", "nan.obj", "tiny.obj", "shrunk.obj", "missing.obj"}) {
    // The bad frame comes last: no frame may be solved or written before all are checked.
    const auto r = run_cli("deform --shell '" + shell + "' --base '" + good + "' '" + good + "' '" + tmp.file(bad) +
                           "' -o '" + out + "'");
    EXPECT_EQ(r.exit_code, 1) << bad << ": " << r.err;
    EXPECT_NE(r.err.find(bad), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << bad;
  }
  EXPECT_EQ(run_cli("deform --shell '" + tmp.file("nope") + "' --base '" + good + "' -o '" + out + "'").exit_code, 1);
  EXPECT_EQ(run_cli("deform --shell '" + shell + "' --base '" + good + "' --tolerance -1 -o '" + out + "'").exit_code, 1);
  EXPECT_FALSE(fs::exists(out));
  // Leftovers: only what the test itself wrote.
  for (const auto& entry : fs::directory_iterator(tmp.path()))
    EXPECT_NE(entry.path().filename().string().front(), '.') << entry.path();
}

TEST(DeformCli, RefusesToReplaceAnUnrelatedFolder) {
  TempDir tmp;
  const std::string shell = write_plane_shell(tmp, 4, 0.1);
  const std::string out = tmp.file("precious");
  fs::create_directory(out);
  test::write_text(out + "/notes.txt", "keep me");
  const auto r = run_cli("deform --shell '" + shell + "' --base '" + shell + "/base.obj' -o '" + out + "' -q");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(test::read_text(out + "/notes.txt"), "keep me");
  EXPECT_EQ(test::count_entries(out), 1);
}

TEST(DeformCli, EndToEndFromGenerate) {
  // generate -> animate -> deform, and texture on the generated shell (the cylinder has UVs).
  TempDir tmp;
  const std::string shell = tmp.file("shell"), frames = tmp.file("frames"), out = tmp.file("out");
  ASSERT_EQ(run_cli("generate builtin:cylinder:24 --thickness-ratio 0.05 -o '" + shell + "' -q").exit_code, 0);
  ASSERT_EQ(run_cli("animate '" + shell + "/base.obj' --twist 60 --frames 2 -o '" + frames + "' -q").exit_code, 0);
  // The folder animate wrote stands for its frames, in order.
  const auto r = run_cli("deform --shell '" + shell + "' --base '" + frames + "' --compare-offset -o '" + out + "' -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = read_json(out + "/report.json");
  ASSERT_EQ(report["frames"].size(), 2u);
  EXPECT_EQ(report["frames"][1]["base"], frames + "/frame_0002.obj");
  EXPECT_EQ(report["summary"]["inverted_tets"], 0);
  EXPECT_TRUE(read_mesh(out + "/frame_0002/top.obj").has_uv()); // textures still apply to the deformed top
  const auto t = run_cli("texture --shell '" + shell + "' --tile builtin:bumps:6 --repeat 8 2 -o '" + tmp.file("tex.ply") + "' -q");
  ASSERT_EQ(t.exit_code, 0) << t.err;
  // The 8 x 2 copies' 7 x 7 grids joined into one grid of 8 * 6 columns (around the cylinder, its
  // UV seam closed) and 2 * 6 + 1 rows.
  EXPECT_EQ(read_mesh(tmp.file("tex.ply")).num_vertices(), 48 * 13);
}


// A sphere squashed to less than its layer's thickness: the paper's solve presses the top
// through itself, so the guard mends the frame. Its line counts both solvers' iterations, as
// the status shown during a long frame does.
TEST(DeformCli, AGuardedFramesLineCountsThePapersAndTheGuardsIterations) {
  TempDir tmp;
  const std::string shell = tmp.file("shell"), out = tmp.file("out");
  ASSERT_EQ(run_cli("generate builtin:sphere:3 --thickness-ratio 0.1 -o '" + shell + "' -q").exit_code, 0);
  TriMesh squashed = read_mesh(shell + "/base.obj");
  squashed.V.col(1) *= 0.08;
  write_mesh(tmp.file("squashed.obj"), squashed);
  const auto r = run_cli("deform --shell '" + shell + "' --base '" + tmp.file("squashed.obj") + "' -o '" + out + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json frame = read_json(out + "/report.json")["frames"][0];
  ASSERT_EQ(frame["method"], "mended");
  const int guarded = frame["guarded_iterations"].get<int>();
  ASSERT_GT(guarded, 0);
  const std::string counts = "frame 1/1: " + std::to_string(frame["iterations"].get<int>()) + " + " +
                             std::to_string(guarded) + " guarded iterations, ";
  EXPECT_NE(r.err.find(counts), std::string::npos) << r.err;
}
TEST(DeformCli, DeformAndPoseWarnWhenTheRestShellsReportCallsItInvalid) {
  // The report as `gshell generate` writes it for a shell over a base that crosses itself: the
  // frames and steps that stay invalid there are explained before the first is reported so.
  TempDir tmp;
  const std::string shell = write_plane_shell(tmp, 6, 0.1), frames = tmp.file("frames");
  const std::string handles = tmp.file("handles.json");
  test::write_text(handles, R"({"handles": [{"select": {"box": [-2, -2, -1, -0.8, 2, 1]}},
                                             {"select": {"box": [0.8, -2, -1, 2, 2, 1]}, "translate": [0, 0, 0.3]}]})");
  ASSERT_EQ(run_cli("animate '" + shell + "/base.obj' --bend 30 --frames 1 -o '" + frames + "' -q").exit_code, 0);
  auto deform = [&] {
    return run_cli("deform --shell '" + shell + "' --base '" + frames + "/frame_0001.obj' -o '" + tmp.file("out") + "' -q");
  };
  auto pose = [&] {
    return run_cli("pose --shell '" + shell + "' --handles '" + handles + "' -o '" + tmp.file("posed") + "' -q");
  };
  const std::string faults = "warning: " + shell + ": the rest shell is not valid (2 inverted tets, 3 top/top, 4 "
                             "top/base and 0 wall intersecting pairs; its base crosses itself at 5 face pairs); the "
                             "guard leaves those places out, so a ";
  test::write_text(shell + "/report.json",
                   R"({"thickness": {"eta": 0.1}, "valid": false, "certificate": {"inverted_tets": 2,
                       "top_self_intersections": 3, "top_base_intersections": 4, "wall_intersections": 0,
                       "exact": true}, "base_self_intersections": 5})");
  const auto d = deform(), p = pose();
  ASSERT_EQ(d.exit_code, 0) << d.err;
  ASSERT_EQ(p.exit_code, 0) << p.err;
  EXPECT_NE(d.err.find(faults + "frame may stay invalid there\n"), std::string::npos) << d.err;
  EXPECT_NE(p.err.find(faults + "pose step may stay invalid there\n"), std::string::npos) << p.err;
  // A report that calls the shell valid, or says nothing of it, gives no such warning.
  for (const char* report : {R"({"thickness": {"eta": 0.1}, "valid": true})", R"({"thickness": 0.1})"}) {
    test::write_text(shell + "/report.json", report);
    const auto dv = deform(), pv = pose();
    ASSERT_EQ(dv.exit_code, 0) << dv.err;
    ASSERT_EQ(pv.exit_code, 0) << pv.err;
    EXPECT_EQ(dv.err.find("rest shell is not valid"), std::string::npos) << dv.err;
    EXPECT_EQ(pv.err.find("rest shell is not valid"), std::string::npos) << pv.err;
  }
}

// A frame whose base lies on itself (a strip bent past a full turn) cannot be valid: even with
// --quiet the run says which frame and why, as report.json does; a valid run says nothing.
TEST(DeformCli, InvalidFramesAreNamedInAWarningEvenWhenQuiet) {
  TempDir tmp;
  const std::string shell = write_plane_shell(tmp, 6, 0.1), frames = tmp.file("frames");
  ASSERT_EQ(run_cli("animate '" + shell + "/base.obj' --bend 450 --frames 2 -o '" + frames + "' -q").exit_code, 0);
  const auto r = run_cli("deform --shell '" + shell + "' --base '" + frames + "/frame_0001.obj' '" + frames +
                         "/frame_0002.obj' -o '" + tmp.file("out") + "' -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string warning = "1 of 2 frames is not valid: the base crosses itself in frame 2 (report.json has each "
                              "frame's certificate)";
  EXPECT_EQ(r.err, "gshell deform: warning: " + warning + "\n");
  const nlohmann::json report = read_json(tmp.file("out") + "/report.json");
  EXPECT_EQ(report["warnings"], nlohmann::json::array({warning}));
  const auto valid = run_cli("deform --shell '" + shell + "' --base '" + frames + "/frame_0001.obj' -o '" +
                             tmp.file("valid") + "' -q");
  ASSERT_EQ(valid.exit_code, 0) << valid.err;
  EXPECT_EQ(valid.err, "");
}

TEST(DeformCli, RenderWritesAPreviewOfTheFrames) {
  if (!offscreen_rendering_available()) GTEST_SKIP() << "built without OSMesa";
  TempDir tmp;
  const std::string shell = write_plane_shell(tmp, 6, 0.1);
  const std::string frames = tmp.file("frames"), out = tmp.file("out");
  ASSERT_EQ(run_cli("animate '" + shell + "/base.obj' --bend 90 --frames 3 -o '" + frames + "' -q").exit_code, 0);
  const std::string bases = "'" + frames + "/frame_0001.obj' '" + frames + "/frame_0002.obj' '" + frames + "/frame_0003.obj'";
  const auto r = run_cli("deform --shell '" + shell + "' --base " + bases + " -o '" + out + "' --render -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(test::read_text(out + "/preview.png").substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  const Image preview = read_png(out + "/preview.png");
  EXPECT_EQ(preview.width, 1280);
  EXPECT_EQ(preview.height, 720);
  // The shell covers a good part of the image (white background) and shows stretch colors: a
  // bend the top follows without stretch is mostly green (0 on the color bar).
  long covered = 0, green = 0;
  for (int y = 0; y < preview.height; ++y)
    for (int x = 0; x < preview.width; ++x) {
      const std::uint8_t* p = preview.at(x, y);
      if (p[0] < 235 || p[1] < 235 || p[2] < 235) ++covered;
      if (p[1] > p[0] + 40 && p[1] > p[2] + 40) ++green;
    }
  const double pixels = double(preview.width) * preview.height;
  EXPECT_GT(covered / pixels, 0.05);
  EXPECT_GT(green / pixels, 0.03);
  EXPECT_EQ(test::count_entries(tmp.path()), 3); // shell, frames, out: no temporaries left

  // A folder holding a preview is still recognised as an earlier deform output and replaced.
  const auto again = run_cli("deform --shell '" + shell + "' --base '" + frames + "/frame_0001.obj' -o '" + out + "' -q");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_FALSE(fs::exists(out + "/preview.png"));
}

TEST(TextureCli, TilesBumpsOverThePlaneShell) {
  TempDir tmp;
  const double eta = 0.2;
  const std::string shell = write_plane_shell(tmp, 8, eta);
  const auto r = run_cli("texture --shell '" + shell + "' --tile builtin:bumps:4 --repeat 3 2 -o '" + tmp.file("t.obj") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const TriMesh tex = read_mesh(tmp.file("t.obj"));
  EXPECT_EQ(tex.num_vertices(), 13 * 9); // the 3 x 2 copies' 5 x 5 grids joined into one grid
  EXPECT_EQ(tex.num_faces(), 6 * 32);
  // Flat shell, identity UVs: x, y span the plane and heights span [0.1, 0.9] * eta.
  EXPECT_NEAR(tex.V.col(0).minCoeff(), -1.0, 1e-9);
  EXPECT_NEAR(tex.V.col(1).maxCoeff(), 1.0, 1e-9);
  EXPECT_NEAR(tex.V.col(2).minCoeff(), 0.1 * eta, 1e-9);
  EXPECT_NEAR(tex.V.col(2).maxCoeff(), 0.9 * eta, 1e-9);

  // A tile from a file works the same way.
  TriMesh tile;
  tile.V.resize(3, 3);
  tile.V << 0.2, 0.2, 0.5, 0.8, 0.2, 0.5, 0.5, 0.8, 1.0;
  tile.F.resize(1, 3);
  tile.F << 0, 1, 2;
  write_mesh(tmp.file("tile.obj"), tile);
  EXPECT_EQ(run_cli("texture --shell '" + shell + "' --tile '" + tmp.file("tile.obj") + "' -o '" + tmp.file("u.obj") + "' -q").exit_code, 0);
  const TriMesh one = read_mesh(tmp.file("u.obj"));
  EXPECT_NEAR(one.V(2, 2), eta, 1e-12);
  EXPECT_NEAR(one.V(0, 0), -0.6, 1e-12);
}

TEST(TextureCli, RejectsBadInput) {
  TempDir tmp;
  const std::string shell = write_plane_shell(tmp, 4, 0.1);
  const std::string out = tmp.file("t.obj");
  EXPECT_EQ(run_cli("texture --shell '" + shell + "' --tile builtin:bumps --repeat 0 1 -o '" + out + "'").exit_code, 1);
  EXPECT_EQ(run_cli("texture --shell '" + shell + "' --tile builtin:nope -o '" + out + "'").exit_code, 1);
  EXPECT_EQ(run_cli("texture --shell '" + shell + "' --tile missing.obj -o '" + out + "'").exit_code, 1);
  // More tiled vertices than an int indexes (it once ran out of memory instead): said before any
  // allocation, with the counts.
  const auto huge = run_cli("texture --shell '" + shell + "' --tile builtin:bumps:1000 --repeat 200 200 -o '" + out + "'");
  EXPECT_EQ(huge.exit_code, 1);
  EXPECT_NE(huge.err.find("4.01e+10 vertices"), std::string::npos) << huge.err;
  // A base without UVs cannot carry a texture.
  write_mesh(shell + "/base.obj", make_sphere(0));
  write_mesh(shell + "/top.obj", make_sphere(0));
  const auto r = run_cli("texture --shell '" + shell + "' --tile builtin:bumps -o '" + out + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("texture coordinates"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

} // namespace
} // namespace gshell
