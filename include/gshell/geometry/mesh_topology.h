#pragma once
#include <gshell/mesh.h>
#include <Eigen/Core>

namespace gshell {

/// Counts and sizes reported by `gshell info`. Preconditions: indices in range.
struct MeshStats {
  int vertices = 0, faces = 0, edges = 0;
  int boundary_loops = 0, components = 0;
  int euler_characteristic = 0; ///< V - E + F
  double genus = 0;             ///< (2*components - boundary_loops - chi) / 2 for orientable meshes
  Eigen::Vector3d bbox_min = Eigen::Vector3d::Zero(), bbox_max = Eigen::Vector3d::Zero();
  double mean_edge_length = 0;
};

MeshStats mesh_stats(const TriMesh& mesh);

/// Unique undirected edges (E x 2, smaller id first), in order of first appearance.
Eigen::MatrixXi unique_edges(const Eigen::MatrixXi& F);

} // namespace gshell
