// The run layer's folders (run/shell_folder.h, run/frames.h, run/staged_folder.h) and the jobs
// on them (run/generate_run.h, run/deform_run.h).
#include "shell_fixtures.h"
#include "test_support.h"

#include <gshell/deform/synthetic_motion.h>
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/io/write_mesh.h>
#include <gshell/run/deform_run.h>
#include <gshell/run/frames.h>
#include <gshell/run/generate_run.h>
#include <gshell/run/pose_run.h>
#include <gshell/run/shell_folder.h>
#include <gshell/run/staged_folder.h>

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>

#include <sys/wait.h>
#include <unistd.h>

using namespace gshell;
namespace fs = std::filesystem;

namespace {

/// What a folder holds, hidden entries (staging leftovers) included.
std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

ShellFolderContents cylinder_contents(double eta) {
  ShellFolderContents c;
  c.surface = make_cylinder(12); // has UVs
  const Shell shell = test::offset_shell(c.surface, eta);
  c.X = shell.vertices();
  Eigen::MatrixXd stretch(3 * c.surface.num_faces(), 1);
  for (Eigen::Index t = 0; t < stretch.rows(); ++t) stretch(t, 0) = 0.001 * static_cast<double>(t);
  c.cell_data = {{"stretch", stretch}};
  c.report = {{"method", "offset"}, {"thickness", {{"eta", eta}, {"ratio", nullptr}}}};
  return c;
}

// A deform job over the offset shell of `surface` (thickness eta) along the named base frames.
DeformInput offset_shell_input(const TriMesh& surface, double eta, std::vector<Eigen::MatrixXd> frames,
                               std::vector<std::string> names) {
  DeformInput input;
  input.shell_name = "rest";
  input.shell = test::offset_shell(surface, eta);
  input.surface = surface;
  input.frames = BaseFrames(std::move(frames));
  input.frame_names = std::move(names);
  return input;
}

} // namespace

TEST(Frames, NamesNumbersAndScanOrder) {
  EXPECT_EQ(frame_name(7), "frame_0007");
  EXPECT_EQ(frame_name(12345, ".obj"), "frame_12345.obj");
  // A sequence longer than 9999 frames names every frame with as many digits as its last, so
  // that its names sort as text (a shell's frame_*.obj) in the frames' order.
  EXPECT_EQ(frame_name(7, ".obj", 9999), "frame_0007.obj");
  EXPECT_EQ(frame_name(7, ".obj", 12000), "frame_00007.obj");
  EXPECT_LT(frame_name(9999, "", 12000), frame_name(10000, "", 12000));
  EXPECT_EQ(frame_number(frame_name(7, "", 12000)), 7);
  EXPECT_EQ(frame_number("frame_0012.obj", ".obj"), 12);
  EXPECT_EQ(frame_number("frame_10000"), 10000);
  EXPECT_EQ(frame_number("frame_012"), 12);      // fewer than four digits: from other tools
  EXPECT_EQ(frame_number("frame_2.obj", ".obj"), 2);
  EXPECT_FALSE(frame_number("frame_.obj", ".obj"));
  EXPECT_FALSE(frame_number("frame_1234567890")); // more than nine
  EXPECT_FALSE(frame_number("frame_0012.obj")); // a file name where a folder name is asked for
  EXPECT_FALSE(frame_number("frame_00x2"));
  EXPECT_FALSE(frame_number("frames_0001"));

  test::TempDir tmp;
  for (const char* dir : {"frame_0010", "frame_10000", "frame_0002", "frame_9999", "frame_12", "other"})
    fs::create_directory(tmp.path() / dir);
  for (const char* file : {"frame_0003.obj", "frame_0001.obj", "frame_0005", "frame_0004.off"})
    test::write_text(tmp.file(file), "");
  std::vector<std::string> folders;
  for (const fs::path& p : list_frames(tmp.path())) folders.push_back(p.filename().string());
  // By number, not by name: frame_10000 sorts after frame_9999.
  EXPECT_EQ(folders, (std::vector<std::string>{"frame_0002", "frame_0010", "frame_12", "frame_9999", "frame_10000"}));
  std::vector<std::string> files;
  test::write_text(tmp.file("frame_2.obj"), ""); // frame_2.obj was skipped without a word
  for (const fs::path& p : list_frames(tmp.path(), ".obj")) files.push_back(p.filename().string());
  EXPECT_EQ(files, (std::vector<std::string>{"frame_0001.obj", "frame_2.obj", "frame_0003.obj"}));
  EXPECT_TRUE(list_frames(tmp.path() / "missing").empty());
  // Two names of one number: which is meant cannot be told.
  test::write_text(tmp.file("frame_1.obj"), "");
  try {
    list_frames(tmp.path(), ".obj");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("frame_0001.obj and frame_1.obj are both frame 1"), std::string::npos) << e.what();
  }
}

