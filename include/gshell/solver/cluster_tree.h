#pragma once
// The cluster hierarchy of the hierarchical solver (paper §5.1; docs/design.md "Hierarchical
// dimension reduction"): built top-down over the base vertices by recursive bisection; top vertex i
// always belongs to the cluster of base vertex i.
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <vector>

namespace gshell {

struct ClusterTreeOptions {
  int depth = 6;            ///< bisection rounds below the root: depth d has at most 2^d clusters
  int min_cluster_size = 8; ///< a cluster is split only if both halves keep this many base vertices
};

/// Clusters of base vertices at every depth 0..depth. Depth 0 is a single cluster; a cluster of
/// depth d+1 is one half of its parent, or a copy of it when the parent could not be split (too
/// small, or a half would be flat), so every depth covers every vertex exactly once.
struct ClusterTree {
  std::vector<std::vector<int>> cluster_of; ///< [d][i]: cluster of base vertex i at depth d
  std::vector<std::vector<int>> parent;     ///< [d][c]: cluster of depth d-1 holding cluster c of depth d (-1 at d = 0)
  /// Whether the root's base and top vertices span 3D. Every cluster below it does when it does
  /// (a half is kept only if it does); where not (a flat shell, top = base) no cluster's affine
  /// map is determined and no reduced level can be built on the tree.
  bool spans_3d = true;

  int num_depths() const { return static_cast<int>(parent.size()); }
  int num_clusters(int d) const { return static_cast<int>(parent[d].size()); }
  /// Base vertex ids of every cluster of depth d.
  std::vector<std::vector<int>> members(int d) const;
};

/// Splits every cluster at the median of its base vertices along their principal axis (largest
/// spread) into two halves of equal size (+-1). Vertex fragments that a cut leaves disconnected
/// from the rest of their half are handed to the other half when they touch it and the halves stay
/// within a factor 1.5 in size, so clusters stay connected where the mesh allows.
/// `shell_rest` holds the 2n rest shell vertices (base rows 0..n-1, top rows n..2n-1): a half is
/// kept only if its base and top vertices span 3D, so its affine map is determined.
/// `F` (base faces) gives the connectivity.
ClusterTree build_cluster_tree(const Eigen::MatrixXd& shell_rest, const Eigen::MatrixXi& F,
                               const ClusterTreeOptions& options = {});

} // namespace gshell
