#include "surface_input.h"
#include "warnings.h"

#include <gshell/io/load_mesh.h>

#include <vector>

namespace gshell::cli {

TriMesh load_surface(const std::string& input, const std::string& command, std::vector<std::string>* warnings) {
  std::vector<std::string> found;
  TriMesh mesh = load_mesh(input, &found);
  print_warnings(command, found);
  if (warnings) warnings->insert(warnings->end(), found.begin(), found.end());
  return mesh;
}

} // namespace gshell::cli