// `gshell deform --base DIR` takes what `gshell animate -o DIR` wrote: a folder stands for its
// frame files in order, a file for itself, in the order given.
TEST(Frames, AFolderArgumentIsItsFrameFiles) {
  test::TempDir tmp;
  const fs::path objs = tmp.path() / "objs", offs = tmp.path() / "offs", none = tmp.path() / "none";
  for (const fs::path& dir : {objs, offs, none}) fs::create_directory(dir);
  for (const char* file : {"frame_0002.obj", "frame_0001.obj", "frame_0010.obj", "notes.obj", "frame_0003.off"})
    test::write_text((objs / file).string(), "");
  // Extensions in any case, as the readers take them.
  for (const char* file : {"frame_0002.OFF", "frame_0001.off"}) test::write_text((offs / file).string(), "");
  const std::string single = tmp.file("single.obj");
  const std::vector<std::string> got = expand_frame_arguments({single, objs.string(), offs.string()});
  EXPECT_EQ(got, (std::vector<std::string>{single, (objs / "frame_0001.obj").string(), (objs / "frame_0002.obj").string(),
                                           (objs / "frame_0010.obj").string(), (offs / "frame_0001.off").string(),
                                           (offs / "frame_0002.OFF").string()}));
  // A missing file is left for the reader to name.
  EXPECT_EQ(expand_frame_arguments({tmp.file("missing.obj")}), std::vector<std::string>{tmp.file("missing.obj")});
  try {
    expand_frame_arguments({none.string()});
    ADD_FAILURE() << "a folder without frames was taken";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(none.string() + ": a folder holding no frame files", 0), 0u) << e.what();
    EXPECT_NE(std::string(e.what()).find("given as files, e.g. " + (none / "*.obj").string()), std::string::npos);
  }
  // A shell folder given by mistake: the message names its base.
  write_shell_folder(tmp.file("shell"), cylinder_contents(0.1));
  try {
    expand_frame_arguments({tmp.file("shell")});
    ADD_FAILURE() << "a shell folder was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("give " + tmp.file("shell") + "/base.obj"), std::string::npos) << e.what();
  }
}

TEST(ShellFolder, WriteReadRoundTrip) {
  test::TempDir tmp;
  const ShellFolderContents c = cylinder_contents(0.1);
  const std::string dir = tmp.file("shell");
  write_shell_folder(dir, c);
  EXPECT_EQ(entries(dir), (std::vector<std::string>{"base.obj", "report.json", "shell.vtu", "top.obj"}));
  ShellFolderReadOptions all;
  all.read_tets = true;
  const ShellFolder f = read_shell_folder(dir, all);
  const int n = c.surface.num_vertices();
  EXPECT_EQ(f.shell.base, c.X.topRows(n)); // full precision both ways
  EXPECT_EQ(f.shell.top, c.X.bottomRows(n));
  EXPECT_EQ(f.shell.F, c.surface.F);
  EXPECT_EQ(f.surface.UV, c.surface.UV);
  EXPECT_EQ(f.surface.FUV, c.surface.FUV);
  EXPECT_DOUBLE_EQ(f.shell.thickness, 0.1);
  EXPECT_EQ(f.made_by, "offset");
  EXPECT_EQ(f.tet_stretch, c.cell_data[0].second.col(0));
  EXPECT_EQ(f.tets.rows(), 3 * c.surface.num_faces());
  EXPECT_EQ(f.report, c.report);
  EXPECT_TRUE(is_shell_folder(dir));
  EXPECT_TRUE(holds_shell_output_of(dir, "generate"));
  EXPECT_FALSE(holds_shell_output_of(dir, "pose"));

  // Without base.obj the shell comes from shell.vtu, the faces from top.obj.
  fs::remove(fs::path(dir) / "base.obj");
  const ShellFolder g = read_shell_folder(dir);
  EXPECT_EQ(g.shell.vertices(), c.X);
  EXPECT_EQ(g.shell.F, c.surface.F);
  // Without top.obj too, the faces are recovered from the prism tets (same vertices, top side up).
  fs::remove(fs::path(dir) / "top.obj");
  const ShellFolder h = read_shell_folder(dir);
  ASSERT_EQ(h.shell.F.rows(), c.surface.F.rows());
  for (Eigen::Index f = 0; f < h.shell.F.rows(); ++f) {
    std::array<int, 3> a{h.shell.F(f, 0), h.shell.F(f, 1), h.shell.F(f, 2)}, b{c.surface.F(f, 0), c.surface.F(f, 1), c.surface.F(f, 2)};
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    EXPECT_EQ(a, b) << "face " << f;
  }
}

