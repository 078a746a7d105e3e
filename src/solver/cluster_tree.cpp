#include <gshell/solver/cluster_tree.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <numeric>

namespace gshell {

std::vector<std::vector<int>> ClusterTree::members(int d) const {
  std::vector<std::vector<int>> out(num_clusters(d));
  for (int i = 0; i < static_cast<int>(cluster_of[d].size()); ++i) out[cluster_of[d][i]].push_back(i);
  return out;
}

namespace {

using Adjacency = std::vector<std::vector<int>>;

Adjacency base_adjacency(int n, const Eigen::MatrixXi& F) {
  Adjacency adj(n);
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      adj[a].push_back(b);
      adj[b].push_back(a);
    }
  for (auto& list : adj) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  return adj;
}

Eigen::Vector3d principal_axis(const Eigen::MatrixXd& X, const std::vector<int>& ids) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i : ids) mean += X.row(i).transpose();
  mean /= static_cast<double>(ids.size());
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (int i : ids) {
    const Eigen::Vector3d d = X.row(i).transpose() - mean;
    C += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(C);
  return eig.eigenvectors().col(2); // eigenvalues ascend
}

/// An affine map of the cluster is determined only if its base and top vertices span 3D.
bool spans_3d(const Eigen::MatrixXd& shell_rest, int n, const std::vector<int>& ids) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i : ids) mean += shell_rest.row(i).transpose() + shell_rest.row(n + i).transpose();
  mean /= 2.0 * static_cast<double>(ids.size());
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (int i : ids)
    for (int v : {i, n + i}) {
      const Eigen::Vector3d d = shell_rest.row(v).transpose() - mean;
      C += d * d.transpose();
    }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(C);
  const Eigen::Vector3d l = eig.eigenvalues();
  return l(2) > 0 && l(0) > 1e-12 * l(2);
}

/// Connected pieces of `part` in the mesh graph, largest first. `side` marks membership.
std::vector<std::vector<int>> pieces(const std::vector<int>& part, const Adjacency& adj,
                                     const std::vector<signed char>& side, signed char which,
                                     std::vector<int>& seen, int stamp) {
  std::vector<std::vector<int>> out;
  for (int s : part) {
    if (seen[s] == stamp) continue;
    std::vector<int> piece{s};
    seen[s] = stamp;
    for (size_t k = 0; k < piece.size(); ++k)
      for (int nb : adj[piece[k]])
        if (side[nb] == which && seen[nb] != stamp) {
          seen[nb] = stamp;
          piece.push_back(nb);
        }
    out.push_back(std::move(piece));
  }
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
  return out;
}

/// Hands stray pieces of half `from` to half `to` when they touch it and sizes stay balanced.
void hand_over_fragments(std::vector<int>& from, std::vector<int>& to, signed char from_side,
                         signed char to_side, const Adjacency& adj, std::vector<signed char>& side,
                         std::vector<int>& seen, int& stamp) {
  constexpr double kMaxRatio = 1.5;
  auto parts = pieces(from, adj, side, from_side, seen, ++stamp);
  if (parts.size() < 2) return;
  for (size_t p = 1; p < parts.size(); ++p) {
    const auto& piece = parts[p];
    bool touches = false;
    for (int v : piece)
      for (int nb : adj[v]) touches = touches || side[nb] == to_side;
    const double a = static_cast<double>(from.size() - piece.size()), b = static_cast<double>(to.size() + piece.size());
    if (!touches || std::max(a, b) > kMaxRatio * std::min(a, b)) continue;
    for (int v : piece) side[v] = to_side;
    to.insert(to.end(), piece.begin(), piece.end());
    std::vector<int> kept;
    kept.reserve(from.size());
    for (int v : from)
      if (side[v] == from_side) kept.push_back(v);
    from.swap(kept);
  }
}

} // namespace

ClusterTree build_cluster_tree(const Eigen::MatrixXd& shell_rest, const Eigen::MatrixXi& F,
                               const ClusterTreeOptions& options) {
  const int n = static_cast<int>(shell_rest.rows() / 2);
  const Adjacency adj = base_adjacency(n, F);
  const int min_size = std::max(2, options.min_cluster_size);

  ClusterTree tree;
  std::vector<std::vector<int>> clusters(1);
  clusters[0].resize(n);
  std::iota(clusters[0].begin(), clusters[0].end(), 0);
  tree.spans_3d = n > 0 && spans_3d(shell_rest, n, clusters[0]);
  tree.cluster_of.emplace_back(n, 0);
  tree.parent.push_back({-1});

  // side[v]: 0 outside the cluster being split, 1 / 2 its two halves
  std::vector<signed char> side(n, 0);
  std::vector<int> seen(n, -1);
  int stamp = 0;
  for (int d = 1; d <= options.depth; ++d) {
    std::vector<std::vector<int>> next;
    std::vector<int> parent;
    for (int c = 0; c < static_cast<int>(clusters.size()); ++c) {
      std::vector<int>& ids = clusters[c];
      bool split = static_cast<int>(ids.size()) >= 2 * min_size;
      std::vector<int> a, b;
      if (split) {
        const Eigen::Vector3d axis = principal_axis(shell_rest, ids);
        std::vector<std::pair<double, int>> key;
        key.reserve(ids.size());
        for (int i : ids) key.emplace_back(shell_rest.row(i).dot(axis), i);
        const size_t half = ids.size() / 2;
        std::nth_element(key.begin(), key.begin() + half, key.end());
        for (size_t k = 0; k < key.size(); ++k) (k < half ? a : b).push_back(key[k].second);
        for (int i : a) side[i] = 1;
        for (int i : b) side[i] = 2;
        hand_over_fragments(a, b, 1, 2, adj, side, seen, stamp);
        hand_over_fragments(b, a, 2, 1, adj, side, seen, stamp);
        for (int i : ids) side[i] = 0;
        split = static_cast<int>(std::min(a.size(), b.size())) >= min_size && spans_3d(shell_rest, n, a) &&
                spans_3d(shell_rest, n, b);
      }
      if (split) {
        std::sort(a.begin(), a.end());
        std::sort(b.begin(), b.end());
        next.push_back(std::move(a));
        next.push_back(std::move(b));
        parent.push_back(c);
        parent.push_back(c);
      } else {
        next.push_back(ids);
        parent.push_back(c);
      }
    }
    std::vector<int> of(n);
    for (int c = 0; c < static_cast<int>(next.size()); ++c)
      for (int i : next[c]) of[i] = c;
    tree.cluster_of.push_back(std::move(of));
    tree.parent.push_back(std::move(parent));
    clusters = std::move(next);
  }
  return tree;
}

} // namespace gshell
