#include <gshell/io/load_mesh.h>

#include <gshell/geometry/builtin_mesh.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/read_mesh.h>
#include <gshell/word_list.h>

#include "file_bytes.h"

namespace gshell {

TriMesh read_mesh_or_builtin(const std::string& input, std::vector<std::string>* warnings,
                             std::vector<std::string>* skipped) {
  return is_builtin_spec(input) ? make_builtin(input) : read_mesh(input, warnings, skipped);
}

std::string carried_data_warning(const std::string& input, const std::vector<std::string>& skipped,
                                 const std::string& output) {
  return input + ": its " + word_list(skipped) + (skipped.size() == 1 && skipped[0].back() != 's' ? " is" : " are") +
         " not carried into " + output +
         (io_detail::lower_extension(output) == "obj" ? " (positions, faces and texture coordinates are)"
                                                      : " (positions and faces are)");
}

std::string dropped_texture_coordinates_warning(const std::string& input, const TriMesh& mesh,
                                                const std::string& output) {
  if (!mesh.has_uv() || io_detail::lower_extension(output) == "obj") return {};
  return input + ": its texture coordinates are not written to " + output + " (only OBJ holds them)";
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