TEST(ShellFolder, ThicknessFromTheReportAsNumberOrEta) {
  test::TempDir tmp;
  ShellFolderContents c = cylinder_contents(0.2);
  c.report = {{"command", "pose"}, {"thickness", 0.25}};
  write_shell_folder(tmp.file("a"), c);
  const ShellFolder a = read_shell_folder(tmp.file("a"));
  EXPECT_DOUBLE_EQ(a.shell.thickness, 0.25);
  EXPECT_EQ(a.made_by, "pose");
  c.report = {{"command", "pose"}};
  write_shell_folder(tmp.file("b"), c);
  EXPECT_THROW(read_shell_folder(tmp.file("b")), InputError); // deform and pose need eta
  ShellFolderReadOptions lenient;
  lenient.require_thickness = false;
  EXPECT_EQ(read_shell_folder(tmp.file("b"), lenient).shell.thickness, 0);
  c.report = {{"thickness", -1}};
  write_shell_folder(tmp.file("c"), c);
  EXPECT_THROW(read_shell_folder(tmp.file("c"), lenient), InputError);
  EXPECT_THROW(read_shell_folder(tmp.file("missing")), InputError);
  fs::create_directory(tmp.path() / "empty");
  EXPECT_THROW(read_shell_folder(tmp.file("empty")), InputError);
  test::write_text(tmp.file("a/report.json"), "{not json");
  EXPECT_THROW(read_shell_folder(tmp.file("a")), InputError);
  // A broken report says where it breaks (it said "not a JSON object").
  test::write_text(tmp.file("a/report.json"), "{\"energy\": [1,\n NaN]}");
  try {
    read_report(tmp.file("a"));
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("report.json: not valid JSON (parse error at line 2, column 2"), std::string::npos) << e.what();
  }
}

TEST(StagedFolder, AFailureLeavesNothingBehind) {
  test::TempDir tmp;
  const ShellFolderContents c = cylinder_contents(0.1);
  const std::string dir = tmp.file("shell");
  // A failure after everything is written (here: while rendering a preview) leaves no folder and
  // no staging folder.
  EXPECT_THROW(write_shell_folder(dir, c, [](const fs::path&) { throw InputError("no preview"); }), InputError);
  EXPECT_TRUE(entries(tmp.path()).empty());
  // A failure while writing (shell.vtu refuses cell data of the wrong size, after the OBJs) too.
  ShellFolderContents bad = c;
  bad.cell_data = {{"stretch", Eigen::MatrixXd::Zero(1, 1)}};
  EXPECT_THROW(write_shell_folder(dir, bad), InputError);
  EXPECT_TRUE(entries(tmp.path()).empty());
  // An earlier output survives a failed replacement, unchanged.
  write_shell_folder(dir, c);
  const auto before = test::read_text(dir + "/report.json");
  EXPECT_THROW(write_shell_folder(dir, c, [](const fs::path&) { throw InputError("no preview"); }), InputError);
  EXPECT_EQ(test::read_text(dir + "/report.json"), before);
  EXPECT_EQ(entries(tmp.path()), std::vector<std::string>{"shell"});
  // A folder of other files is never replaced, and nothing is left beside it.
  fs::create_directory(tmp.path() / "mine");
  test::write_text(tmp.file("mine/notes.txt"), "keep me");
  EXPECT_THROW(write_shell_folder(tmp.file("mine"), c), InputError);
  EXPECT_THROW(check_output_folder(tmp.file("mine"), [](const fs::path& d) { return holds_shell_output_of(d, "generate"); }), InputError);
  EXPECT_NO_THROW(check_output_folder(tmp.file("mine"))); // without a rule only the path is checked
  EXPECT_EQ(entries(tmp.path() / "mine"), std::vector<std::string>{"notes.txt"});
  EXPECT_EQ(entries(tmp.path()), (std::vector<std::string>{"mine", "shell"}));
  EXPECT_THROW(check_output_folder(tmp.file("no/such/parent/out")), InputError);
  EXPECT_THROW(check_output_folder(tmp.file("mine/notes.txt")), InputError);
}

TEST(StagedFolder, WriteErrorsNameTheDestinationNotTheHiddenFolder) {
  test::TempDir tmp;
  const std::string dir = tmp.file("shell");
  const auto fail = [](const fs::path& staging) {
    throw InputError(with_file((staging / "preview.png").string(), "write failed (disk full?)"));
  };
  try {
    write_shell_folder(dir, cylinder_contents(0.1), fail);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), (fs::path(dir) / "preview.png").string() + ": write failed (disk full?)");
  }
  EXPECT_TRUE(entries(tmp.path()).empty());
  // Every mention, and nothing else.
  StagedFolder staged(dir);
  const std::string hidden = staged.path().string();
  EXPECT_EQ(staged.at_destination(hidden + "/a and " + hidden + "/b, not " + tmp.path().string()),
            dir + "/a and " + dir + "/b, not " + tmp.path().string());
}

