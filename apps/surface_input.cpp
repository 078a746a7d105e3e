#include "surface_input.h"

#include <gshell/io/load_mesh.h>

#include <iostream>
#include <vector>

namespace gshell::cli {

TriMesh load_surface(const std::string& input, const std::string& command) {
  std::vector<std::string> warnings;
  TriMesh mesh = load_mesh(input, &warnings);
  for (const std::string& w : warnings) std::cerr << "gshell " << command << ": warning: " << w << "\n";
  return mesh;
}

} // namespace gshell::cli
