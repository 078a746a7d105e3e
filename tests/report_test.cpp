// `gshell report`: the page is well-formed, self-contained, and shows every figure of report.json
// (generation runs, and deformation runs with per-frame records).
#include <gshell/io/xml_escape.h>
#include <gshell/render/html_report.h>
#include <gshell/render/scene.h>
#include <gshell/render/shell_render.h>
#include <gshell/render/svg_plot.h>

#include "test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>

using namespace gshell;
using namespace gshell::test;
namespace fs = std::filesystem;

namespace {

// Tag balance of an XHTML-syntax page: every element closed in order (void elements self-closed).
// Returns an empty string when fine, else what went wrong.
std::string tag_balance_problem(const std::string& html) {
  std::vector<std::string> open;
  size_t i = 0;
  while ((i = html.find('<', i)) != std::string::npos) {
    const size_t end = html.find('>', i);
    if (end == std::string::npos) return "unterminated tag at " + std::to_string(i);
    const std::string tag = html.substr(i + 1, end - i - 1);
    i = end + 1;
    if (tag.empty()) return "empty tag";
    if (tag[0] == '!' || tag[0] == '?') continue; // doctype, comments, XML declaration
    const bool closing = tag[0] == '/';
    const bool self_closing = tag.back() == '/';
    std::string name = tag.substr(closing ? 1 : 0);
    name = name.substr(0, name.find_first_of(" \t\n/"));
    if (self_closing) continue;
    if (!closing) {
      open.push_back(name);
    } else {
      if (open.empty() || open.back() != name) return "</" + name + "> closes <" + (open.empty() ? "" : open.back()) + ">";
      open.pop_back();
    }
  }
  return open.empty() ? "" : "<" + open.back() + "> never closed";
}

// Python's XML parser as a second, independent check of the markup. python3 is a dependency
// (scripts/setup installs it), so its absence is a failure, not a reason to skip the check.
void expect_python_parses_as_xml(const std::string& path) {
  if (!fs::exists("/usr/bin/python3")) {
    ADD_FAILURE() << "/usr/bin/python3 is missing (scripts/setup installs it): the page's XML check cannot run";
    return;
  }
  const std::string cmd = "/usr/bin/python3 -c \"import sys, xml.etree.ElementTree as ET, html.parser; "
                          "ET.parse(sys.argv[1]); html.parser.HTMLParser().feed(open(sys.argv[1]).read())\" '" + path +
                          "'";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << path << " does not parse as XML (python3's message above)";
}

// Numbers written in table cells of the page (the figures; plot coordinates do not count).
std::vector<double> table_numbers(const std::string& html) {
  std::vector<double> numbers;
  static const std::regex cell("<td>([^<]*)</td>");
  static const std::regex number(R"([-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?)");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), cell); it != std::sregex_iterator(); ++it) {
    const std::string text = (*it)[1];
    for (auto n = std::sregex_iterator(text.begin(), text.end(), number); n != std::sregex_iterator(); ++n)
      numbers.push_back(std::stod((*n)[0]));
  }
  return numbers;
}

void collect_json_numbers(const nlohmann::json& v, const std::string& path, std::vector<std::pair<std::string, double>>& out) {
  if (v.is_number()) out.emplace_back(path, v.get<double>());
  if (v.is_object())
    for (auto it = v.begin(); it != v.end(); ++it) collect_json_numbers(it.value(), path + "." + it.key(), out);
  if (v.is_array())
    for (size_t i = 0; i < v.size(); ++i) collect_json_numbers(v[i], path + "[" + std::to_string(i) + "]", out);
}

void collect_json_keys(const nlohmann::json& v, std::vector<std::string>& out) {
  if (v.is_object())
    for (auto it = v.begin(); it != v.end(); ++it) {
      out.push_back(it.key());
      collect_json_keys(it.value(), out);
    }
  if (v.is_array())
    for (const auto& x : v) collect_json_keys(x, out);
}

// Every number and every key of report.json shows up in the page.
void expect_every_figure(const std::string& html, const nlohmann::json& report) {
  const std::vector<double> shown = table_numbers(html);
  std::vector<std::pair<std::string, double>> figures;
  collect_json_numbers(report, "", figures);
  ASSERT_FALSE(figures.empty());
  for (const auto& [path, value] : figures) {
    const bool found = std::any_of(shown.begin(), shown.end(), [&](double s) {
      return std::abs(s - value) <= 1e-5 * std::abs(value) + 1e-300;
    });
    EXPECT_TRUE(found) << path << " = " << value << " is not in the page";
  }
  std::vector<std::string> keys;
  collect_json_keys(report, keys);
  for (const auto& key : keys) EXPECT_NE(html.find(key), std::string::npos) << "key " << key;
}

