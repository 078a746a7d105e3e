#include <gshell/io/load_mesh.h>

#include <gshell/geometry/builtin_mesh.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/read_mesh.h>

namespace gshell {

TriMesh read_mesh_or_builtin(const std::string& input, std::vector<std::string>* warnings,
                             std::vector<std::string>* skipped) {
  return is_builtin_spec(input) ? make_builtin(input) : read_mesh(input, warnings, skipped);
}

TriMesh load_mesh(const std::string& input, std::vector<std::string>* warnings, std::vector<std::string>* skipped) {
  std::vector<std::string> read_warnings;
  TriMesh mesh = read_mesh_or_builtin(input, &read_warnings, skipped);
  std::vector<std::string> found = require_valid_mesh(mesh, input);
  if (warnings) {
    *warnings = std::move(read_warnings);
    warnings->insert(warnings->end(), found.begin(), found.end());
  }
  return mesh;
}

} // namespace gshell
