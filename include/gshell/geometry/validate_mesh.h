#pragma once
#include <gshell/mesh.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <string>
#include <vector>

namespace gshell {

struct MeshProblem {
  enum class Severity { Info, Warning, Error };
  Severity severity;
  std::string message; ///< one line, naming the face/vertex index where the problem is
  int count = 1;       ///< occurrences this entry stands for (> 1 for "and N more ..." summaries)
  std::string kind;    ///< what kind of problem, plural ("unreferenced vertices"); the same for its summary
};

/// "error", "warning" or "info".
const char* severity_name(MeshProblem::Severity severity);

/// Largest coordinate magnitude gshell accepts: |x| < 1e50. Lengths are then below 4e50 and the
/// products of up to six lengths the computations form stay finite doubles (DBL_MAX = 1.8e308):
/// volumes (3), squared areas (4: Eigen's norm of a cross product squares it first) and
/// determinants of 3x3 blocks of squared lengths (6: the hierarchy's affine fits), below 5e303.
constexpr double max_coordinate_magnitude = 1e50;
/// Smallest mesh size (bounding-box diagonal) gshell accepts: 1e-40. The same products of six
/// lengths, for features down to 1e-5 of the size (thin tets, small clusters), then stay above the
/// smallest normal double (2.2e-308) instead of underflowing to 0, which reads as zero area.
constexpr double min_mesh_size = 1e-40;

/// Checks everything a shell needs: non-empty; finite coordinates of magnitude below
/// max_coordinate_magnitude; a size (bounding-box diagonal) of at least min_mesh_size unless all
/// vertices coincide; face indices in range and
/// distinct; no zero-area faces (doubled area <= 1e-12 * bbox diagonal^2); manifold edges (at most
/// two faces) and vertices (incident faces form one fan); consistently oriented neighbours (errors);
/// texture coordinates, when present: 2 per row, one row of ids per face, ids in range, finite;
/// unreferenced vertices (warning); open boundaries (info, with the loop count).
/// Errors come first, then warnings, then information. Each kind lists at most 10 places
/// individually and then one summary entry with `count` = the rest.
std::vector<MeshProblem> validate_mesh(const TriMesh& mesh);

/// "" when every coordinate of p is below max_coordinate_magnitude in magnitude, else the problem
/// as a phrase: "a coordinate of magnitude 1e+60; gshell needs |x| < 1e+50 (...)". For inputs that
/// are positions or offsets without being mesh vertices (handle translations and centres).
std::string too_large_coordinate(const Eigen::Vector3d& p);

/// For positions that are not validated as a surface (a shell's top, deformed base frames):
/// throws InputError "NAME: vertex V has ..." on the first non-finite coordinate or one of
/// magnitude max_coordinate_magnitude or more, with validate_mesh's wording.
void require_usable_coordinates(const Eigen::MatrixXd& V, const std::string& name);

/// validate_mesh's checks of the texture coordinates (UV, FUV) alone, for a surface whose
/// positions are not validated as a mesh (a shell folder's base.obj). \throws InputError naming
/// `name` on the first problem.
void require_usable_texture_coordinates(const TriMesh& mesh, const std::string& name);

/// require_usable_coordinates, and a size (bounding-box diagonal) of at least min_mesh_size: what a
/// new pose of a checked base (a deformation frame) must meet, its faces being the base's.
/// \throws InputError naming `name`.
void require_usable_frame(const Eigen::MatrixXd& V, const std::string& name);

/// Faces of V (usable coordinates, as require_usable_frame) with zero area by validate_mesh's
/// rule (twice the area at most 1e-12 of the squared diagonal of the box of the faces' vertices:
/// coincident or collinear corners), ascending. A frame may have them (an edge collapsed in an
/// animation); an input mesh may not.
/// \throws InputError if V or F has not 3 columns or a face index is out of range.
std::vector<int> zero_area_faces(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

/// Throws InputError "NAME: <first error> (and K more problems)" if validate_mesh finds an error;
/// K counts the other errors and warnings. Otherwise returns the warnings, one line per kind:
/// "NAME: <first> (and K more <kind>)".
std::vector<std::string> require_valid_mesh(const TriMesh& mesh, const std::string& name);

} // namespace gshell
