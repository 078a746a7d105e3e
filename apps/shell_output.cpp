#include "shell_output.h"

#include <gshell/error.h>
#include <gshell/io/tet_mesh_io.h>
#include <gshell/io/write_mesh.h>
#include <gshell/shell/prism_tets.h>

#include <filesystem>
#include <fstream>
#include <random>

namespace gshell::cli {

namespace fs = std::filesystem;

void check_output_dir(const std::string& dir) {
  const fs::path path(dir);
  if (dir.empty()) throw InputError("no output folder given");
  if (fs::exists(path) && !fs::is_directory(path)) throw InputError(with_file(dir, "exists and is not a folder"));
  fs::path absolute = fs::absolute(path).lexically_normal();
  if (absolute.filename().empty()) absolute = absolute.parent_path(); // "DIR/" names DIR
  const fs::path parent = absolute.parent_path();
  if (!fs::is_directory(parent)) throw InputError(with_file(dir, "parent folder does not exist"));
}

namespace {

// A temporary folder beside `dir` (same file system, so renames are atomic), removed unless kept.
class StagingDir {
public:
  explicit StagingDir(const fs::path& dir) {
    std::random_device rd;
    fs::path abs = fs::absolute(dir).lexically_normal();
    if (abs.filename().empty()) abs = abs.parent_path(); // "DIR/" names DIR
    path_ = abs.parent_path() / ("." + abs.filename().string() + ".tmp-" + std::to_string(rd()));
    std::error_code ec;
    if (!fs::create_directory(path_, ec)) throw InputError(with_file(path_.string(), "cannot create folder"));
  }
  ~StagingDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

private:
  fs::path path_;
};

} // namespace

void write_shell_dir(const std::string& dir, const TriMesh& base, const Shell& shell, const ShellMetrics& metrics,
                     const nlohmann::json& report) {
  check_output_dir(dir);
  const StagingDir staging{fs::path(dir)};
  const fs::path& tmp = staging.path();

  write_mesh((tmp / "base.obj").string(), base);
  TriMesh top = base; // same faces, order and UVs
  top.V = shell.top;
  write_mesh((tmp / "top.obj").string(), top);

  TetMesh tets;
  tets.X = shell.vertices();
  tets.T = build_prism_tets(shell.F, shell.num_base_vertices());
  Eigen::MatrixXd inverted = (metrics.tet_determinant.array() <= 0).cast<double>().matrix();
  Eigen::MatrixXd prism(tets.T.rows(), 1);
  for (Eigen::Index t = 0; t < prism.rows(); ++t) prism(t, 0) = static_cast<double>(t / 3);
  tets.cell_data = {{"stretch", metrics.tet_stretch}, {"inverted", inverted}, {"prism", prism}};
  write_tet_mesh((tmp / "shell.vtu").string(), tets);

  {
    std::ofstream out(tmp / "report.json");
    out << report.dump(2) << "\n";
    if (!out) throw InputError(with_file((fs::path(dir) / "report.json").string(), "cannot write"));
  }

  const fs::path target(dir);
  std::error_code ec;
  if (!fs::exists(target)) {
    fs::rename(tmp, target, ec);
    if (!ec) return;
  }
  // DIR exists (maybe with other files in it): move the finished files in one by one.
  fs::create_directories(target, ec);
  for (const char* name : {"base.obj", "top.obj", "shell.vtu", "report.json"}) {
    fs::rename(tmp / name, target / name, ec);
    if (ec) throw InputError(with_file((target / name).string(), "cannot write: " + ec.message()));
  }
}

} // namespace gshell::cli