TEST(StagedFolder, AFileWhereAFolderIsWantedIsNamedAsSuch) {
  test::TempDir tmp;
  test::write_text(tmp.file("afile"), "x");
  auto message = [](const std::function<void()>& f) {
    try {
      f();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message([&] { check_output_folder(tmp.file("afile") + "/sub", {}); }),
            tmp.file("afile") + "/sub: parent " + tmp.file("afile") + " is not a folder");
  EXPECT_EQ(message([&] { check_output_folder(tmp.file("none") + "/sub", {}); }),
            tmp.file("none") + "/sub: parent folder does not exist");
  EXPECT_NE(message([&] { read_shell_folder(tmp.file("afile")); }).find("not a shell folder (a file;"), std::string::npos);
  EXPECT_NE(message([&] { read_shell_folder(tmp.file("none")); }).find("(no such directory)"), std::string::npos);
  // /proc exists but takes no new folders, and says "No such file or directory" if asked; the
  // check before a run finds it (not the run's end), and leaves nothing behind where it can write.
  if (std::filesystem::is_directory("/proc/self")) {
    const std::string refused = "/proc/gshell_out: cannot write in /proc: its file system does not allow new folders";
    EXPECT_EQ(message([&] { check_output_folder("/proc/gshell_out", {}); }), refused);
    EXPECT_EQ(message([&] { StagedFolder staged(std::filesystem::path("/proc/gshell_out")); }), refused);
  }
  EXPECT_EQ(message([&] { check_output_folder(tmp.file("out"), {}); }), "no error");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(tmp.path()), std::filesystem::directory_iterator{}), 1);
}

// "OUT/." names OUT: its staging folder goes beside OUT, not into it (where the check for other
// files found it and refused an empty folder). The current folder, or one holding it, is never
// replaced: the user's shell would be left in a deleted folder.
TEST(StagedFolder, AFolderNamedByItsOwnEntryIsThatFolderAndTheCurrentOneIsRefused) {
  test::TempDir tmp;
  fs::create_directory(tmp.path() / "out");
  const ShellFolderContents c = cylinder_contents(0.1);
  write_shell_folder(tmp.file("out") + "/.", c);
  EXPECT_EQ(entries(tmp.path()), std::vector<std::string>{"out"});
  EXPECT_TRUE(fs::exists(tmp.file("out/report.json")));
  write_shell_folder(tmp.file("out") + "/.", c); // an earlier output, replaced
  EXPECT_EQ(entries(tmp.path()), std::vector<std::string>{"out"});
  // Through a symbolic link: the folder it leads to is replaced, the link kept.
  fs::create_directory_symlink("out", tmp.path() / "link");
  write_shell_folder(tmp.file("link"), c);
  EXPECT_TRUE(fs::is_symlink(tmp.path() / "link"));
  EXPECT_EQ(entries(tmp.path()), (std::vector<std::string>{"link", "out"}));
  fs::remove(tmp.path() / "link");
  fs::create_directory(tmp.path() / "out2");
  const fs::path before = fs::current_path();
  fs::current_path(tmp.path() / "out2");
  EXPECT_THROW(check_output_folder("."), InputError);
  EXPECT_THROW(check_output_folder(".."), InputError);
  EXPECT_THROW(check_output_folder(tmp.file("out2")), InputError);
  EXPECT_NO_THROW(check_output_folder("sub"));
  fs::current_path(before);
  EXPECT_EQ(entries(tmp.path() / "out2"), std::vector<std::string>{});
}

// Staging folders left by runs killed outright (kill -9, the out-of-memory killer) are removed by
// the next run to the same output: those whose process is gone. A live process's, another
// output's and names of another shape stay.
TEST(StagedFolder, OrphansOfKilledRunsAreRemovedByTheNextRun) {
  test::TempDir tmp;
  const pid_t gone = fork();
  if (gone == 0) _exit(0);
  ASSERT_GT(gone, 0);
  waitpid(gone, nullptr, 0); // reaped: its id names no process now (unless reused at once)
  const std::string dead = std::to_string(gone);
  for (const std::string& name : std::vector<std::string>{".out.tmp-" + dead + "-5", ".out.old-" + dead + "-6", ".out.tmp-1-7",
                                 ".other.tmp-" + dead + "-8", ".out.tmpx-" + dead + "-9"}) {
    fs::create_directory(tmp.path() / name);
    test::write_text((tmp.path() / name / "top.obj").string(), "v 0 0 0\n");
  }
  write_shell_folder(tmp.file("out"), cylinder_contents(0.1));
  EXPECT_EQ(entries(tmp.path()), (std::vector<std::string>{".other.tmp-" + dead + "-8", ".out.tmp-1-7",
                                                           ".out.tmpx-" + dead + "-9", "out"}));
}

