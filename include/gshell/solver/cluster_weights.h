#pragma once
// How the clusters of one depth of a cluster tree move the vertices: every base vertex i (and top
// vertex n+i with it) follows a weighted blend of the affine maps of nearby clusters,
// x_i = sum_j w_ij (M_j (u_i - c_j) + t_j), with weights that sum to 1 (a partition of unity, so
// one affine map shared by all clusters moves the whole shell by that map). The hierarchy uses
// piecewise weights (each vertex follows its own cluster); a smooth blend across seams was tried
// and removed: it never paid for its denser reduced matrices (docs/design.md).
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

namespace gshell {

/// Sparse per-vertex weights over the clusters of one depth.
struct ClusterWeights {
  int num_clusters = 0;
  std::vector<int> start;      ///< base vertex i has the entries start[i] .. start[i+1]-1
  std::vector<int> cluster;    ///< cluster of an entry
  std::vector<double> weight;  ///< its weight (> 0; a vertex's weights sum to 1)

  int num_vertices() const { return static_cast<int>(start.size()) - 1; }
  /// Weight of cluster j at base vertex i (0 when j has no entry there).
  double at(int i, int j) const;
};

/// Weight 1 for the cluster that holds the vertex: piecewise affine maps (the paper's subspace).
ClusterWeights piecewise_cluster_weights(const std::vector<int>& cluster_of, int num_clusters);

/// Rest centroid of every cluster, weighted like its map acts: c_j = sum_v w_vj u_v / sum_v w_vj
/// over the 2n shell vertices `rest_vertices` (base rows 0..n-1, then top; top vertex n+i takes
/// base vertex i's weights). m x 3.
Eigen::MatrixXd cluster_centroids(const ClusterWeights& weights, const Eigen::MatrixXd& rest_vertices);

/// The prolongation B (2n x 4m) from the clusters' affine maps to the shell's vertices:
/// x_v^T = sum_j w_vj [(u_v - c_j)^T 1] Z_j, Z_j = [M_j^T; t_j^T] rows 4j..4j+3 of z (4m x 3),
/// so X = B z. Because the weights sum to 1 at every vertex, maps that all describe one affine
/// motion x = A u + b (M_j = A, t_j = A c_j + b) move every vertex by exactly that motion.
/// \throws InputError when the sizes of `weights`, `rest_vertices` (2n x 3) and `centroids`
/// (m x 3) do not match.
Eigen::SparseMatrix<double> prolongation_matrix(const ClusterWeights& weights, const Eigen::MatrixXd& rest_vertices,
                                                const Eigen::MatrixXd& centroids);

} // namespace gshell
