// `gshell convert`: good conversions exit 0 and keep the mesh exactly; bad inputs and outputs
// exit 1 with one line on stderr naming the file, and leave no output file behind.
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/io/read_mesh.h>
#include <gshell/io/write_mesh.h>

#include "shell_fixtures.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

using namespace gshell;
using gshell::test::count_entries;
using gshell::test::run_cli;
using gshell::test::TempDir;
using gshell::test::write_text;

namespace {

std::string shell_quoted(const std::string& s) { return "'" + s + "'"; }

int count_lines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

TEST(ConvertCli, ConvertsBetweenAllFormatsKeepingTheMesh) {
  TempDir dir;
  const TriMesh torus = make_torus(16);
  write_mesh(dir.file("in.obj"), torus);
  std::string previous = dir.file("in.obj");
  for (const std::string name : {"a.ply", "b.off", "c.obj", "d.ply"}) {
    const std::string out = dir.file(name);
    const auto r = run_cli("convert " + shell_quoted(previous) + " " + shell_quoted(out) + (name == "d.ply" ? " --ascii" : ""));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const TriMesh m = read_mesh(out);
    EXPECT_TRUE(m.V == torus.V) << name;
    EXPECT_TRUE(m.F == torus.F) << name;
    previous = out;
  }
  // OBJ to OBJ keeps the texture coordinates.
  ASSERT_EQ(run_cli("convert " + shell_quoted(dir.file("in.obj")) + " " + shell_quoted(dir.file("uv.obj"))).exit_code, 0);
  const TriMesh uv = read_mesh(dir.file("uv.obj"));
  EXPECT_TRUE(uv.has_uv() && uv.UV == torus.UV && uv.FUV == torus.FUV);
}

TEST(ConvertCli, SaysWhichDataOfTheInputItDoesNotWrite) {
  TempDir dir;
  write_text(dir.file("c.off"), "COFF\n3 1 0\n0 0 0 1 0 0 1\n1 0 0 1 0 0 1\n0 1 0 1 0 0 1\n3 0 1 2 255 0 0\n");
  const auto r = run_cli("convert " + shell_quoted(dir.file("c.off")) + " " + shell_quoted(dir.file("c.obj")));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("c.off: its vertex colors and face colors are not written to"), std::string::npos) << r.err;
  const auto plain = run_cli("convert builtin:sphere:1 " + shell_quoted(dir.file("s.off")));
  EXPECT_EQ(plain.err.find("not written"), std::string::npos) << plain.err;
}

