// Messages a user meets on common mistakes: a mistyped command or option gets a "did you mean",
// coordinates out of gshell's range get one line saying so (never a confusing later failure), all
// with exit code 1, one line on stderr and nothing written.
#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

#include <sys/wait.h>

using gshell::test::count_entries;
using gshell::test::run_cli;
using gshell::test::TempDir;
using gshell::test::write_text;

namespace {

std::string quoted(const std::string& s) { return "'" + s + "'"; }

/// Expects exit code 1 and exactly the line `gshell: error: <message>` on stderr, nothing on stdout.
void expect_error_line(const std::string& args, const std::string& message) {
  const auto r = run_cli(args);
  EXPECT_EQ(r.exit_code, 1) << args;
  EXPECT_EQ(r.err, "gshell: error: " + message + "\n") << args;
  EXPECT_TRUE(r.out.empty()) << args << "\n" << r.out;
}

/// Expects exit code 1 and one error line on stderr containing `fragment`.
void expect_error_containing(const std::string& args, const std::string& fragment) {
  const auto r = run_cli(args);
  EXPECT_EQ(r.exit_code, 1) << args;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(r.err.rfind("gshell: error: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(fragment), std::string::npos) << "'" << r.err << "' lacks '" << fragment << "'";
}

/// A closed tetrahedron scaled by `scale`, as OFF text.
std::string tetrahedron_off(double scale) {
  char text[400];
  std::snprintf(text, sizeof text, "OFF\n4 4 0\n0 0 0\n%.17g 0 0\n0 %.17g 0\n0 0 %.17g\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n",
                scale, scale, scale);
  return text;
}

/// OBJ text with every vertex position multiplied by `factor` (other lines kept).
std::string scaled_obj(const std::string& obj, double factor) {
  std::istringstream in(obj);
  std::ostringstream out;
  out.precision(17);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("v ", 0) == 0) {
      std::istringstream v(line.substr(2));
      double x, y, z;
      v >> x >> y >> z;
      out << "v " << x * factor << " " << y * factor << " " << z * factor << "\n";
    } else {
      out << line << "\n";
    }
  }
  return out.str();
}

/// Expects stderr written as a log: lines (each ended) that all start with "gshell COMMAND: ",
/// no carriage return or terminal escape, and at least `min_lines` of them.
void expect_log_lines(const std::string& err, const std::string& command, int min_lines) {
  EXPECT_EQ(err.find('\r'), std::string::npos) << err;
  EXPECT_EQ(err.find('\x1b'), std::string::npos) << err;
  ASSERT_FALSE(err.empty());
  EXPECT_EQ(err.back(), '\n') << err;
  std::istringstream in(err);
  int lines = 0;
  for (std::string line; std::getline(in, line); ++lines)
    EXPECT_EQ(line.rfind("gshell " + command + ": ", 0), 0u) << "'" << line << "' in\n" << err;
  EXPECT_GE(lines, min_lines) << err;
}

} // namespace

TEST(CliMessages, MistypedCommandSuggestsTheClosestOne) {
  TempDir dir;
  expect_error_line("generat builtin:sphere:1 -o " + quoted(dir.file("out")) + " --thickness 0.1",
                    "unknown command 'generat' (did you mean 'generate'?)");
  expect_error_line("convret a.obj b.ply", "unknown command 'convret' (did you mean 'convert'?)");
  expect_error_line("-q infp builtin:sphere", "unknown command 'infp' (did you mean 'info'?)");
  expect_error_line("gen builtin:sphere", "unknown command 'gen' (did you mean 'generate'?)"); // unique prefix
  expect_error_line("frobnicate x", "unknown command 'frobnicate' (see gshell --help for the commands)");
  EXPECT_EQ(count_entries(dir.path()), 0);
}

TEST(CliMessages, MistypedOptionSuggestsTheClosestOne) {
  TempDir dir;
  const std::string out = " -o " + quoted(dir.file("out"));
  expect_error_line("generate builtin:sphere:1" + out + " --thicknes 0.1",
                    "unknown option '--thicknes' for 'generate' (did you mean '--thickness'?)");
  expect_error_line("generate builtin:sphere:1" + out + " --thickness-ratoi=0.1",
                    "unknown option '--thickness-ratoi' for 'generate' (did you mean '--thickness-ratio'?)");
  // One word of a longer option, misspelt or not; an ambiguous word suggests nothing.
  expect_error_line("generate builtin:sphere:1" + out + " --ratoi 0.1",
                    "unknown option '--ratoi' for 'generate' (did you mean '--thickness-ratio'?)");
  expect_error_line("deform --start previous", "unknown option '--start' for 'deform' (did you mean '--warm-start'?)");
  expect_error_line("generate builtin:sphere:1" + out + " --thick 0.1",
                    "unknown option '--thick' for 'generate' (see gshell generate --help)");
  expect_error_line("info --jsn builtin:sphere", "unknown option '--jsn' for 'info' (did you mean '--json'?)");
  expect_error_line("--quite info builtin:sphere", "unknown option '--quite' (did you mean '--quiet'?)");
  expect_error_line("generate builtin:sphere:1" + out + " --zzzzzz", "unknown option '--zzzzzz' for 'generate' (see gshell generate --help)");
  EXPECT_EQ(count_entries(dir.path()), 0);
}

