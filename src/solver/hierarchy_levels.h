#pragma once
// The reduced levels of the hierarchical solver: the problem over per-cluster affine maps. (The
// full level is a ShellSolver.) The local step (rotations, energy) goes into a cache object, so the
// caller can evaluate a candidate state and keep or drop it.
#include "hierarchy_linear.h"

#include <gshell/solver/cluster_weights.h>
#include <gshell/solver/hierarchical_solver.h>

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

namespace gshell::detail {

/// Result of a reduced level's local step: the rotations as the 3x3 operands Q of the global
/// step's right-hand side (see ReducedLevel::local), and the elastic energy (no springs).
struct LocalCache {
  std::vector<Eigen::Matrix3d> Q;
  /// Exact border-tet rotations only: per cluster interior, then per border tet, the energy
  /// (kept here so that its storage is reused from one local step to the next).
  std::vector<double> element_energy;
  double elastic = 0;
  bool energy_valid = false; ///< `elastic` was computed along with Q
};

/// Gradient rows g_k (F = sum_k x_k g_k^T) of a tet from its inverse rest edge matrix.
inline Eigen::Matrix<double, 4, 3> gradient_rows(const Eigen::Matrix3d& Dm_inv) {
  Eigen::Matrix<double, 4, 3> G;
  G.row(0) = -Dm_inv.colwise().sum();
  G.bottomRows(3) = Dm_inv;
  return G;
}

/// Stiffness matrix L = sum_t vol_t G_t^T G_t over `num_vertices` (one coordinate; same for x, y, z).
Eigen::SparseMatrix<double> stiffness_matrix(const RestTets& rest, int num_vertices);

/// Rigid change of one cluster between two affine maps: y -> dR (y - from) + to, where dR is the
/// rotation change and from/to the cluster centroid's positions before and after.
struct RigidChange {
  Eigen::Matrix3d dR = Eigen::Matrix3d::Identity();
  Eigen::Vector3d from = Eigen::Vector3d::Zero(), to = Eigen::Vector3d::Zero();
  Eigen::Vector3d apply(const Eigen::Vector3d& y) const { return dR * (y - from) + to; }
};

class ReducedLevel {
public:
  /// `weights` blend the clusters' affine maps at every base vertex; top vertex n+i takes base
  /// vertex i's weights. `home[i]` is the cluster holding base vertex i in the tree (the owner of
  /// the tets at its corner 0, and whose rigid change the paper coupling applies to it).
  /// `weight` is the absolute spring weight of the constraints on this level.
  /// With `cluster_rotations`, every tet takes the rotation of the cluster that owns it (the
  /// home cluster of its corner 0), border tets included: then the local step and the
  /// right-hand side come from precomputed per-cluster-pair matrices and cost O(cluster pairs),
  /// not O(tets). Without, every tet whose corners are not all moved by one cluster alone gets its
  /// own rotation (the exact subspace energy).
  ReducedLevel(const RestTets& rest, const Eigen::MatrixXd& rest_vertices, const ClusterWeights& weights,
               const std::vector<int>& home, const Eigen::SparseMatrix<double>& L, const std::vector<int>& constrained,
               double weight, bool cluster_rotations);

  int num_clusters() const { return m_; }
  /// The root mean square distance of the rest vertices from their clusters' centroids (model
  /// units): how far a unit change of a map row moves them, which a translation row moves them
  /// by itself (extrapolate_parameters).
  double cluster_radius() const { return cluster_radius_; }
  void reset();                                   ///< identity maps (the rest shape)
  const Eigen::MatrixXd& parameters() const { return Z_; }
  Eigen::MatrixXd& parameters() { return Z_; }
  Eigen::Matrix3d map(int cluster) const { return Z_.block(4 * cluster, 0, 3, 3).transpose(); }
  Eigen::Vector3d translation(int cluster) const { return Z_.row(4 * cluster + 3).transpose(); }
  Eigen::Vector3d position(int v) const;
  Eigen::MatrixXd positions() const;              ///< B z, all 2n vertices
  Eigen::MatrixXd positions(const Eigen::MatrixXd& parameters) const; ///< B z for other parameters
  int cluster_of_vertex(int v) const { return home_[v]; } ///< home cluster
  const ClusterWeights& weights() const { return weights_; }

