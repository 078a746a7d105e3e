#pragma once
// Joining a surface's cuts: boundary vertices that sit at exactly one position (a triangle soup,
// seams split by an exporter) made one vertex.
#include <gshell/mesh.h>

#include <utility>
#include <vector>

namespace gshell {

/// Among `candidates` (vertex ids into V, any order, no repeats), those at exactly the position of
/// another: one (kept, merged) pair per vertex that is not the lowest id at its position, kept
/// being that lowest id; sorted by merged id. With a positive `tolerance` (model units), vertices
/// closer than it to another are at its position, chained (a group's kept vertex is its lowest
/// id); meant for rounding-sized tolerances.
std::vector<std::pair<int, int>> coincident_vertices(const Eigen::MatrixXd& V, std::vector<int> candidates,
                                                     double tolerance = 0);

/// The surface with every boundary vertex (on an edge of one face) that sits at exactly the
/// position of a lower-numbered boundary vertex replaced by it and removed; the other vertices keep
/// their order. Faces keep their order and texture coordinates (which are per corner). `merged`
/// (if not null) receives the number of vertices removed, `ids` (if not null) every input
/// vertex's id in the result. `tolerance`: as for coincident_vertices. `joinable` (one flag per
/// vertex, or empty for all): only flagged boundary vertices are joined. The result is not
/// validated: joining two patches that touch at one corner makes a non-manifold vertex
/// (require_valid_mesh says so).
/// Preconditions: face ids in [0, V.rows()); `joinable` empty or of V.rows() flags.
TriMesh weld_boundary_vertices(const TriMesh& mesh, int* merged = nullptr, std::vector<int>* ids = nullptr,
                               double tolerance = 0, const std::vector<char>& joinable = {});

} // namespace gshell