TEST(CliMessages, OtherArgumentErrorsKeepTheirMessage) {
  // Not a typo: the command and options exist, an operand is missing.
  expect_error_line("info", "MESH is required (see gshell info --help)");
  expect_error_line("pose --handles h.json -o out", "--shell is required (see gshell pose --help)");
  expect_error_line("", "A subcommand is required (see gshell --help)");
  // Values that do not convert say what the option takes (CLI11: "Could not convert: --steps = ...").
  expect_error_line("animate builtin:plane:4 --bend 30 -o out --frames 99999999999",
                    "--frames 99999999999: expected a whole number of at most 2147483647 (see gshell animate --help)");
  expect_error_line("animate builtin:plane:4 --bend 30 -o out --frames -99999999999",
                    "--frames -99999999999: expected a whole number of at least -2147483648 (see gshell animate --help)");
  expect_error_line("animate builtin:plane:4 --bend 30 -o out --frames 2.5",
                    "--frames 2.5: expected a whole number (see gshell animate --help)");
  expect_error_line("generate builtin:sphere -o out --thickness-ratio abc",
                    "--thickness-ratio abc: expected a number (see gshell generate --help)");
  expect_error_line("generate builtin:sphere -o out --thickness-ratio 0.03 --thickness-ratio 0.05",
                    "--thickness-ratio is given 2 times (once at most) (see gshell generate --help)");
  // Correct spellings still work after the check.
  EXPECT_EQ(run_cli("--quiet info builtin:sphere:1 --json").exit_code, 0);
}

TEST(CliMessages, HugeCoordinatesSayTheyAreTooLarge) {
  TempDir dir;
  for (const double big : {1e150, 1e200}) {
    const std::string mesh = dir.file("big.off");
    write_text(mesh, tetrahedron_off(big));
    char expected[200];
    std::snprintf(expected, sizeof expected,
                  ": vertex 1 has a coordinate of magnitude %g; gshell needs |x| < 1e+50 (volumes and products of "
                  "lengths would overflow) (and 2 more problems)",
                  big);
    expect_error_line("generate " + quoted(mesh) + " -o " + quoted(dir.file("out")) + " --thickness-ratio 0.05",
                      mesh + expected);
    expect_error_line("convert " + quoted(mesh) + " " + quoted(dir.file("c.obj")), mesh + expected);
    const auto info = run_cli("info " + quoted(mesh));
    EXPECT_EQ(info.exit_code, 1);
    EXPECT_NE(info.out.find("error: vertex 3 has a coordinate of magnitude"), std::string::npos) << info.out;
    EXPECT_EQ(info.out.find("zero area"), std::string::npos) << info.out;
  }
  EXPECT_EQ(count_entries(dir.path()), 1); // only the input
}

TEST(CliMessages, TinyMeshesSayTheyAreTooSmall) {
  TempDir dir;
  const std::string mesh = dir.file("tiny.off");
  write_text(mesh, tetrahedron_off(1e-150));
  expect_error_line("generate " + quoted(mesh) + " -o " + quoted(dir.file("out")) + " --thickness-ratio 0.05",
                    mesh + ": the mesh is too small: its bounding box diagonal is 1.73e-150; gshell needs at least "
                           "1e-40 (areas and volumes would underflow; scale the mesh up)");
  EXPECT_EQ(count_entries(dir.path()), 1);
}

TEST(CliMessages, LargeButAcceptedCoordinatesMakeAShell) {
  TempDir dir;
  const std::string mesh = dir.file("large.off");
  write_text(mesh, tetrahedron_off(9e49));
  const auto r = run_cli("generate " + quoted(mesh) + " -o " + quoted(dir.file("out")) + " --thickness-ratio 0.05 -q");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("valid        yes (exact: 0 inverted tets;"), std::string::npos) << r.out;
}

TEST(CliMessages, ThicknessesOutOfScaleSayWhy) {
  // Before the bound (generate_shell.h), a ratio of 1e20 failed with "the start state is not valid" or "the shell
  // system is singular", and 1e-300 with a non-finite certificate vertex.
  TempDir dir;
  // Without -q: the error comes before the run's first progress line, alone.
  expect_error_containing("generate builtin:sphere:2 -o " + quoted(dir.file("out")) + " --thickness-ratio 1e20",
                          "thickness 1e+20 is 1e+20 times the mesh's bounding radius (1); gshell builds layers up to 10 "
                          "times it (thickness ratio 10)");
  expect_error_containing("generate builtin:sphere:2 -o " + quoted(dir.file("out")) + " --thickness 1e-300",
                          "below 1e-09 of the mesh's extent (1): double precision cannot tell a top that close from the base");
  expect_error_line("generate builtin:sphere:2 -q -o " + quoted(dir.file("out")) + " --thickness-ratio -1e-20",
                    "--thickness-ratio must be positive and finite (got -1e-20)");
  // The metrics' normal prisms too (it printed "stretch mean inf" and a 300-digit thickness).
  expect_error_containing("metrics builtin:sphere:2 builtin:sphere:2 --thickness 1e-300 -o " + quoted(dir.file("m.json")),
                          "thickness 1e-300 is 1e-300 times the mesh's bounding radius (1), below 1e-09");
  EXPECT_EQ(count_entries(dir.path()), 0);
}

