#include <gshell/solver/cluster_weights.h>

#include <gshell/error.h>

#include <algorithm>
#include <string>

namespace gshell {

double ClusterWeights::at(int i, int j) const {
  for (int e = start[i]; e < start[i + 1]; ++e)
    if (cluster[e] == j) return weight[e];
  return 0;
}

ClusterWeights piecewise_cluster_weights(const std::vector<int>& cluster_of, int num_clusters) {
  ClusterWeights w;
  w.num_clusters = num_clusters;
  const int n = static_cast<int>(cluster_of.size());
  w.start.resize(n + 1);
  for (int i = 0; i <= n; ++i) w.start[i] = i;
  w.cluster = cluster_of;
  w.weight.assign(n, 1.0);
  return w;
}

Eigen::MatrixXd cluster_centroids(const ClusterWeights& weights, const Eigen::MatrixXd& rest_vertices) {
  const int n = weights.num_vertices();
  if (rest_vertices.rows() != 2 * n || rest_vertices.cols() != 3)
    throw InputError("cluster_centroids: rest_vertices must be " + std::to_string(2 * n) + " x 3 (base, then top)");
  Eigen::MatrixXd centroid = Eigen::MatrixXd::Zero(weights.num_clusters, 3);
  Eigen::VectorXd mass = Eigen::VectorXd::Zero(weights.num_clusters);
  for (int v = 0; v < 2 * n; ++v) {
    const int i = v < n ? v : v - n;
    for (int e = weights.start[i]; e < weights.start[i + 1]; ++e) {
      centroid.row(weights.cluster[e]) += weights.weight[e] * rest_vertices.row(v);
      mass(weights.cluster[e]) += weights.weight[e];
    }
  }
  for (int j = 0; j < weights.num_clusters; ++j) centroid.row(j) /= std::max(1e-300, mass(j));
  return centroid;
}

Eigen::SparseMatrix<double> prolongation_matrix(const ClusterWeights& weights, const Eigen::MatrixXd& rest_vertices,
                                                const Eigen::MatrixXd& centroids) {
  const int n = weights.num_vertices(), m = weights.num_clusters;
  if (rest_vertices.rows() != 2 * n || rest_vertices.cols() != 3)
    throw InputError("prolongation_matrix: rest_vertices must be " + std::to_string(2 * n) + " x 3 (base, then top)");
  if (centroids.rows() != m || centroids.cols() != 3)
    throw InputError("prolongation_matrix: centroids must be " + std::to_string(m) + " x 3 (one per cluster)");
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(8 * weights.cluster.size());
  for (int v = 0; v < 2 * n; ++v) {
    const int i = v < n ? v : v - n;
    for (int e = weights.start[i]; e < weights.start[i + 1]; ++e) {
      const int j = weights.cluster[e];
      const double w = weights.weight[e];
      for (int k = 0; k < 3; ++k) entries.emplace_back(v, 4 * j + k, w * (rest_vertices(v, k) - centroids(j, k)));
      entries.emplace_back(v, 4 * j + 3, w);
    }
  }
  Eigen::SparseMatrix<double> B(2 * n, 4 * m);
  B.setFromTriplets(entries.begin(), entries.end());
  return B;
}

} // namespace gshell
