#include "surface_input.h"
#include "warnings.h"

#include <gshell/io/load_mesh.h>

#include <vector>

namespace gshell::cli {

TriMesh load_surface(const std::string& input, const std::string& command) {
  std::vector<std::string> warnings;
  TriMesh mesh = load_mesh(input, &warnings);
  print_warnings(command, warnings);
  return mesh;
}

} // namespace gshell::cli