TEST(CliMessages, DeformedFramesBeyondTheLimitNameTheFrame) {
  TempDir dir;
  const std::string shell = dir.file("shell"), frame = dir.file("frame.off");
  ASSERT_EQ(run_cli("generate builtin:sphere:1 -o " + quoted(shell) + " --thickness-ratio 0.05 -q").exit_code, 0);
  ASSERT_EQ(run_cli("convert builtin:sphere:1 " + quoted(frame) + " -q").exit_code, 0);
  std::string text = gshell::test::read_text(frame);
  const auto line = text.find("\n", text.find("\n") + 1) + 1; // first vertex line
  text.replace(line, text.find(' ', line) - line, "3e60");
  write_text(frame, text);
  expect_error_containing("deform --shell " + quoted(shell) + " --base " + quoted(frame) + " -o " +
                              quoted(dir.file("out")),
                          frame + ": vertex 0 has a coordinate of magnitude 3e+60; gshell needs |x| < 1e+50");
  EXPECT_FALSE(std::filesystem::exists(dir.file("out")));
}

TEST(CliMessages, HugeButAcceptedThicknessesAreWrittenWithAnExponent) {
  // A top 1e30 times its base's size (allowed: below 1e50) is 1e31 eta away: a figure, not 32 digits.
  TempDir dir;
  const std::string shell = dir.file("shell"), far = dir.file("far.obj");
  ASSERT_EQ(run_cli("generate builtin:sphere:1 -o " + quoted(shell) + " --thickness-ratio 0.05 -q").exit_code, 0);
  write_text(far, scaled_obj(gshell::test::read_text(shell + "/top.obj"), 1e30));
  const auto r = run_cli("metrics " + quoted(shell + "/base.obj") + " " + quoted(far) + " --thickness-ratio 0.05");
  const std::size_t line = r.out.find("thickness    min ");
  ASSERT_NE(line, std::string::npos) << r.out << r.err;
  const std::string text = r.out.substr(line, r.out.find('\n', line) - line);
  EXPECT_NE(text.find("e+"), std::string::npos) << text;
  EXPECT_LT(text.size(), 100u) << text; // fixed point: 33 digits each
}

TEST(CliMessages, IterationCountsShareOneWordingAndHandlesNameTheirFile) {
  // generate and deform keep their start at 0 iterations; a pose needs one to meet its handles.
  TempDir dir;
  const std::string shell = dir.file("shell"), frame = dir.file("frame.off"), handles = dir.file("handles.json");
  ASSERT_EQ(run_cli("generate builtin:sphere:1 -o " + quoted(shell) + " --thickness-ratio 0.05 -q").exit_code, 0);
  ASSERT_EQ(run_cli("convert builtin:sphere:1 " + quoted(frame) + " -q").exit_code, 0);
  write_text(handles, R"({"handles": [{"vertices": [0], "translate": [0, 0, 0.01]}, {"vertices": [5]}]})");
  const std::string out = " -o " + quoted(dir.file("out"));
  expect_error_line("generate builtin:sphere:1 --thickness-ratio 0.05 --iterations -1" + out,
                    "--iterations must be >= 0 (got -1; 0 keeps the start)");
  expect_error_line("deform --shell " + quoted(shell) + " --base " + quoted(frame) + " --iterations -2" + out,
                    "--iterations must be >= 0 (got -2; 0 keeps the start)");
  expect_error_line("pose --shell " + quoted(shell) + " --handles " + quoted(handles) + " --iterations 0" + out,
                    "--iterations must be >= 1 (got 0; the targets are reached by iterating)");
  EXPECT_EQ(run_cli("-q generate builtin:sphere:1 --thickness-ratio 0.05 --iterations 0" + out).exit_code, 0);
  EXPECT_EQ(run_cli("-q deform --shell " + quoted(shell) + " --base " + quoted(frame) + " " + quoted(frame) +
                    " --iterations 0 -o " +
                    quoted(dir.file("deformed")))
                .exit_code,
            0);
  // A handle file for a sequence of frames names the file, not the code that found it out.
  expect_error_line("-q view " + quoted(dir.file("deformed")) + " --handles " + quoted(handles) + " --port 0",
                    handles + ": handles pose a single shell, and " + dir.file("deformed") +
                        " is a sequence of frames (a deform output)");
  // What needs no shell is checked before one is generated: the error is the only line (without
  // -q, a generation would have printed its progress first).
  const std::string garbage = dir.file("garbage.json");
  write_text(garbage, "garbage");
  expect_error_containing("view builtin:sphere:3 --thickness-ratio 0.05 --port 0 --handles " + quoted(garbage),
                          garbage + ": not valid JSON");
  expect_error_line("view builtin:sphere:3 --thickness-ratio 0.05 --port 0 --handles " + quoted(dir.file("none.json")),
                    dir.file("none.json") + ": cannot open handle file");
  expect_error_containing("view builtin:sphere:3 --thickness-ratio 0.05 --port 0 --host 10.255.255.254",
                          "cannot listen on 10.255.255.254:0");
}