  /// Q: one per cluster (R^T with cluster rotations, else interior volume * R^T), then one per border tet.
  /// Without `with_energy` (cluster rotations only) the energies are left out and marked invalid.
  void local(LocalCache& cache, bool with_energy = true) const;
  double springs(const Eigen::MatrixXd& targets) const;
  /// Right-hand side B^T (b(R) + springs) of the reduced global step for the rotations of `cache`.
  Eigen::MatrixXd rhs(const Eigen::MatrixXd& targets, const LocalCache& cache) const;
  /// Parameters <- A^-1 rhs: the exact minimiser in the subspace for fixed rotations.
  void solve(const Eigen::MatrixXd& rhs);
  /// Half the reduced energy gradient A z - rhs at the current parameters (cache taken there).
  Eigen::MatrixXd half_gradient(const Eigen::MatrixXd& targets, const LocalCache& cache) const;
  /// Parameters <- the least-squares fit B z = X to positions X (2n x 3).
  void fit(const Eigen::MatrixXd& X);
  /// B^T g for a per-vertex field g (2n x 3): how a fine-level force acts on the affine maps.
  Eigen::MatrixXd restrict_field(const Eigen::MatrixXd& g) const;

  /// B^T g of this level from B_f^T g of a finer level whose clusters nest in these
  /// (parent_of[c] = this level's cluster holding the finer cluster c, as the levels of one
  /// cluster tree with piecewise weights): O(clusters) instead of a pass over the vertices, since
  /// [u - c_p; 1] = [u - c_c; 1] + [c_c - c_p; 0] for every vertex u of a finer cluster c in p.
  Eigen::MatrixXd coarsen(const Eigen::MatrixXd& finer_restricted, const ReducedLevel& finer,
                          const std::vector<int>& parent_of) const;
  /// Parameters <- the least-squares fit to positions X, given B^T X (fit(X) is fit_restricted(B^T X)).
  void fit_restricted(const Eigen::MatrixXd& restricted);

  /// Per-cluster rigid change from parameters `before` to the current ones.
  std::vector<RigidChange> changes_since(const Eigen::MatrixXd& before) const;
  /// Adds the parent level's change since `parent_before`, whose clusters hold these
  /// (parent_of[c] = the parent's cluster holding cluster c): every cluster takes its parent's
  /// affine change re-expressed about its own centroid, so the vertices move exactly as the
  /// parent moves them (piecewise maps on nested clusters; O(clusters)).
  void apply_change(const ReducedLevel& parent, const Eigen::MatrixXd& parent_before, const std::vector<int>& parent_of);
  /// Applies each parent's rigid change to this level's clusters (parent_of[c] = parent cluster).
  void apply(const std::vector<RigidChange>& parent_change, const std::vector<int>& parent_of);

private:
  const RestTets& rest_;
  int N_, n_, m_;
  ClusterWeights weights_;
  std::vector<int> home_;                    // per shell vertex
  Eigen::MatrixXd coords_;                   // per weight entry e and surface s (row 2e + s): u - c_cluster
  double cluster_radius_ = 1;                // see cluster_radius()
  Eigen::VectorXd interior_volume_;          // per cluster
  std::vector<int> border_;                  // tets not moved by one cluster alone (exact rotations)
  Eigen::MatrixXd centroid_;                 // rest centroid per cluster (weighted)
  std::vector<int> constrained_;
  double weight_;
  Eigen::SparseMatrix<double, Eigen::RowMajor> B_, Bt_; // x = B z (2n x 4m) and its transpose
  Eigen::SparseMatrix<double> A_;
  SpdSolver solver_;
  SpdSolver fit_solver_;                     // B^T B
  Eigen::MatrixXd Z_, Z_rest_;

  // Cluster rotations: sum over the tets owned by cluster j of vol F_t = sum_i Z_i^T W_ji, with
  // W_ji = sum over those tets' corners k and the weights w_ki of cluster i there of
  // vol w_ki [u_k - c_i; 1] g_k^T (4x3).
  struct Pair {
    int cluster; // i
    Eigen::Matrix<double, 4, 3> W;
  };
  bool cluster_rotations_;
  std::vector<int> pair_start_;  // per owner cluster j, into pairs_
  std::vector<Pair> pairs_;
  Eigen::SparseMatrix<double> A_elastic_; // B^T L B: sum vol ||F_t||^2 = tr(Z^T A_elastic Z)
  double total_volume_ = 0;
  int base_of(int v) const { return v < n_ ? v : v - n_; }
  /// [u_v - c_j; 1] of weight entry e at shell vertex v.
  Eigen::Vector4d lifted(int e, int v) const {
    Eigen::Vector4d u;
    u << coords_.row(2 * e + (v < n_ ? 0 : 1)).transpose(), 1.0;
    return u;
  }
  void build_pairs();
  void local_cluster_rotations(LocalCache& cache, bool with_energy) const;
};

} // namespace gshell::detail
