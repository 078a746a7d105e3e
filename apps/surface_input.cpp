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

void warn_invalid_rest_shell(const std::string& shell, const std::string& faults, const std::string& result) {
  if (faults.empty()) return;
  std::cerr << "warning: " << shell << ": the rest shell is not valid (" << faults
            << "); the guard leaves those places out, so a " << result << " may stay invalid there\n";
}

} // namespace gshell::cli