TEST(CliMessages, HugeCoordinatesInShellFoldersAndHandlesSayTheyAreTooLarge) {
  // The positions of metrics' top, a shell folder's surfaces and a handle's translation are not
  // validated as a surface, but 1e150 must still be "too large", not an overflow further on.
  TempDir dir;
  const std::string shell = dir.file("shell"), huge = dir.file("huge");
  ASSERT_EQ(run_cli("generate builtin:sphere:1 -o " + quoted(shell) + " --thickness-ratio 0.05 -q").exit_code, 0);
  std::filesystem::copy(shell, huge);
  for (const std::string name : {"/base.obj", "/top.obj"})
    write_text(huge + name, scaled_obj(gshell::test::read_text(shell + name), 1e150));
  const std::string too_large = "; gshell needs |x| < 1e+50 (volumes and products of lengths would overflow)";
  const std::string out = " -o " + quoted(dir.file("out"));

  expect_error_containing("metrics " + quoted(shell + "/base.obj") + " " + quoted(huge + "/top.obj") +
                              " --thickness-ratio 0.05",
                          huge + "/top.obj: vertex 0 has a coordinate of magnitude "); // 1e150 x (1 + eta)
  // Vertex 0 of the icosphere: (-1, phi, 0) / |(1, phi)|, phi the golden ratio.
  expect_error_containing("metrics " + quoted(huge + "/base.obj") + " " + quoted(huge + "/top.obj") +
                              " --thickness-ratio 0.05",
                          huge + "/base.obj: vertex 0 has a coordinate of magnitude 8.51e+149" + too_large);
  expect_error_line("deform --shell " + quoted(huge) + " --base " + quoted(shell + "/base.obj") + out,
                    huge + "/base.obj: vertex 0 has a coordinate of magnitude 8.51e+149" + too_large);
  const std::string handles = dir.file("handles.json");
  write_text(handles, R"({"handles": [{"vertices": [0], "translate": [0, 0, 0.01]}, {"vertices": [5]}]})");
  expect_error_line("pose --shell " + quoted(huge) + " --handles " + quoted(handles) + out,
                    huge + "/base.obj: vertex 0 has a coordinate of magnitude 8.51e+149" + too_large);
  write_text(handles, R"({"handles": [{"vertices": [0], "translate": [0, 0, 1e150]}, {"vertices": [5]}]})");
  expect_error_line("pose --shell " + quoted(shell) + " --handles " + quoted(handles) + out,
                    handles + ": handle 0: translate: a coordinate of magnitude 1e+150" + too_large);
  EXPECT_FALSE(std::filesystem::exists(dir.file("out")));
}

TEST(CliMessages, OptionsThatWouldBeIgnoredAreErrors) {
  TempDir dir;
  const std::string out = " -o " + quoted(dir.file("out"));
  expect_error_line("generate builtin:sphere:1 --thickness-ratio 0.05 --s-min 0.8" + out,
                    "--s-min applies only to --method curvature");
  expect_error_line("generate builtin:sphere:1 --thickness-ratio 0.05 --method offset --s-max 1.5" + out,
                    "--s-max applies only to --method curvature");
  // The offset is not optimised; the unguarded run is the plain iteration from the plain offset.
  for (const char* flag : {"--iterations 3", "--tolerance 1e-3", "--anderson 2", "--start-smoothing 0.1", "--allow-invalid"})
    expect_error_line("generate builtin:sphere:1 --thickness-ratio 0.05 --method offset " + std::string(flag) + out,
                      std::string(flag).substr(0, std::string(flag).find(' ')) +
                          " applies only to --method rigid or curvature");
  for (const char* flag : {"--anderson 2", "--start-smoothing 0.1"})
    expect_error_line("generate builtin:sphere:1 --thickness-ratio 0.05 --allow-invalid " + std::string(flag) + out,
                      std::string(flag).substr(0, std::string(flag).find(' ')) +
                          " applies only to guarded runs (not with --allow-invalid)");
  expect_error_line("pose --shell " + quoted(dir.file("no_shell")) + " --handles h.json --solver single --levels 3" + out,
                    "--levels applies only to --solver hierarchical");
  expect_error_line("view builtin:plane:4 --solver single --levels 3", "--levels applies only to --solver hierarchical");
  expect_error_line("animate builtin:plane:4 --twist 30 --band 0.5" + out,
                    "--band applies only to --bend (a twist turns the whole axis)");
  // animate checks its folder before making any frame (it made them all, then refused the folder).
  std::filesystem::create_directory(dir.file("taken"));
  write_text(dir.file("taken/notes.txt"), "");
  expect_error_line("animate builtin:plane:4 --bend 30 --frames 3 -o " + quoted(dir.file("taken")),
                    dir.file("taken") + ": exists and holds files gshell does not write there (notes.txt), which "
                                        "replacing the folder would delete; move them, remove the folder or choose another output folder");
  std::filesystem::remove_all(dir.file("taken"));
  EXPECT_EQ(count_entries(dir.path()), 0);
  // The curvature method takes them, and a bend its band.
  EXPECT_EQ(run_cli("generate builtin:sphere:1 --thickness-ratio 0.05 --method curvature --s-min 0.8 -q" + out).exit_code, 0);
  EXPECT_EQ(run_cli("animate builtin:plane:4 --bend 30 --band 0.5 --frames 2 -q -o " + quoted(dir.file("frames"))).exit_code, 0);
  // render and convert as well.
  const std::string png = " -o " + quoted(dir.file("x.png"));
  expect_error_line("convert builtin:plane:4 " + quoted(dir.file("x.obj")) + " --ascii", "--ascii applies only to a .ply output");
  const std::string uncolored =
      "--max applies only to colored renders (--color none colors nothing, --color auto no plain surface)";
  expect_error_line("render builtin:plane:4 --color none --max 0.2" + png, uncolored);
  expect_error_line("render builtin:plane:4 --max 0.2" + png, uncolored);
  expect_error_line("render builtin:plane:4 --frame-each" + png, "--frame-each applies only to two or more inputs (panels)");
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.png")));
  EXPECT_EQ(run_cli("-q convert builtin:plane:4 " + quoted(dir.file("x.ply")) + " --ascii").exit_code, 0);
  ASSERT_EQ(run_cli("-q generate builtin:sphere:1 --thickness-ratio 0.05 -o " + quoted(dir.file("shell"))).exit_code, 0);
  const auto shell_render = run_cli("-q render " + quoted(dir.file("shell")) + " --max 0.2" + png);
  EXPECT_EQ(shell_render.exit_code, 0) << shell_render.err;
}