TEST(ConvertCli, AcceptsBuiltinInputAndQuietMode) {
  TempDir dir;
  const auto r = run_cli("convert builtin:sphere:2 " + shell_quoted(dir.file("s.ply")) + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  EXPECT_TRUE(read_mesh(dir.file("s.ply")).V == make_sphere(2).V);
  const auto loud = run_cli("convert builtin:sphere:2 " + shell_quoted(dir.file("t.off")));
  EXPECT_EQ(loud.exit_code, 0);
  EXPECT_NE(loud.err.find("162 vertices"), std::string::npos) << loud.err;
}

TEST(ConvertCli, BadInputsExitOneWithOneLineAndNoOutput) {
  TempDir inputs, outputs;
  const std::string valid_vertices = "0 0 0\n1 0 0\n0 1 0\n";
  struct Case {
    std::string name, content;
  };
  const std::vector<Case> cases = {
      {"truncated.off", "OFF\n3 1 0\n" + valid_vertices},
      {"garbage.ply", std::string("\x01\x02\x03 not a mesh \xff", 17)},
      {"wrong_counts.off", "OFF\n3 1 0\n" + valid_vertices + "3 0 1 2\n3 0 2 1\n"},
      {"bad_number.obj", "v 0 0 0\nv 1 0 0\nv 0 1 x\nf 1 2 3\n"},
      {"short.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                    "property float z\nend_header\n" + std::string(30, '\0')},
      {"huge.off", "OFF\n1000000000 1000000000 0\n" + valid_vertices},
      {"nan.obj", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n"},          // read fine, refused by validation
      {"nonmanifold.off", "OFF\n5 3 0\n0 0 0\n1 0 0\n0 1 0\n0 -1 0\n0 0 1\n3 0 1 2\n3 1 0 3\n3 0 1 4\n"},
      {"unknown.xyz", "0 0 0\n"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string in = inputs.file(c.name);
    write_text(in, c.content);
    const auto r = run_cli("convert " + shell_quoted(in) + " " + shell_quoted(outputs.file("out.ply")));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(c.name), std::string::npos) << r.err;
    EXPECT_EQ(count_entries(outputs.path()), 0) << "output or temporary left behind";
  }
  const auto missing = run_cli("convert " + shell_quoted(inputs.file("missing.obj")) + " " + shell_quoted(outputs.file("o.obj")));
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("missing.obj"), std::string::npos);
  EXPECT_EQ(count_entries(outputs.path()), 0);
}

TEST(ConvertCli, BadOutputsExitOneAndLeaveNothing) {
  TempDir dir;
  // builtin:torus has texture coordinates, which only OBJ keeps: the format's error comes alone,
  // not after a warning that they would be dropped.
  for (const std::string out : {"x.stl", "x.abc", "no/such/folder/x.obj"}) {
    const auto r = run_cli("convert builtin:torus " + shell_quoted(dir.file(out)));
    EXPECT_EQ(r.exit_code, 1) << out << ": " << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(dir.file(out)), std::string::npos) << r.err;
  }
  EXPECT_EQ(count_entries(dir.path()), 0);
  const auto usage = run_cli("convert builtin:sphere:1");
  EXPECT_EQ(usage.exit_code, 1);
}

// A triangle soup (every face with its own vertices, as some exporters write OBJ) is a surface cut
// along every edge: `generate` (and every command reading a surface) warns of it and names the cure, `convert --weld` applies it, and the
// welded sphere's shell is valid.
TEST(ConvertCli, WeldJoinsATriangleSoupThatGenerateWarnsOf) {
  TempDir dir;
  const TriMesh sphere = make_sphere(2);
  const TriMesh soup = gshell::test::triangle_soup(sphere);
  write_mesh(dir.file("soup.obj"), soup);
  const auto cut = run_cli("generate " + shell_quoted(dir.file("soup.obj")) + " -o " + shell_quoted(dir.file("cut")) +
                           " --thickness-ratio 0.05 --quiet");
  EXPECT_EQ(cut.exit_code, 0) << cut.err;
  EXPECT_NE(cut.err.find("soup.obj: vertices "), std::string::npos) << cut.err;
  EXPECT_NE(cut.err.find("convert --weld"), std::string::npos) << cut.err;
  const auto animate = run_cli("animate " + shell_quoted(dir.file("soup.obj")) + " --twist 10 --frames 1 -o " +
                               shell_quoted(dir.file("frames")) + " --quiet");
  EXPECT_EQ(animate.exit_code, 0) << animate.err;
  EXPECT_NE(animate.err.find("gshell animate: warning: " + dir.file("soup.obj") + ": vertices "), std::string::npos)
      << animate.err;
  const auto weld = run_cli("convert " + shell_quoted(dir.file("soup.obj")) + " " + shell_quoted(dir.file("w.obj")) + " --weld");
  ASSERT_EQ(weld.exit_code, 0) << weld.err;
  EXPECT_NE(weld.err.find("welded " + std::to_string(soup.V.rows() - sphere.V.rows()) + " vertices"), std::string::npos)
      << weld.err;
  EXPECT_EQ(read_mesh(dir.file("w.obj")).V.rows(), sphere.V.rows());
  const auto whole = run_cli("generate " + shell_quoted(dir.file("w.obj")) + " -o " + shell_quoted(dir.file("whole")) +
                             " --thickness-ratio 0.05 --quiet");
  EXPECT_EQ(whole.exit_code, 0) << whole.err;
  EXPECT_TRUE(whole.err.empty()) << whole.err;
  EXPECT_NE(whole.out.find("valid        yes"), std::string::npos) << whole.out;
}

} // namespace
