#include <gshell/solver/cluster_weights.h>

#include <gshell/error.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <string>
#include <utility>

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

ClusterWeights blended_cluster_weights(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F,
                                       const std::vector<int>& cluster_of, int num_clusters, double width) {
  if (!(width > 0)) throw InputError("blended_cluster_weights: width must be > 0 (got " + std::to_string(width) + ")");
  const int n = static_cast<int>(base.rows());
  // Edge graph of the base mesh with rest lengths.
  std::vector<std::vector<std::pair<int, double>>> adjacency(n);
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      const double length = (base.row(a) - base.row(b)).norm();
      adjacency[a].emplace_back(b, length);
      adjacency[b].emplace_back(a, length);
    }
  std::vector<std::vector<int>> members(num_clusters);
  for (int i = 0; i < n; ++i) members[cluster_of[i]].push_back(i);

  // Raw weights per vertex: a bounded multi-source Dijkstra from every cluster.
  std::vector<std::vector<std::pair<int, double>>> raw(n);
  constexpr double kFar = std::numeric_limits<double>::infinity();
  std::vector<double> distance(n, kFar);
  std::vector<int> reached;
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  for (int j = 0; j < num_clusters; ++j) {
    if (members[j].empty()) continue;
    Eigen::RowVector3d centroid = Eigen::RowVector3d::Zero();
    for (int i : members[j]) centroid += base.row(i);
    centroid /= static_cast<double>(members[j].size());
    double spread = 0;
    for (int i : members[j]) spread += (base.row(i) - centroid).squaredNorm();
    const double h = width * std::sqrt(spread / static_cast<double>(members[j].size()));
    for (int i : members[j]) {
      distance[i] = 0;
      reached.push_back(i);
      queue.emplace(0.0, i);
    }
    while (!queue.empty()) {
      const auto [d, v] = queue.top();
      queue.pop();
      if (d > distance[v]) continue;
      for (const auto& [u, length] : adjacency[v]) {
        const double next = d + length;
        if (next < distance[u] && next < h) {
          if (distance[u] == kFar) reached.push_back(u);
          distance[u] = next;
          queue.emplace(next, u);
        }
      }
    }
    for (int v : reached) {
      const double s = h > 0 ? distance[v] / h : 0.0;
      const double phi = (1 - s * s) * (1 - s * s);
      if (phi > 0) raw[v].emplace_back(j, phi);
      distance[v] = kFar;
    }
    reached.clear();
  }

  ClusterWeights w;
  w.num_clusters = num_clusters;
  w.start.assign(n + 1, 0);
  for (int i = 0; i < n; ++i) {
    auto& list = raw[i];
    std::sort(list.begin(), list.end());
    double sum = 0;
    for (const auto& e : list) sum += e.second;
    for (const auto& [j, phi] : list) {
      w.cluster.push_back(j);
      w.weight.push_back(phi / sum);
    }
    w.start[i + 1] = static_cast<int>(w.cluster.size());
  }
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