TEST(CliMessages, ValuesAreShownAsGivenAndOutputsNamedAsWritten) {
  TempDir dir;
  const std::string png = dir.file("x.png");
  // 36001 was shown as "3.6e+04", and a 6-digit size as not being WIDTHxHEIGHT at all.
  expect_error_containing("animate builtin:plane:4 --twist 36001 -o " + quoted(dir.file("a")), "(100 turns; got 36001)");
  expect_error_line("render builtin:sphere:1 -o " + quoted(png) + " --size 100000x100000",
                    "--size 100000x100000: width and height must be in [32, 8192]");
  expect_error_line("render builtin:sphere:1 -o " + quoted(png) + " --size 99999999999999999999x64",
                    "--size 99999999999999999999x64: width and height must be in [32, 8192]");
  // render writes PNG whatever the name says: any other name is refused.
  expect_error_line("render builtin:sphere:1 -o " + quoted(dir.file("x.jpg")),
                    dir.file("x.jpg") + ": the output is written as png: give it a .png name");
  EXPECT_EQ(count_entries(dir.path()), 0);
  EXPECT_EQ(run_cli("render builtin:sphere:1 --size 64x64 -q -o " + quoted(dir.file("x.PNG"))).exit_code, 0);
}

TEST(CliMessages, NoOutputIsWrittenOverAnInputOrAFileOfAShellFolder) {
  // `report DIR -o DIR/report.json` turned the shell's report into HTML, `texture -o DIR/top.obj`
  // replaced its top, `metrics BASE TOP -o TOP` wrote JSON over the top it measured.
  TempDir dir;
  const std::string shell = dir.file("plane"), base = shell + "/base.obj", top = shell + "/top.obj";
  ASSERT_EQ(run_cli("generate builtin:plane:4 --thickness-ratio 0.05 -q -o " + quoted(shell)).exit_code, 0);
  const std::string report = gshell::test::read_text(shell + "/report.json"), top_text = gshell::test::read_text(top);
  const std::string breaks = ": is a file of a gshell output folder, which this command would break; write the output elsewhere";
  expect_error_line("report " + quoted(shell) + " --no-renders -o " + quoted(dir.file("page.txt")),
                    dir.file("page.txt") + ": the output is written as html: give it a .html name");
  expect_error_line("report " + quoted(shell) + " --no-renders -o " + quoted(shell + "/report.json"),
                    shell + "/report.json: the output is written as html: give it a .html name");
  expect_error_line("texture --shell " + quoted(shell) + " --tile builtin:bumps:4 -o " + quoted(top), top + breaks);
  expect_error_line("metrics " + quoted(base) + " " + quoted(top) + " --thickness-ratio 0.05 -o " + quoted(shell + "/report.json"),
                    shell + "/report.json" + breaks);
  expect_error_line("convert builtin:plane:4 " + quoted(base), base + breaks);
  const std::string tile = dir.file("tile.obj");
  ASSERT_EQ(run_cli("convert builtin:plane:2 " + quoted(tile)).exit_code, 0);
  expect_error_line("texture --shell " + quoted(shell) + " --tile " + quoted(tile) + " -o " + quoted(tile),
                    tile + ": is an input of this command (" + tile + "); write the output elsewhere");
  EXPECT_EQ(gshell::test::read_text(shell + "/report.json"), report);
  EXPECT_EQ(gshell::test::read_text(top), top_text);
  // A report.json nested 100,000 deep crashed the HTML report (its formatting recurses).
  const std::string deep = dir.file("deep");
  std::filesystem::create_directory(deep);
  std::filesystem::copy(base, deep + "/base.obj");
  std::filesystem::copy(top, deep + "/top.obj");
  write_text(deep + "/report.json", "{\"command\": \"generate\", \"x\": " + std::string(100000, '[') + "1" +
                                        std::string(100000, ']') + "}");
  expect_error_line("report " + quoted(deep) + " --no-renders -o " + quoted(dir.file("deep.html")),
                    deep + "/report.json: nested deeper than 64 levels");
  // Other files into the folder are fine: the README writes the HTML report beside the shell.
  EXPECT_EQ(run_cli("report " + quoted(shell) + " --no-renders -q -o " + quoted(shell + "/report.html")).exit_code, 0);
  EXPECT_EQ(run_cli("metrics " + quoted(base) + " " + quoted(top) + " --thickness-ratio 0.05 -o " + quoted(dir.file("m.json"))).exit_code, 0);
}