TEST(GenerateRun, OptionsReportAndFolder) {
  GenerateRunOptions o;
  EXPECT_THROW(o.check(), InputError); // no thickness
  o.thickness.thickness = 0.05;
  o.thickness.thickness_ratio = 0.05;
  EXPECT_THROW(o.check(), InputError); // both
  o.thickness.thickness.reset();
  o.generate.s_min = 1.5;
  EXPECT_THROW(o.check(), InputError);
  o.generate.s_min = GenerateOptions{}.s_min;
  o.generate.solve.max_iterations = 10;
  EXPECT_NO_THROW(o.check());

  const TriMesh sphere = make_sphere(2);
  const GenerateRun run = run_generate(sphere, "builtin:sphere:2", o);
  EXPECT_DOUBLE_EQ(run.result.shell.thickness, thickness_from_ratio(sphere.V, 0.05));
  const auto report = run.to_json();
  EXPECT_EQ(report["input"], "builtin:sphere:2");
  EXPECT_DOUBLE_EQ(report["thickness"]["ratio"].get<double>(), 0.05);
  EXPECT_EQ(report["certificate"]["inverted_tets"], run.result.metrics.certificate.inverted_tets);
  EXPECT_NE(run.summary().find("builtin:sphere:2"), std::string::npos);
  test::TempDir tmp;
  run.write(tmp.file("shell"));
  const ShellFolder back = read_shell_folder(tmp.file("shell"));
  EXPECT_EQ(back.shell.top, run.result.shell.top);
  EXPECT_DOUBLE_EQ(back.shell.thickness, run.result.shell.thickness);
  EXPECT_EQ(back.report, report);
}

TEST(DeformRun, RigidFramesMoveTheTopRigidlyAndTheFolderHoldsEveryFrame) {
  test::TempDir tmp;
  const TriMesh cylinder = make_cylinder(16);
  const Shell rest = test::offset_shell(cylinder, 0.1);
  DeformInput input;
  input.shell_name = "rest";
  input.shell = rest;
  input.surface = cylinder;
  const int frames = 3;
  std::vector<Eigen::MatrixXd> bases;
  for (int k = 1; k <= frames; ++k) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.2 * k, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
    bases.push_back((rest.base * R.transpose()).rowwise() + Eigen::RowVector3d(0.1 * k, 0, 0));
    input.frame_names.push_back("turn " + std::to_string(k));
  }
  input.frames = BaseFrames(bases);
  DeformRunOptions options;
  options.frame.tolerance = 1e-10;
  options.compare_offset = true;
  int calls = 0;
  const std::string out = tmp.file("run");
  const DeformRun run = run_deform(input, options, out, [&](const DeformRun& so_far, int count) {
    EXPECT_EQ(count, frames);
    EXPECT_EQ(static_cast<int>(so_far.frames.size()), calls++);
  });
  EXPECT_EQ(calls, frames + 1); // after the setup and after every frame
  ASSERT_EQ(static_cast<int>(run.frames.size()), frames);
  for (const DeformFrameRecord& f : run.frames) {
    EXPECT_LT(f.result.stretch.max, 1e-12) << f.frame;
    ASSERT_TRUE(f.offset.has_value());
  }
  const auto report = run.to_json();
  EXPECT_EQ(report["command"], "deform");
  EXPECT_EQ(report["warm_start"], "extrapolated");
  EXPECT_EQ(report["summary"]["frames"], frames);
  EXPECT_EQ(report["summary"]["inverted_tets"], 0);
  EXPECT_TRUE(report["summary"].contains("offset"));
  EXPECT_EQ(report["warnings"], nlohmann::ordered_json::array()); // every frame valid
  EXPECT_EQ(report["frames"][1]["base"], "turn 2");
  EXPECT_EQ(read_report(out), report);
  EXPECT_EQ(entries(out), (std::vector<std::string>{"frame_0001", "frame_0002", "frame_0003", "report.json"}));
  EXPECT_TRUE(holds_only_deform_output(out));
  // A frame folder reads as a shell: the run's thickness, the base's faces and UVs.
  const ShellFolder last = read_shell_folder(out + "/frame_0003");
  EXPECT_DOUBLE_EQ(last.shell.thickness, 0.1);
  EXPECT_EQ(last.shell.F, cylinder.F);
  EXPECT_TRUE(last.surface.has_uv());
  EXPECT_LT((last.shell.base - bases.back()).cwiseAbs().maxCoeff(), 1e-12);

  options.frame.max_iterations = -1;
  EXPECT_THROW(run_deform(input, options), InputError);
  EXPECT_EQ(entries(tmp.path()), std::vector<std::string>{"run"});
}

