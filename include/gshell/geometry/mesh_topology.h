#pragma once
#include <gshell/mesh.h>
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <string>
#include <vector>

namespace gshell {

/// Counts and sizes reported by `gshell info`. Works on any mesh, also one that fails validation:
/// faces with an out-of-range or repeated index are left out of edges, loops, components and chi.
struct MeshStats {
  int vertices = 0, faces = 0, edges = 0;
  int boundary_loops = 0, components = 0;
  int euler_characteristic = 0; ///< V - E + F, V counting only vertices used by some face
  double genus = 0;             ///< (2*components - boundary_loops - chi) / 2 for orientable meshes
  Eigen::Vector3d bbox_min = Eigen::Vector3d::Zero(), bbox_max = Eigen::Vector3d::Zero(); ///< of finite vertices
  double mean_edge_length = 0;  ///< over unique edges with finite ends, model units
  int boundary_edges = 0;       ///< edges with exactly one face
  int unreferenced_vertices = 0;
};

MeshStats mesh_stats(const TriMesh& mesh);

/// Per vertex id in [0, n): 1 if some row of `elements` (faces, tets) uses it, else 0. Ids outside
/// [0, n) are skipped.
std::vector<char> used_vertices(const Eigen::MatrixXi& elements, Eigen::Index n);

/// Grows the vertex set `flags` (one flag per vertex) by `rings` rings: each ring adds every
/// vertex of a face of F with a flagged vertex. \throws InputError when F is not m x 3 or has an id
/// outside [0, flags.size()).
void grow_by_rings(const Eigen::MatrixXi& F, int rings, std::vector<char>& flags);

/// Unique undirected edges (E x 2, smaller id first), in order of first appearance.
/// Faces with a negative or repeated index are skipped.
Eigen::MatrixXi unique_edges(const Eigen::MatrixXi& F);

/// Undirected edges with the face corners around them. Half-edge h = 3*f + k runs from F(f,k) to
/// F(f,(k+1)%3) (so h is also the corner of face f at F(f,k)). Faces with an index outside
/// [0, num_vertices) or a repeated index are skipped entirely.
struct EdgeIncidence {
  Eigen::MatrixXi edges;      ///< E x 2, smaller id first, in order of first appearance
  std::vector<int> offsets;   ///< E + 1 entries: edge e owns halfedges[offsets[e] .. offsets[e+1])
  std::vector<int> halfedges; ///< half-edge ids grouped by edge, ascending within an edge
  std::vector<char> face_used; ///< per face: 1 if the face was taken into account

  int num_edges() const { return static_cast<int>(edges.rows()); }
  int valence(int e) const { return offsets[e + 1] - offsets[e]; } ///< faces at edge e (1 = boundary)
};

EdgeIncidence edge_incidence(const Eigen::MatrixXi& F, int num_vertices);

/// Number of boundary loops: connected pieces of the graph of edges with exactly one face.
int count_boundary_loops(const EdgeIncidence& incidence, int num_vertices);

/// The closed connected parts of (V, F) (no edge of the part with exactly one face) whose faces
/// point inwards: the volume they enclose, summed over their faces as signed tets, is negative by
/// more than 1e-6 of the sum of the tets' absolute volumes (a part flat to rounding, e.g. two
/// sheets face to face, has no side). A shell grows into such a part. Returns each part's lowest
/// vertex id, ascending. Faces with an id outside [0, V.rows()) or a repeated id are skipped;
/// meaningful on consistently oriented meshes (validate_mesh).
std::vector<int> inward_closed_parts(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);
/// The sentence `gshell info` and generation's warnings give for inward_closed_parts' result
/// (empty when it is empty).
std::string inward_closed_parts_message(const std::vector<int>& parts);

} // namespace gshell