// A file output whose folder is missing, or that is a folder, is named before any work, as the
// folder outputs are (curvature of bunny00 with wide rings ran 7 s, then found no such folder;
// a folder given as the PNG printed a progress line before its error).
TEST(CliMessages, AFileOutputThatCannotBeWrittenThereIsNamedBeforeTheWork) {
  TempDir dir;
  const std::string missing = dir.file("nodir");
  expect_error_line("curvature builtin:sphere:3 -o " + quoted(missing + "/k.ply"), missing + "/k.ply: parent folder does not exist");
  expect_error_line("render builtin:sphere:3 -o " + quoted(missing + "/r.png"), missing + "/r.png: parent folder does not exist");
  expect_error_line("convert builtin:sphere:3 " + quoted(missing + "/s.obj"), missing + "/s.obj: parent folder does not exist");
  std::filesystem::create_directory(dir.file("k.ply"));
  expect_error_line("curvature builtin:sphere:3 -o " + quoted(dir.file("k.ply")), dir.file("k.ply") + ": is a directory, expected a file name");
  write_text(dir.file("afile"), "x");
  expect_error_line("texture --shell x --tile builtin:bumps:4 -o " + quoted(dir.file("afile") + "/t.obj"),
                    dir.file("afile") + "/t.obj: parent " + dir.file("afile") + " is not a folder");
}

TEST(CliMessages, TextureCoordinatesAndTexturesNameTheirFile) {
  TempDir dir;
  // A tetrahedron whose second texture coordinate is NaN: an error of the mesh, named by its file.
  const std::string nan_uv = dir.file("nan_uv.obj");
  write_text(nan_uv, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt nan 0\nvt 0 1\nvt 1 1\n"
                     "f 1/1 3/3 2/2\nf 1/1 2/2 4/4\nf 1/1 4/4 3/3\nf 2/2 3/3 4/4\n");
  const std::string message = nan_uv + ": texture coordinate 1 is not finite (NaN or infinity)";
  expect_error_line("generate " + quoted(nan_uv) + " --thickness-ratio 0.05 -o " + quoted(dir.file("s")), message);
  expect_error_line("convert " + quoted(nan_uv) + " " + quoted(dir.file("c.obj")), message);
  // Texture coordinates on only some faces are dropped, with a warning that says so.
  const std::string partial = dir.file("partial.obj");
  write_text(partial, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\n"
                      "f 1/1 3/3 2/2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  const std::string dropped = "3 of 4 faces have no texture coordinates: all are dropped";
  const auto info = run_cli("info " + quoted(partial));
  EXPECT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("  warning: " + dropped), std::string::npos) << info.out;
  const auto made = run_cli("generate " + quoted(partial) + " --thickness-ratio 0.05 -o " + quoted(dir.file("ps")));
  EXPECT_EQ(made.exit_code, 0) << made.err;
  EXPECT_NE(made.err.find("gshell generate: warning: " + partial + ": " + dropped), std::string::npos) << made.err;

  const std::string shell = dir.file("plane"), tiled = " -o " + quoted(dir.file("t.obj"));
  ASSERT_EQ(run_cli("generate builtin:plane:4 --thickness-ratio 0.05 -q -o " + quoted(shell)).exit_code, 0);
  // A tile or a detail mesh is carried into an output: a NaN texture coordinate is an error (it
  // was written out as `vt nan`), data it holds that the output does not (normals, materials)
  // and a partial set of texture coordinates are warnings (they were dropped without a word).
  expect_error_line("texture --shell " + quoted(shell) + " --tile " + quoted(nan_uv) + tiled, message);
  const std::string deformed = " -o " + quoted(dir.file("d")) + " --embed ";
  const std::string deform = "deform --shell " + quoted(shell) + " --base " + quoted(shell + "/base.obj");
  expect_error_line(deform + deformed + quoted(nan_uv), message);
  expect_error_line(deform + deformed + "''", "--embed: the detail mesh's name is empty");
  const std::string normals = dir.file("normals.obj");
  write_text(normals, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\n"
                      "f 1//1 3//1 2//1\nf 1//1 2//1 4//1\nf 1//1 4//1 3//1\nf 2//1 3//1 4//1\n");
  const auto carried = run_cli(deform + deformed + quoted(normals) + " -q");
  EXPECT_EQ(carried.exit_code, 0) << carried.err;
  EXPECT_NE(carried.err.find("gshell deform: warning: " + normals + ": its normals are not carried into detail.obj"),
            std::string::npos) << carried.err;
  const auto partly = run_cli("texture --shell " + quoted(shell) + " --tile " + quoted(partial) + tiled + " -q");
  EXPECT_EQ(partly.exit_code, 0) << partly.err;
  EXPECT_NE(partly.err.find("gshell texture: warning: " + partial + ": " + dropped), std::string::npos) << partly.err;
  std::filesystem::remove(dir.file("t.obj"));
  // Into a PLY: normals are dropped and the texture coordinates too, which only OBJ holds; both said.
  const std::string uv_normals = dir.file("uv_normals.obj");
  write_text(uv_normals, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\n"
                         "f 1/1/1 3/3/1 2/2/1\nf 1/1/1 2/2/1 4/1/1\nf 1/1/1 4/1/1 3/3/1\nf 2/2/1 3/3/1 4/1/1\n");
  const std::string ply = dir.file("t.ply");
  const auto into_ply = run_cli("texture --shell " + quoted(shell) + " --tile " + quoted(uv_normals) + " -o " +
                                quoted(ply) + " -q");
  EXPECT_EQ(into_ply.exit_code, 0) << into_ply.err;
  EXPECT_NE(into_ply.err.find(uv_normals + ": its normals are not carried into " + ply + " (positions and faces are)"),
            std::string::npos)
      << into_ply.err;
  EXPECT_NE(into_ply.err.find(uv_normals + ": its texture coordinates are not written to " + ply +
                              " (only OBJ holds them)"),
            std::string::npos)
      << into_ply.err;
  expect_error_line("texture --shell " + quoted(shell) + " --tile builtin:sphere:1" + tiled,
                    "builtin:sphere:1: unknown tile (built-in tiles: builtin:bumps[:N])");
  expect_error_containing("texture --shell " + quoted(shell) + " --tile builtin:bumps:4 --repeat 100000 100000" + tiled,
                          shell + ": 100000 x 100000 tiles of 25 vertices");
  // A NaN texture coordinate in the folder's base.obj, named by that file.
  std::string base = gshell::test::read_text(shell + "/base.obj");
  const auto vt = base.find("\nvt ");
  ASSERT_NE(vt, std::string::npos);
  base.replace(vt + 1, base.find('\n', vt + 1) - vt - 1, "vt nan 0");
  write_text(shell + "/base.obj", base);
  expect_error_line("texture --shell " + quoted(shell) + " --tile builtin:bumps:4" + tiled,
                    shell + "/base.obj: texture coordinate 0 is not finite (NaN or infinity)");
  EXPECT_FALSE(std::filesystem::exists(dir.file("t.obj")));
}