// Outputs are numbered by position: frames whose numbers skip are named in a warning (frame_0003
// written as frame_0002 went without a word); frames numbered 1, 2, ... or not named as frames at
// all are not.
TEST(DeformRun, FrameNumbersThatSkipAreAWarning) {
  const TriMesh cylinder = make_cylinder(12);
  auto numbering_warnings = [&](const std::vector<std::string>& names) {
    const DeformInput input = offset_shell_input(cylinder, 0.1, {cylinder.V, cylinder.V}, names);
    const std::vector<std::string> w = run_deform(input, DeformRunOptions{}).warnings();
    return std::count_if(w.begin(), w.end(), [](const std::string& line) {
      return line.rfind("the frames' numbers do not run 1, 2, 3", 0) == 0;
    });
  };
  EXPECT_EQ(numbering_warnings({"seq/frame_0001.obj", "seq/frame_0003.obj"}), 1);
  EXPECT_EQ(numbering_warnings({"seq/frame_0001.OBJ", "seq/frame_0002.OBJ"}), 0);
  EXPECT_EQ(numbering_warnings({"rest.obj", "bent.obj"}), 0);
}

// A negative scale turns the base inside out: the top follows the faces' winding to the other side,
// inside a closed base, which a user must hear of (the frame itself may well be valid).
TEST(DeformRun, AMirroredFrameIsAWarning) {
  const TriMesh cylinder = make_cylinder(16);
  Eigen::MatrixXd mirrored = cylinder.V, squashed = cylinder.V;
  mirrored.col(0) *= -1;
  squashed.col(2) *= 0.5;
  // Two turns of twist about the box's first axis (`gshell animate --twist 720`): the best linear
  // map has a block near zero across the axis, so the sign of its determinant is rounding, not a
  // mirror (the warning was given for it).
  const Eigen::MatrixXd twisted = twist(cylinder.V, motion_frame(cylinder.V), 720);
  const DeformInput input = offset_shell_input(cylinder, 0.1, {cylinder.V, mirrored, squashed, twisted},
                                               {"rest", "mirror", "squash", "twist"});
  const DeformRun run = run_deform(input, DeformRunOptions{});
  ASSERT_EQ(run.frames.size(), 4u);
  EXPECT_FALSE(run.frames[0].mirrored);
  EXPECT_TRUE(run.frames[1].mirrored);
  EXPECT_FALSE(run.frames[2].mirrored);
  EXPECT_FALSE(run.frames[3].mirrored);
  const std::vector<std::string> w = run.warnings();
  EXPECT_EQ(std::count_if(w.begin(), w.end(), [](const std::string& line) {
              return line.rfind("frame 2 mirrors the rest base", 0) == 0;
            }),
            1)
      << ::testing::PrintToString(w);
}

// A frame cut off by the iteration cap may be far from its minimum: a warning names it, as it names
// pose steps; frames that converged are not named.
TEST(DeformRun, FramesThatRanOutOfIterationsAreAWarning) {
  const TriMesh cylinder = make_cylinder(16);
  const MotionFrame frame = motion_frame(cylinder.V);
  const DeformInput input = offset_shell_input(cylinder, 0.1, {twist(cylinder.V, frame, 30), twist(cylinder.V, frame, 60)},
                                               {"twist 30", "twist 60"});
  const auto capped_line = [](const DeformRun& run) {
    std::string found;
    for (const std::string& line : run.warnings())
      if (line.find("ran out of iterations") != std::string::npos) found = line;
    return found;
  };
  DeformRunOptions cut;
  cut.frame.max_iterations = 2;
  cut.frame.tolerance = 1e-9;
  const DeformRun short_run = run_deform(input, cut);
  ASSERT_EQ(short_run.frames.size(), 2u);
  ASSERT_FALSE(short_run.frames[1].result.converged);
  const std::string line = capped_line(short_run);
  const std::string named = short_run.frames[0].result.converged ? "frame 2 " : "frames 1, 2 ";
  EXPECT_EQ(line.rfind(named + "ran out of iterations before converging (--iterations 2)", 0), 0u) << line;

  DeformRunOptions enough;
  enough.frame.max_iterations = 1000;
  const DeformRun full_run = run_deform(input, enough);
  for (const DeformFrameRecord& f : full_run.frames) ASSERT_TRUE(f.result.converged) << f.frame;
  EXPECT_EQ(capped_line(full_run), "");

  // No iterations asked for (each frame is its warm start): nothing ran out.
  DeformRunOptions none;
  none.frame.max_iterations = 0;
  const DeformRun start_run = run_deform(input, none);
  ASSERT_FALSE(start_run.frames[1].result.converged);
  EXPECT_EQ(capped_line(start_run), "");
}

