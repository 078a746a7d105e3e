#pragma once
#include <gshell/mesh.h>
#include <string>
#include <vector>

namespace gshell {

struct MeshProblem {
  enum class Severity { Info, Warning, Error };
  Severity severity;
  std::string message; ///< one line, naming the face/vertex index where the problem is
  int count = 1;       ///< occurrences this entry stands for (> 1 for "and N more ..." summaries)
};

/// "error", "warning" or "info".
const char* severity_name(MeshProblem::Severity severity);

/// Checks everything a shell needs: non-empty; finite coordinates; face indices in range and
/// distinct; no zero-area faces (doubled area <= 1e-12 * bbox diagonal^2); manifold edges (at most
/// two faces) and vertices (incident faces form one fan); consistently oriented neighbours (errors);
/// unreferenced vertices (warning); open boundaries (info, with the loop count).
/// Errors come first, then warnings, then information. Each kind lists at most 10 places
/// individually and then one summary entry with `count` = the rest.
std::vector<MeshProblem> validate_mesh(const TriMesh& mesh);

/// Throws InputError "NAME: <first error> (and K more problems)" if validate_mesh finds an error;
/// K counts the other errors and warnings.
void require_valid_mesh(const TriMesh& mesh, const std::string& name);

} // namespace gshell
