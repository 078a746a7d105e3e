#pragma once
#include <gshell/mesh.h>
#include <string>
#include <vector>

namespace gshell {

struct MeshProblem {
  enum class Severity { Info, Warning, Error };
  Severity severity;
  std::string message; ///< one line, naming the face/vertex index where the problem is
};

/// Checks everything a shell needs: non-empty; finite coordinates; face indices in range and
/// distinct; no zero-area faces; manifold edges and vertices; consistently oriented neighbours
/// (errors); unreferenced vertices (warning); open boundaries (info).
std::vector<MeshProblem> validate_mesh(const TriMesh& mesh);

/// Throws InputError "NAME: <first error> (and K more problems)" if validate_mesh finds an error.
void require_valid_mesh(const TriMesh& mesh, const std::string& name);

} // namespace gshell
