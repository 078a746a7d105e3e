#include <gshell/shell/shell_dir.h>

#include <gshell/error.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/read_mesh.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

namespace gshell {

Shell load_shell_dir(const std::string& dir, TriMesh* uv_source) {
  namespace fs = std::filesystem;
  const fs::path root(dir);
  if (!fs::is_directory(root)) throw InputError(with_file(dir, "not a shell folder (no such directory)"));
  for (const char* name : {"base.obj", "top.obj", "report.json"})
    if (!fs::exists(root / name)) throw InputError(with_file(dir, std::string("not a shell folder (") + name + " missing)"));
  TriMesh base = read_mesh((root / "base.obj").string());
  TriMesh top = read_mesh((root / "top.obj").string());
  if (base.V.rows() != top.V.rows() || base.F.rows() != top.F.rows() || base.F != top.F)
    throw InputError(with_file(dir, "base.obj and top.obj differ in vertex count or faces"));
  require_usable_coordinates(base.V, (root / "base.obj").string());
  require_usable_coordinates(top.V, (root / "top.obj").string());

  double thickness = 0;
  try {
    std::ifstream in(root / "report.json");
    const nlohmann::json report = nlohmann::json::parse(in);
    // `thickness` is a number (eta) in reports of `generate`; accept {"eta": ...} as well.
    const auto& t = report.at("thickness");
    thickness = t.is_number() ? t.get<double>() : t.at("eta").get<double>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError(with_file((root / "report.json").string(), std::string("no thickness: ") + e.what()));
  }
  if (!(thickness > 0) || !std::isfinite(thickness))
    throw InputError(with_file((root / "report.json").string(), "thickness must be positive"));

  Shell shell;
  shell.base = base.V;
  shell.top = top.V;
  shell.F = base.F;
  shell.thickness = thickness;
  if (uv_source) *uv_source = std::move(base);
  return shell;
}

} // namespace gshell