TEST(CliMessages, ProgressInALogIsOneLinePerUpdate) {
  // run_cli's stderr is a file, not a terminal: the status line of a terminal becomes one line per
  // update (animate: deform_cli_test).
  TempDir dir;
  const std::string shell = dir.file("shell"), frames = dir.file("frames");
  const auto generate = run_cli("generate builtin:sphere:2 -o " + quoted(shell) +
                                " --thickness-ratio 0.05 --tolerance 0 --iterations 3");
  ASSERT_EQ(generate.exit_code, 0) << generate.err;
  expect_log_lines(generate.err, "generate", 4); // the input line and 3 iterations
  ASSERT_EQ(run_cli("animate " + quoted(shell + "/base.obj") + " --bend 30 --frames 3 -o " + quoted(frames) + " -q").exit_code, 0);
  const auto deform = run_cli("deform --shell " + quoted(shell) + " --base " + quoted(frames + "/frame_0001.obj") + " " +
                              quoted(frames + "/frame_0002.obj") + " " + quoted(frames + "/frame_0003.obj") + " -o " +
                              quoted(dir.file("deformed")));
  ASSERT_EQ(deform.exit_code, 0) << deform.err;
  expect_log_lines(deform.err, "deform", 4); // the setup line and 3 frames
  const std::string handles = dir.file("handles.json");
  write_text(handles, R"({"handles": [{"vertices": [0], "translate": [0, 0, 0.05]}, {"vertices": [5]}]})");
  const auto pose = run_cli("pose --shell " + quoted(shell) + " --handles " + quoted(handles) + " --steps 2 -o " +
                            quoted(dir.file("posed")));
  ASSERT_EQ(pose.exit_code, 0) << pose.err;
  expect_log_lines(pose.err, "pose", 3); // the setup line and 2 steps
}