// A rest shell whose top lies inside its base (every tet inverted) deforms with normal-prism rest
// shapes: its frames' tops come out on the other side, which a warning must say.
TEST(DeformRun, InvertedRestTetsAreAWarning) {
  const TriMesh sphere = make_sphere(2);
  DeformInput input = offset_shell_input(sphere, 0.05, {sphere.V * 1.01}, {"grown"});
  const DeformRun right = run_deform(input, DeformRunOptions{});
  EXPECT_EQ(right.replaced_rest_tets, 0);
  for (const std::string& line : right.warnings()) EXPECT_EQ(line.find("rest shell tets"), std::string::npos) << line;

  input.shell.top = sphere.V * 0.95;
  const DeformRun run = run_deform(input, DeformRunOptions{});
  ASSERT_EQ(run.replaced_rest_tets, run.tets);
  const std::string expected = std::to_string(run.tets) + " of " + std::to_string(run.tets) +
                               " rest shell tets are flat or inverted";
  const std::vector<std::string> w = run.warnings();
  ASSERT_FALSE(w.empty());
  EXPECT_EQ(w[0].rfind(expected, 0), 0u) << w[0];
  EXPECT_NE(w[0].find("wrong side of the base"), std::string::npos) << w[0];
}

// Frames and pose steps that are not valid are named in one warning line, by what explains them;
// the line goes into report.json too (the CLI prints it even with --quiet).
TEST(DeformRun, DetailFarOutsideTheShellIsAWarning) {
  // Points outside every tet follow their nearest tet's map extrapolated: a detail in other units
  // (1e45 away in one case) was carried without a word but the report's count.
  DeformRun run;
  run.thickness = 0.1;
  run.embed = DeformRun::Embed{"detail.obj", 10, 2, 0.05};
  EXPECT_TRUE(run.warnings().empty()); // within one thickness: rounding or a detail on the top
  run.embed->max_outside_distance = 0.5;
  ASSERT_EQ(run.warnings().size(), 1u);
  EXPECT_EQ(run.warnings()[0].rfind("2 of 10 detail vertices of detail.obj lie outside the shell, up to 0.5 from it "
                                    "(5 times its thickness)", 0), 0u) << run.warnings()[0];
  EXPECT_EQ(run.to_json()["warnings"].size(), 1u);
}

TEST(DeformRun, InvalidFramesAreNamedInAWarningByCause) {
  DeformRun run;
  auto add = [&](bool valid, int crossings, std::vector<int> unextrudable) {
    DeformFrameRecord f;
    f.frame = static_cast<int>(run.frames.size()) + 1;
    f.result.valid = valid;
    f.result.converged = true;
    f.result.certificate.base_self_intersections = crossings;
    f.result.unextrudable_vertices = std::move(unextrudable);
    run.frames.push_back(f);
  };
  add(true, 0, {});
  EXPECT_TRUE(run.warnings().empty());
  add(false, 4, {});
  add(false, 0, {});
  add(true, 0, {});
  add(false, 2, {7, 9});
  const std::vector<std::string> w = run.warnings();
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0], "3 of 5 frames are not valid: the base crosses itself in frames 2, 5; base vertices cannot be "
                  "extruded in frame 5; the guard could not make frame 3 valid (report.json has each frame's "
                  "certificate)");
  EXPECT_EQ(run.to_json()["warnings"], nlohmann::ordered_json(w));
  run.options.frame.allow_invalid = true; // unexplained frames were not guarded at all
  EXPECT_NE(run.warnings()[0].find("frame 3 unguarded (allow_invalid)"), std::string::npos) << run.warnings()[0];
  // A frame with faces of zero area (an edge collapsed onto itself) was said only to cross itself.
  run.frames[1].result.zero_area_faces = 2;
  ASSERT_EQ(run.warnings().size(), 2u);
  EXPECT_EQ(run.warnings()[1].rfind("frame 2 has base faces of zero area (up to 2 a frame: a collapsed edge or "
                                    "collinear corners)", 0), 0u) << run.warnings()[1];
  EXPECT_EQ(run.to_json()["frames"][1]["zero_area_faces"], 2);
  // A base whose parts touch to rounding crosses nothing by the exact test, yet no layer fits
  // between them (a plane bent by exactly 360 degrees): named as such, not as the guard's failure;
  // a frame whose base also crosses itself is named for the crossing alone.
  run.frames[2].result.base_nearly_touching = true;
  run.frames[4].result.base_nearly_touching = true;
  EXPECT_EQ(run.warnings()[0], "3 of 5 frames are not valid: the base crosses itself in frames 2, 5; base vertices "
                               "cannot be extruded in frame 5; parts of the base touch or nearly touch in frame 3 "
                               "(closer than the layer can thin between them) (report.json has each frame's "
                               "certificate)");
  EXPECT_EQ(run.to_json()["frames"][2]["base_nearly_touching"], true);

  PoseResult pose;
  auto step = [&](bool valid, bool blocked, int crossings) {
    PoseStepReport s;
    s.guarded = s.certified = true;
    s.valid = valid;
    s.blocked_by_contact = blocked;
    s.base_self_intersections = crossings;
    s.converged = true;
    pose.steps.push_back(s);
  };
  step(true, false, 0);
  EXPECT_TRUE(pose.warnings().empty());
  step(true, true, 0);
  step(false, false, 3);
  const std::vector<std::string> p = pose.warnings();
  ASSERT_EQ(p.size(), 2u);
  // A stall is named as such: contact is its likely cause, not its only one (more steps can help).
  EXPECT_EQ(p[0].rfind("pose step 2: stopped short of the handles' targets, valid: the guarded drag stalled", 0), 0u) << p[0];
  EXPECT_NE(p[0].find("more --steps"), std::string::npos) << p[0];
  EXPECT_EQ(p[1], "1 of 3 pose steps is not valid: the base crosses itself in pose step 3 (report.json has each "
                  "pose step's certificate)");
  EXPECT_EQ(pose.to_json()["warnings"], nlohmann::ordered_json(p));
  // A step that ran out of iterations may be far from the pose's minimum: said so too.
  // A step stopped at contact is not said to have run out of iterations (more would not move
  // it), and the hierarchical solver is suggested only to runs without it.
  pose.max_iterations = 500;
  pose.steps[0].converged = false;
  pose.steps[1].converged = false;
  ASSERT_EQ(pose.warnings().size(), 3u);
  EXPECT_EQ(pose.warnings()[2], "pose step 1 ran out of iterations before converging (--iterations 500): the shell "
                                "may be short of the pose's minimum; more iterations get closer");
  pose.solver = PoseSolverKind::Single;
  EXPECT_NE(pose.warnings()[2].find("or the hierarchical solver"), std::string::npos) << pose.warnings()[2];
  pose.solver = PoseSolverKind::Hierarchical;
  step(false, false, 0);
  pose.steps.back().rest_faults_only = true; // invalid only where the rest shell is
  EXPECT_EQ(pose.warnings()[1], "2 of 4 pose steps are not valid: the base crosses itself in pose step 3; pose step "
                                "4 keeps the rest shell's own faults (report.json has each pose step's certificate)");
  // Soft handles are cut back, not dragged: contact is not the only cause to name.
  pose.mode = ConstraintMode::Soft;
  pose.steps[1].drag_start = 0.0824;
  EXPECT_EQ(pose.warnings()[0], "pose step 2: the solver's step was not valid and could not be mended, so 8.24 % of it "
                                "was kept, short of the handles' targets (soft handles are cut back, not dragged; "
                                "blocked_by_contact in report.json)");
}