void expect_self_contained(const std::string& html) {
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);
  EXPECT_EQ(html.find("href="), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  for (size_t i = html.find("<img"); i != std::string::npos; i = html.find("<img", i + 1)) {
    const size_t src = html.find("src=\"", i);
    ASSERT_NE(src, std::string::npos);
    EXPECT_EQ(html.compare(src + 5, 22, "data:image/png;base64,"), 0);
  }
}

/// The page's text, after checking that it is balanced, parses as XML and needs no other file.
std::string read_well_formed_page(const std::string& page) {
  const std::string html = read_text(page);
  EXPECT_EQ(tag_balance_problem(html), "");
  expect_python_parses_as_xml(page);
  expect_self_contained(html);
  return html;
}

nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

} // namespace

TEST(Base64, KnownVectors) {
  EXPECT_EQ(base64_encode(""), "");
  EXPECT_EQ(base64_encode("f"), "Zg==");
  EXPECT_EQ(base64_encode("fo"), "Zm8=");
  EXPECT_EQ(base64_encode("foo"), "Zm9v");
  EXPECT_EQ(base64_encode("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64_encode(std::string("\xff\x00\x10", 3)), "/wAQ");
}

TEST(SvgPlot, IsBalancedAndEscapesText) {
  PlotOptions options;
  options.title = "a < b & c";
  options.log_y = true;
  const std::string svg = svg_line_plot({10, 1, 0.1, NAN, 0.01}, options);
  EXPECT_EQ(tag_balance_problem(svg), "");
  EXPECT_NE(svg.find("a &lt; b &amp; c"), std::string::npos);
  EXPECT_NE(svg.find("<polyline"), std::string::npos);
  EXPECT_EQ(tag_balance_problem(svg_line_plot(std::vector<double>{}, options)), ""); // no data: still a valid element
}

// Counts that stay zero over a run (base crossings per frame) are drawn on an axis from 0, not
// from -1 as if negative counts were possible; a negative constant keeps room below.
TEST(SvgPlot, AConstantSeriesKeepsItsSignOnTheAxis) {
  const auto tick_labels = [](const std::string& svg) {
    std::vector<std::string> labels;
    for (std::size_t at = svg.find("text-anchor=\"end\">"); at != std::string::npos;
         at = svg.find("text-anchor=\"end\">", at + 1)) {
      const std::size_t from = svg.find('>', at) + 1;
      labels.push_back(svg.substr(from, svg.find('<', from) - from));
    }
    return labels;
  };
  const std::vector<std::string> zeros = tick_labels(svg_line_plot({0, 0, 0, 0}, PlotOptions{}));
  ASSERT_FALSE(zeros.empty());
  EXPECT_EQ(zeros.front(), "0");
  for (const std::string& label : zeros) EXPECT_NE(label.front(), '-') << label;
  const std::vector<std::string> negative = tick_labels(svg_line_plot({-2, -2, -2}, PlotOptions{}));
  ASSERT_FALSE(negative.empty());
  EXPECT_EQ(negative.front().front(), '-');
  EXPECT_LT(std::stod(negative.front()), -2);
}

TEST(XmlEscape, WritesOnlyUtf8WithoutControlCharacters) {
  EXPECT_EQ(xml_escape("a<b>&\"'"), "a&lt;b&gt;&amp;&quot;&apos;");
  const std::string fffd = "\xef\xbf\xbd";
  EXPECT_EQ(xml_escape("caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x90\x9a"), "caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x90\x9a"); // kept
  EXPECT_EQ(xml_escape("lat\xe9/m\xff.off"), "lat" + fffd + "/m" + fffd + ".off");                 // Latin-1 bytes
  EXPECT_EQ(xml_escape("\xc0\xaf"), fffd + fffd);                                                // overlong '/'
  EXPECT_EQ(xml_escape("\xed\xa0\x80"), fffd + fffd + fffd);                                    // a surrogate
  EXPECT_EQ(xml_escape("\xe2\x82"), fffd + fffd);                                                // cut short
  EXPECT_EQ(xml_escape("a\x01\tb\n"), "a" + fffd + "\tb\n");
}

TEST(ReportCli, GenerateRunGivesAWellFormedPageWithEveryFigure) {
  TempDir tmp("report-generate");
  const std::string dir = tmp.file("torus");
  const CliResult g = run_cli("generate builtin:torus:24 -o '" + dir + "' --thickness-ratio 0.05 --iterations 8 -q");
  ASSERT_EQ(g.exit_code, 0) << g.err;
  const std::string page = tmp.file("report.html");
  const CliResult r = run_cli("report '" + dir + "' -o '" + page + "' -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find(page), std::string::npos); // prints where the page is
  const std::string html = read_well_formed_page(page);
  expect_every_figure(html, read_json(dir + "/report.json"));
  EXPECT_NE(html.find("energy per iteration"), std::string::npos);
  EXPECT_NE(html.find("convergence: (E_k - E_last) / E_last"), std::string::npos);
  EXPECT_NE(html.find("<svg"), std::string::npos);
  // A thin torus shell is valid, and the page says so up front.
  EXPECT_NE(html.find("Valid shell: yes</strong> (exact certificate: 0 inverted tets"), std::string::npos);
  // An offset shell thicker than the torus's tube crosses itself in the hole.
  const std::string thick = tmp.file("thick");
  ASSERT_EQ(run_cli("generate builtin:torus:24 -o '" + thick + "' --thickness 0.6 --method offset -q").exit_code, 0);
  const std::string thick_page = tmp.file("thick.html");
  ASSERT_EQ(run_cli("report '" + thick + "' -o '" + thick_page + "' --no-renders -q").exit_code, 0);
  EXPECT_NE(read_well_formed_page(thick_page).find("Valid shell: no</strong>"), std::string::npos);
  if (offscreen_rendering_available()) {
    EXPECT_NE(html.find("data:image/png;base64,"), std::string::npos);
    EXPECT_EQ(html.find("No render"), std::string::npos);
  }
}

TEST(ReportCli, DeformationRunShowsTimePerFrame) {
  TempDir tmp("report-deform");
  const std::string rest = tmp.file("rest"), out = tmp.file("deformed");
  ASSERT_EQ(run_cli("generate builtin:plane:8 -o '" + rest + "' --thickness 0.1 --iterations 3 -q").exit_code, 0);
  // A deform-like output: per-frame folders with shell.vtu, and a report with a `frames` array.
  const int frames = 3;
  for (int k = 0; k < frames; ++k) {
    const std::string frame = out + "/frame_000" + std::to_string(k);
    fs::create_directories(frame);
    fs::copy_file(rest + "/shell.vtu", frame + "/shell.vtu");
    fs::copy_file(rest + "/top.obj", frame + "/top.obj");
  }
  nlohmann::json report = {
      {"command", "deform"}, {"shell", rest}, {"tolerance", 1e-4}, {"frames", nlohmann::json::array()}};
  for (int k = 0; k < frames; ++k)
    report["frames"].push_back({{"iterations", 3 + k},
                                {"energy", {1.5 / (k + 1), 0.7 / (k + 1)}},
                                {"stretch", {{"mean", 0.001 * (k + 1)}, {"max", 0.0123 * (k + 2)}}},
                                {"inverted_tets", k},
                                {"seconds", 0.0421 + 0.001 * k}});
  write_text(out + "/report.json", report.dump(2));
  const std::string page = tmp.file("deform.html");
  const CliResult r = run_cli("report '" + out + "' -o '" + page + "' -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string html = read_well_formed_page(page);
  expect_every_figure(html, report);
  EXPECT_NE(html.find("time (seconds) per frame"), std::string::npos);
  // Each frame's energy per iteration, one line per frame (3 frames: all of them).
  EXPECT_NE(html.find("energy per iteration"), std::string::npos);
  EXPECT_NE(html.find("convergence: (E_k - E_last) / E_last"), std::string::npos);
  for (const char* name : {">frame 1<", ">frame 2<", ">frame 3<"}) EXPECT_NE(html.find(name), std::string::npos) << name;
  if (offscreen_rendering_available()) {
    EXPECT_NE(html.find("frame_0002 (first, middle and last frame)"), std::string::npos);
    EXPECT_EQ(html.find("No render"), std::string::npos);
  }
}

TEST(ReportCli, PoseRunShowsTimeAndEnergyPerStepAndTheRestShell) {
  TempDir tmp("report-pose");
  const std::string rest = tmp.file("bowl"), out = tmp.file("pulled"), handles = tmp.file("pull.json");
  ASSERT_EQ(run_cli("generate builtin:bowl:8 -o '" + rest + "' --thickness 0.08 --iterations 3 -q").exit_code, 0);
  write_text(handles, R"({"handles": [
    {"select": {"surface": "both", "box": [-2, -2, -0.2, -0.6, 2, 2]}},
    {"select": {"surface": "both", "box": [0.6, -2, -0.2, 2, 2, 2]}, "translate": [0.3, 0, 0.1]}]})");
  const CliResult p = run_cli("pose --shell '" + rest + "' --handles '" + handles + "' --steps 3 --levels 3 -o '" + out + "' -q");
  ASSERT_EQ(p.exit_code, 0) << p.err;
  const std::string page = tmp.file("pose.html");
  const CliResult r = run_cli("report '" + out + "' -o '" + page + "' -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string html = read_well_formed_page(page);
  expect_every_figure(html, read_json(out + "/report.json"));
  EXPECT_NE(html.find("time (seconds) per step"), std::string::npos);
  EXPECT_NE(html.find("energy per step"), std::string::npos);
  if (offscreen_rendering_available()) {
    EXPECT_NE(html.find("rest and posed shell"), std::string::npos);
    EXPECT_EQ(html.find("No render"), std::string::npos);
  }
}

// A pose folder names its rest shell relative to itself ("rest_shell"), so its readers find it
// wherever they run and wherever the two folders moved together; "shell" stays as the pose was
// given it. A rest shell that is not the posed one's (an older folder's "shell", read from
// elsewhere, naming another shell) is left out, and the page and the CLI say so.
TEST(ReportCli, APoseFolderFindsItsRestShellFromItselfAndRefusesAnotherShell) {
  TempDir tmp("report-rest");
  const std::string work = tmp.file("work"), handles = tmp.file("pull.json");
  fs::create_directories(work + "/nested");
  ASSERT_EQ(run_cli("generate builtin:bowl:8 -o '" + work + "/bowl' --thickness 0.08 --iterations 3 -q").exit_code, 0);
  write_text(handles, R"({"handles": [
    {"select": {"surface": "both", "box": [-2, -2, -0.2, -0.6, 2, 2]}},
    {"select": {"surface": "both", "box": [0.6, -2, -0.2, 2, 2, 2]}, "translate": [0.2, 0, 0]}]})");
  const CliResult p = run_cli("pose --shell '" + work + "/bowl' --handles '" + handles + "' --levels 3 -o '" + work +
                              "/nested/pulled' -q");
  ASSERT_EQ(p.exit_code, 0) << p.err;
  EXPECT_EQ(read_json(work + "/nested/pulled/report.json")["rest_shell"], "../../bowl");
  // Both moved: "shell" names a folder that is gone, "rest_shell" still leads to the rest.
  const std::string moved = tmp.file("moved");
  fs::rename(work, moved);
  const std::string pose = moved + "/nested/pulled";
  PreviewPanels panels = preview_panels(pose);
  ASSERT_EQ(panels.subjects.size(), 2u) << panels.note;
  EXPECT_EQ(panels.captions[0], "rest");
  EXPECT_TRUE(panels.note.empty()) << panels.note;
  // A report that names another shell (as an older folder read from another directory can).
  ASSERT_EQ(run_cli("generate builtin:sphere:2 -o '" + tmp.file("other") + "' --thickness-ratio 0.05 -q").exit_code, 0);
  nlohmann::json report = read_json(pose + "/report.json");
  report.erase("rest_shell");
  report["shell"] = tmp.file("other");
  write_text(pose + "/report.json", report.dump());
  panels = preview_panels(pose);
  EXPECT_EQ(panels.subjects.size(), 1u);
  EXPECT_NE(panels.note.find("is not the posed shell's"), std::string::npos) << panels.note;
  const CliResult r = run_cli("report '" + pose + "' -o '" + tmp.file("page.html") + "'");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("gshell report: warning: the rest shell"), std::string::npos) << r.err;
  EXPECT_NE(read_text(tmp.file("page.html")).find("is not the posed shell&apos;s"), std::string::npos);
}

TEST(ReportCli, MissingReportIsAnInputErrorAndWritesNothing) {
  TempDir tmp("report-missing");
  fs::create_directories(tmp.file("empty"));
  const CliResult r = run_cli("report '" + tmp.file("empty") + "' -o '" + tmp.file("out.html") + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("report.json"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(tmp.file("out.html")));
  write_text(tmp.file("empty") + "/report.json", "{not json");
  EXPECT_EQ(run_cli("report '" + tmp.file("empty") + "' -o '" + tmp.file("out.html") + "'").exit_code, 1);
  EXPECT_FALSE(fs::exists(tmp.file("out.html")));
  // A JSON object no gshell command wrote would make a page of nothing: it is named instead.
  write_text(tmp.file("empty") + "/report.json", R"({"name": "not ours", "figures": [1, 2]})");
  const CliResult other = run_cli("report '" + tmp.file("empty") + "' -o '" + tmp.file("out.html") + "'");
  EXPECT_EQ(other.exit_code, 1);
  EXPECT_EQ(other.err, "gshell: error: " + tmp.file("empty") +
                           "/report.json: not a report of gshell (none of \"command\", \"method\", \"gshell_version\")\n");
  EXPECT_FALSE(fs::exists(tmp.file("out.html")));
}