TEST(CliMessages, OnATerminalTheInputIsNamedWhileItIsReadAndGivesWayToWhatFollows) {
  // Reading a 5M-face input takes seconds; a terminal showed nothing then. util-linux's `script`
  // gives the run a terminal and keeps what it wrote, escape sequences included.
  TempDir dir;
  const auto on_terminal = [&](const std::string& args) {
    const std::string typescript = dir.file("typescript");
    const std::string cmd = "script -qec " + quoted("\"" GSHELL_CLI_PATH "\" " + args) + " " + quoted(typescript) +
                            " >/dev/null 2>&1";
    EXPECT_NE(std::system(cmd.c_str()), -1);
    return gshell::test::read_text(typescript);
  };
  const std::string clear = "\r\033[K";
  const std::string shell = dir.file("shell");
  const std::string made = on_terminal("generate builtin:sphere:2 --thickness-ratio 0.05 -o \"" + shell + "\"");
  const auto reading = made.find("gshell generate: reading builtin:sphere:2...");
  ASSERT_NE(reading, std::string::npos) << made;
  EXPECT_EQ(made.find(clear + "gshell generate: builtin:sphere:2 (162 vertices", reading), made.find(clear, reading))
      << made; // the status line is cleared, then the input's line
  const std::string posed = on_terminal("pose --shell \"" + shell + "\" --handles \"" + dir.file("missing.json") +
                                        "\" -o \"" + dir.file("posed") + "\"");
  const auto pose_reading = posed.find("gshell pose: reading " + shell + "...");
  ASSERT_NE(pose_reading, std::string::npos) << posed;
  EXPECT_EQ(posed.find(clear + "gshell: error: "), posed.find(clear, pose_reading)) << posed;
  // The error line stands alone on a terminal as in a log (the status cleared first).
  const std::string missing = on_terminal("deform --shell \"" + dir.file("nothing") + "\" --base builtin:sphere:2 -o \"" +
                                          dir.file("deformed") + "\"");
  EXPECT_NE(missing.find("gshell deform: reading " + dir.file("nothing") + "..." + clear + "gshell: error: "),
            std::string::npos)
      << missing;
}

TEST(CliMessages, AWriteThatFailsNamesTheOutputNotItsHiddenStagingFolder) {
  // Past a file size limit (as on a full disk) the write fails: one line naming the file in the
  // folder asked for (it named "./.big.tmp-141687477/shell.vtu"), exit 1, nothing left behind.
  TempDir dir;
  const std::string cmd = "cd " + quoted(dir.path().string()) + " && ulimit -f 64 && '" GSHELL_CLI_PATH
                          "' generate builtin:sphere:5 --thickness-ratio 0.02 -o big --quiet 2>err";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);
  const std::string err = gshell::test::read_text(dir.file("err"));
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_NE(err.find(": big/"), std::string::npos) << err;
  EXPECT_NE(err.find("write failed"), std::string::npos) << err;
  EXPECT_EQ(err.find(".tmp"), std::string::npos) << err;
  EXPECT_EQ(count_entries(dir.path()), 1); // err alone
}

TEST(CliMessages, FileNamesThatAreNotUtf8AreWrittenIntoJsonWithReplacementCharacters) {
  // Linux file names are bytes: a Latin-1 folder name made `info --json`, `generate` (after all
  // its work) and `deform` end in "internal error: [json.exception.type_error.316]".
  TempDir dir;
  const std::string latin1 = dir.file("lat\xe9"), mesh = latin1 + "/m\xff.off";
  std::filesystem::create_directory(latin1);
  ASSERT_EQ(run_cli("convert builtin:sphere:1 " + quoted(mesh) + " -q").exit_code, 0);
  const auto info = run_cli("info " + quoted(mesh) + " --json");
  EXPECT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("m\xef\xbf\xbd.off"), std::string::npos) << info.out; // U+FFFD
  const auto generated = run_cli("generate " + quoted(mesh) + " --thickness-ratio 0.05 -q -o " + quoted(latin1 + "/sh"));
  ASSERT_EQ(generated.exit_code, 0) << generated.err;
  EXPECT_NE(gshell::test::read_text(latin1 + "/sh/report.json").find("lat\xef\xbf\xbd/m\xef\xbf\xbd.off"),
            std::string::npos);
  const auto deformed = run_cli("deform --shell " + quoted(latin1 + "/sh") + " --base " + quoted(mesh) + " -q -o " +
                                quoted(latin1 + "/def"));
  EXPECT_EQ(deformed.exit_code, 0) << deformed.err;
  EXPECT_EQ(run_cli("report " + quoted(latin1 + "/sh") + " -q -o " + quoted(latin1 + "/r.html")).exit_code, 0);
  // The page is XHTML: it names the folder with U+FFFD too (it copied the raw bytes, which
  // browsers' XML parser refuses).
  const std::string page = gshell::test::read_text(latin1 + "/r.html");
  EXPECT_NE(page.find("lat\xef\xbf\xbd/sh"), std::string::npos);
  EXPECT_EQ(page.find("lat\xe9"), std::string::npos);
}

TEST(CliMessages, ConvertSaysWhenTextureCoordinatesAreDropped) {
  TempDir dir;
  const std::string obj = dir.file("uv.obj");
  write_text(obj, "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nf 1/1 2/2 3/3\n");
  const auto to_ply = run_cli("convert " + quoted(obj) + " " + quoted(dir.file("uv.ply")));
  EXPECT_EQ(to_ply.exit_code, 0) << to_ply.err;
  EXPECT_NE(to_ply.err.find(obj + ": its texture coordinates are not written to " + dir.file("uv.ply") +
                            " (only OBJ holds them)"),
            std::string::npos)
      << to_ply.err;
  const auto to_obj = run_cli("convert " + quoted(obj) + " " + quoted(dir.file("copy.OBJ")));
  EXPECT_EQ(to_obj.exit_code, 0) << to_obj.err;
  EXPECT_EQ(to_obj.err.find("warning"), std::string::npos) << to_obj.err;
}