// A sequence too large to hold is read again frame by frame: the same run, bit for bit. Its files
// are all checked before any work, and one changed during the run ends it with the file named
// and nothing written.
TEST(DeformRun, FramesReadAgainWhenTooLargeToHoldGiveTheSameRun) {
  test::TempDir tmp;
  const TriMesh cylinder = make_cylinder(16);
  const Shell rest = test::offset_shell(cylinder, 0.1);
  std::vector<std::string> paths;
  for (int k = 1; k <= 3; ++k) {
    TriMesh frame = cylinder;
    frame.V.col(0) = cylinder.V.col(0) * (1 + 0.05 * k) + cylinder.V.col(2) * (0.1 * k);
    paths.push_back(tmp.file("base" + std::to_string(k) + ".obj"));
    write_mesh(paths.back(), frame);
  }
  const BaseFrames held = BaseFrames::load(paths, rest);
  const BaseFrames read_again = BaseFrames::load(paths, rest, 0);
  ASSERT_TRUE(held.held());
  ASSERT_FALSE(read_again.held());
  ASSERT_EQ(read_again.size(), 3);
  DeformInput input;
  input.shell_name = "rest";
  input.shell = rest;
  input.surface = cylinder;
  input.frame_names = paths;
  input.frames = held;
  const DeformRun a = run_deform(input, {});
  input.frames = read_again;
  const DeformRun b = run_deform(input, {});
  ASSERT_EQ(a.frames.size(), 3u);
  ASSERT_EQ(b.frames.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(read_again.get(k), held.get(k)) << k;
    EXPECT_EQ(a.frames[k].result.energy, b.frames[k].result.energy) << k;
  }

  // A bad file fails at load() whether the frames are held or not.
  test::write_text(tmp.file("bad.obj"), "v 0 0 0\n");
  std::vector<std::string> with_bad = paths;
  with_bad.push_back(tmp.file("bad.obj"));
  EXPECT_THROW(BaseFrames::load(with_bad, rest, 0), InputError);

  // The last frame's file replaced by a mesh of another size after the load: the run stops there.
  write_mesh(paths.back(), make_cylinder(8));
  const std::string out = tmp.file("run");
  try {
    run_deform(input, {}, out);
    ADD_FAILURE() << "a frame changed during the run was used";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(paths.back()), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(out));
}
