#include <gshell/io/load_mesh.h>

#include <gshell/geometry/builtin_mesh.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/read_mesh.h>

namespace gshell {

TriMesh load_mesh(const std::string& input) {
  TriMesh mesh = is_builtin_spec(input) ? make_builtin(input) : read_mesh(input);
  require_valid_mesh(mesh, input);
  return mesh;
}

} // namespace gshell
