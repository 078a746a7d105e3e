// `gshell curvature`: PLY properties with the analytic values, errors leave nothing behind.
#include "test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <sstream>
#include <string>
#include <vector>

using namespace gshell::test;

namespace {

/// Scalar properties of one element of an ASCII PLY file, by name (list properties skipped).
using Columns = std::map<std::string, std::vector<double>>;

/// Minimal ASCII PLY reader for the test: element name -> property name -> values.
std::map<std::string, Columns> read_ascii_ply_properties(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  struct Property { std::string name; bool list; };
  struct Element { std::string name; long count; std::vector<Property> props; };
  std::vector<Element> elements;
  std::getline(in, line);
  EXPECT_EQ(line.rfind("ply", 0), 0u);
  while (std::getline(in, line) && line.rfind("end_header", 0) != 0) {
    std::istringstream words(line);
    std::string kind;
    words >> kind;
    if (kind == "format") {
      std::string format;
      words >> format;
      EXPECT_EQ(format, "ascii");
    } else if (kind == "element") {
      Element e;
      words >> e.name >> e.count;
      elements.push_back(e);
    } else if (kind == "property") {
      std::string type, name;
      words >> type;
      if (type == "list") {
        std::string count_type, item_type;
        words >> count_type >> item_type >> name;
        elements.back().props.push_back({name, true});
      } else {
        words >> name;
        elements.back().props.push_back({name, false});
      }
    }
  }
  std::map<std::string, Columns> result;
  for (const Element& e : elements) {
    Columns& columns = result[e.name];
    for (long i = 0; i < e.count; ++i)
      for (const Property& p : e.props) {
        if (p.list) {
          int n = 0;
          in >> n;
          for (int k = 0; k < n; ++k) {
            double skip;
            in >> skip;
          }
        } else {
          double value;
          in >> value;
          columns[p.name].push_back(value);
        }
      }
  }
  EXPECT_TRUE(in) << "PLY body shorter than its header says";
  return result;
}

} // namespace

TEST(CurvatureCli, WritesFaceAndVertexCurvatureOfASphere) {
  TempDir dir;
  const std::string out = dir.file("sphere.ply");
  // builtin:sphere is the unit sphere: k1 = k2 = mean = gauss = 1.
  const CliResult r = run_cli("curvature builtin:sphere:4 -o '" + out + "' --ascii --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  const auto ply = read_ascii_ply_properties(read_text(out));
  ASSERT_TRUE(ply.count("face") && ply.count("vertex"));
  for (const char* element : {"face", "vertex"}) {
    const Columns& c = ply.at(element);
    for (const char* name : {"k1", "k2", "mean", "gauss"}) {
      ASSERT_TRUE(c.count(name)) << element << " lacks " << name;
      ASSERT_EQ(c.at(name).size(), std::string(element) == "face" ? 5120u : 2562u);
      for (double value : c.at(name)) EXPECT_NEAR(value, 1.0, 0.05) << element << " " << name;
    }
  }
}

TEST(CurvatureCli, CylinderDirectionsAreWritten) {
  TempDir dir;
  const std::string out = dir.file("cyl.ply");
  const CliResult r = run_cli("curvature builtin:cylinder:64 -o '" + out + "' --ascii --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Columns faces = read_ascii_ply_properties(read_text(out)).at("face");
  // The middle of the tube (unit radius): k2 = 0, e2 along the axis.
  const auto& k2 = faces.at("k2");
  const auto& e2z = faces.at("e2z");
  const size_t mid = k2.size() / 2;
  EXPECT_NEAR(k2[mid], 0.0, 0.03);
  EXPECT_NEAR(std::abs(e2z[mid]), 1.0, 1e-3);
}

TEST(CurvatureCli, BadInputsExitWithOneAndWriteNothing) {
  TempDir dir;
  CliResult r = run_cli("curvature '" + dir.file("missing.off") + "' -o '" + dir.file("out.ply") + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("missing.off"), std::string::npos) << r.err;
  r = run_cli("curvature builtin:sphere:2 -o '" + dir.file("out.obj") + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(".ply"), std::string::npos) << r.err;
  r = run_cli("curvature builtin:sphere:2 -o '" + dir.file("out.ply") + "' --face-rings 0");
  EXPECT_EQ(r.exit_code, 1);
  r = run_cli("curvature builtin:sphere:2 -o '" + dir.file("no/such/dir/out.ply") + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(count_entries(dir.path()), 0);
}
