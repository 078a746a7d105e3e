#include <gshell/run/shell_folder.h>

#include "io/json_input.h"
#include "run/output_folder_files.h"

#include <gshell/error.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/atomic_file.h>
#include <gshell/io/read_mesh.h>
#include <gshell/io/tet_mesh_io.h>
#include <gshell/io/write_mesh.h>
#include <gshell/quality/certificate_report.h>
#include <gshell/run/frames.h>
#include <gshell/run/staged_folder.h>
#include <gshell/shell/prism_tets.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <iterator>
#include <optional>

namespace gshell {

namespace fs = std::filesystem;

namespace {

// Base faces of a prism shell recovered from its tets (3 per face): the three base ids of the
// prism, oriented so that the top lies on the side of the face normal.
Eigen::MatrixXi faces_from_prism_tets(const Eigen::MatrixXi& T, const Eigen::MatrixXd& X, int n,
                                      const std::string& name) {
  const Eigen::Index m = T.rows() / 3;
  Eigen::MatrixXi F(m, 3);
  auto not_a_prism = [&](Eigen::Index f) {
    return InputError(with_file(name, "tets " + std::to_string(3 * f) + ".." + std::to_string(3 * f + 2) +
                                          " of shell.vtu do not form a prism"));
  };
  for (Eigen::Index f = 0; f < m; ++f) {
    std::array<int, 3> base{};
    int count = 0;
    Eigen::Vector3d top_centre = Eigen::Vector3d::Zero();
    int top_count = 0;
    for (int t = 0; t < 3; ++t)
      for (int k = 0; k < 4; ++k) {
        const int id = T(3 * f + t, k);
        if (id < n) {
          if (std::find(base.begin(), base.begin() + count, id) == base.begin() + count) {
            if (count == 3) throw not_a_prism(f);
            base[count++] = id;
          }
        } else {
          top_centre += X.row(id).transpose();
          ++top_count;
        }
      }
    if (count != 3 || top_count == 0) throw not_a_prism(f);
    const Eigen::Vector3d a = X.row(base[0]), b = X.row(base[1]), c = X.row(base[2]);
    if ((b - a).cross(c - a).dot(top_centre / top_count - (a + b + c) / 3) < 0) std::swap(base[1], base[2]);
    F.row(f) << base[0], base[1], base[2];
  }
  return F;
}

// eta as the report records it: `thickness` as a number (deform, pose) or {"eta": ...} (generate).
std::optional<double> report_thickness(const nlohmann::ordered_json& report) {
  if (!report.is_object() || !report.contains("thickness")) return std::nullopt;
  const auto& t = report["thickness"];
  if (t.is_number()) return t.get<double>();
  if (t.is_object() && t.contains("eta") && t["eta"].is_number()) return t["eta"].get<double>();
  return std::nullopt;
}

std::string report_made_by(const nlohmann::ordered_json& report) {
  for (const char* key : {"method", "command"})
    if (report.is_object() && report.contains(key) && report[key].is_string()) return report[key].get<std::string>();
  return {};
}

// report[key] as a count, -1 when absent or not a non-negative integer.
long long report_count(const nlohmann::ordered_json& report, const char* key) {
  if (!report.is_object() || !report.contains(key) || !report[key].is_number_integer()) return -1;
  const long long count = report[key].get<long long>();
  return count >= 0 ? count : -1;
}

// The report that describes DIR: its own, or for a deform frame its run's.
fs::path report_folder(const fs::path& dir) {
  if (fs::exists(dir / kReportFile)) return dir;
  fs::path normal = dir.lexically_normal();
  if (normal.filename().empty()) normal = normal.parent_path();
  if (frame_number(normal.filename().string()) && fs::exists(normal.parent_path() / kReportFile))
    return normal.parent_path();
  return {};
}

} // namespace

nlohmann::ordered_json read_report(const fs::path& dir) {
  const fs::path path = dir / kReportFile;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(with_file(path.string(), "cannot open (is " + dir.string() + " a gshell output folder?)"));
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // gshell's reports nest 5 levels; a hostile one 100,000 deep crashed the HTML report's formatting.
  constexpr int kMaxReportDepth = 64;
  if (io_detail::json_nesting_depth(text, kMaxReportDepth) > kMaxReportDepth)
    throw InputError(with_file(path.string(), "nested deeper than " + std::to_string(kMaxReportDepth) + " levels"));
  nlohmann::ordered_json report;
  try {
    report = nlohmann::ordered_json::parse(text);
  } catch (const nlohmann::json::exception& e) { // a cut-off or hand-edited report (NaN is not JSON)
    throw InputError(with_file(path.string(), io_detail::not_valid_json(e)));
  }
  if (!report.is_object()) throw InputError(with_file(path.string(), "not a JSON object"));
  return report;
}

void write_report(const fs::path& path, const nlohmann::ordered_json& report) {
  // File names are bytes: one that is not UTF-8 (a Latin-1 folder) is written with U+FFFD for its
  // bad bytes, not an "internal error" after the whole run.
  const std::string text = report.dump(2, ' ', false, nlohmann::json::error_handler_t::replace);
  write_file_atomically(path.string(), [&](std::ostream& out) { out << text << "\n"; });
}

std::string invalid_rest_shell_warning(const std::string& dir, const nlohmann::ordered_json& report,
                                       const std::string& result) {
  if (!report.is_object() || !report.contains("valid") || !report["valid"].is_boolean() || report["valid"].get<bool>())
    return {};
  std::string out;
  if (report.contains("certificate")) {
    const auto& c = report["certificate"];
    const long long inverted = report_count(c, "inverted_tets"), top_top = report_count(c, "top_self_intersections"),
                    top_base = report_count(c, "top_base_intersections"), wall = report_count(c, "wall_intersections");
    if (inverted >= 0) out += std::to_string(inverted) + " inverted tets";
    if (top_top >= 0 && top_base >= 0 && wall >= 0)
      out += (out.empty() ? "" : ", ") + std::to_string(top_top) + " top/top, " + std::to_string(top_base) +
             " top/base and " + std::to_string(wall) + " wall intersecting pairs";
    if (const long long nested = report_count(c, "nested_parts"); nested > 0)
      out += ", " + nested_parts_phrase(nested);
  }
  const long long base_crossings = report_count(report, "base_self_intersections");
  if (base_crossings > 0)
    out += (out.empty() ? "" : "; ") + std::string("its base crosses itself at ") + std::to_string(base_crossings) +
           " face pairs";
  return dir + ": the rest shell is not valid (" + (out.empty() ? "its report says so" : out) +
         "); the guard leaves those places out, so a " + result + " may stay invalid there";
}

bool is_shell_folder(const fs::path& dir) {
  std::error_code ec;
  return fs::exists(dir / "top.obj", ec) || fs::exists(dir / "shell.vtu", ec);
}

bool is_output_folder_file(const fs::path& file) {
  const std::string name = file.filename().string();
  if (!is_shell_file(name) && name != kDetailFile) return false;
  const fs::path dir = file.has_parent_path() ? file.parent_path() : fs::path(".");
  std::error_code ec;
  return is_shell_folder(dir) || fs::exists(dir / kReportFile, ec);
}

ShellFolder read_shell_folder(const std::string& dir_text, const ShellFolderReadOptions& options) {
  const fs::path dir(dir_text);
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw InputError(with_file(dir_text, fs::exists(dir, ec) ? "not a shell folder (a file; a shell is the folder "
                                                               "gshell generate writes)"
                                                             : "not a shell folder (no such directory)"));
  ShellFolder out;
  const fs::path report_dir = report_folder(dir);
  if (!report_dir.empty()) out.report = read_report(report_dir);
  out.made_by = report_made_by(out.report);

  const bool has_surfaces = fs::exists(dir / "base.obj") && fs::exists(dir / "top.obj");
  const bool has_vtu = fs::exists(dir / "shell.vtu");
  if (!has_surfaces && !has_vtu)
    throw InputError(with_file(dir_text, "not a shell folder (no base.obj + top.obj, no shell.vtu)"));
  std::optional<TetMesh> vtu;
  if (has_vtu && (options.read_tets || !has_surfaces)) {
    vtu = read_tet_mesh((dir / "shell.vtu").string());
    if (vtu->X.rows() % 2 || vtu->T.rows() % 3)
      throw InputError(with_file((dir / "shell.vtu").string(), "not a prism shell (2n points and 3m tets expected)"));
  }
  if (has_surfaces) {
    out.surface = read_mesh((dir / "base.obj").string());
    const TriMesh top = read_mesh((dir / "top.obj").string());
    if (out.surface.V.rows() != top.V.rows() || out.surface.F.rows() != top.F.rows() || out.surface.F != top.F)
      throw InputError(with_file(dir_text, "base.obj and top.obj differ in vertex count or faces"));
    // Positions from a folder are not validated as a surface (a top may well be degenerate), but
    // they must be coordinates gshell can compute with.
    require_usable_coordinates(out.surface.V, (dir / "base.obj").string());
    require_usable_texture_coordinates(out.surface, (dir / "base.obj").string());
    require_usable_coordinates(top.V, (dir / "top.obj").string());
    out.shell.base = out.surface.V;
    out.shell.top = top.V;
  } else {
    require_usable_coordinates(vtu->X, (dir / "shell.vtu").string());
    const int n = static_cast<int>(vtu->X.rows() / 2);
    out.shell.base = vtu->X.topRows(n);
    out.shell.top = vtu->X.bottomRows(n);
    if (fs::exists(dir / "top.obj")) {
      out.surface = read_mesh((dir / "top.obj").string()); // a deform frame: same faces and UVs as the base
      if (out.surface.V.rows() != n || out.surface.F.rows() != vtu->T.rows() / 3)
        throw InputError(with_file(dir_text, "top.obj and shell.vtu differ in vertex or face count"));
      require_usable_texture_coordinates(out.surface, (dir / "top.obj").string());
    } else {
      out.surface.F = faces_from_prism_tets(vtu->T, vtu->X, n, dir_text);
    }
    out.surface.V = out.shell.base;
  }
  out.shell.F = out.surface.F;

  const std::optional<double> eta = report_thickness(out.report);
  if (eta && !(*eta > 0 && std::isfinite(*eta)))
    throw InputError(with_file((report_dir / kReportFile).string(), "thickness must be positive and finite"));
  if (!eta && options.require_thickness)
    throw InputError(with_file(dir_text, report_dir.empty() ? "not a shell folder (report.json missing)"
                                                            : "report.json gives no thickness"));
  out.shell.thickness = eta.value_or(0);

  if (vtu && options.read_tets) {
    const Eigen::Index m = out.shell.F.rows();
    if (vtu->T.rows() == 3 * m && vtu->X.rows() == 2 * out.shell.base.rows()) {
      out.tets = std::move(vtu->T);
      for (const auto& [name, values] : vtu->cell_data)
        if (name == "stretch" && values.rows() == 3 * m && values.cols() == 1) out.tet_stretch = values.col(0);
    }
  }
  if (fs::exists(dir / kDetailFile)) out.detail = read_mesh((dir / kDetailFile).string());
  return out;
}

void write_shell_files(const fs::path& dir, const ShellFolderContents& c) {
  const int n = c.surface.num_vertices() > 0 ? c.surface.num_vertices() : static_cast<int>(c.X.rows() / 2);
  if (c.X.rows() != 2 * n || c.X.cols() != 3)
    throw InputError("shell folder: X must have 2n rows for a base of " + std::to_string(n) + " vertices");
  TriMesh base = c.surface, top = c.surface; // same faces, order and UVs
  base.V = c.X.topRows(n);
  top.V = c.X.bottomRows(n);
  write_mesh((dir / "base.obj").string(), base);
  write_mesh((dir / "top.obj").string(), top);
  TetMesh tets;
  tets.X = c.X;
  tets.T = build_prism_tets(c.surface.F, n);
  tets.cell_data = c.cell_data;
  write_tet_mesh((dir / "shell.vtu").string(), tets);
  write_report(dir / kReportFile, c.report);
}

std::string shell_output_command(const nlohmann::ordered_json& report) {
  if (report.is_object() && report.contains("command") && report["command"].is_string())
    return report["command"].get<std::string>();
  return "generate";
}

bool holds_shell_output_of(const fs::path& dir, const std::string& command) {
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (!is_shell_file(name) && name != kPreviewFile) return false;
  }
  try {
    return shell_output_command(read_report(dir)) == command;
  } catch (const InputError&) {
    return false; // no readable report: which command made it is unknown, so it is not replaced
  }
}

void write_shell_folder(const std::string& dir, const ShellFolderContents& contents, const BeforeCommit& before_commit) {
  StagedFolder staged(dir);
  staged.write([&] {
    write_shell_files(staged.path(), contents);
    if (before_commit) before_commit(staged.path());
  });
  const std::string command = shell_output_command(contents.report);
  staged.commit([&](const fs::path& d) { return holds_shell_output_of(d, command); });
}

} // namespace gshell
