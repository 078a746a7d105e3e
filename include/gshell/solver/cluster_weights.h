#pragma once
// How the clusters of one depth of a cluster tree move the vertices: every base vertex i (and top
// vertex n+i with it) follows a weighted blend of the affine maps of nearby clusters,
// x_i = sum_j w_ij (M_j (u_i - c_j) + t_j), with weights that sum to 1 (a partition of unity, so
// one affine map shared by all clusters moves the whole shell by that map).
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

/// Smooth partition of unity: cluster j's raw weight at base vertex i is phi(d_ij / h_j), with d_ij
/// the shortest-path distance along base mesh edges from i to the nearest vertex of j (0 inside j),
/// h_j = `width` times j's RMS radius (root mean square distance of its base vertices from their
/// centroid) and phi(s) = (1 - s^2)^2 for s < 1, else 0; the raw weights are divided by their sum.
/// So a vertex keeps raw weight 1 for its own cluster, weights fall smoothly (zero slope at both
/// ends) across a band of width h_j around each cluster, and only clusters within h_j of a vertex
/// act on it. `base` is n x 3 (rest base vertices), `F` the base faces, `width` > 0.
/// \throws InputError when `width` is not > 0.
ClusterWeights blended_cluster_weights(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F,
                                       const std::vector<int>& cluster_of, int num_clusters, double width);

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
