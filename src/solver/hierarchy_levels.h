#pragma once
// The reduced levels of the hierarchical solver: the problem over per-cluster affine maps. (The
// full level is a ShellSolver.) The local step (rotations, energy) goes into a cache object, so the
// caller can evaluate a candidate state and keep or drop it.
#include "hierarchy_linear.h"

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
  /// `cluster_of_base[i]` in 0..num_clusters-1; top vertex n+i shares base vertex i's cluster.
  /// `weight` is the absolute spring weight of the constraints on this level.
  /// With `cluster_rotations`, every tet takes the rotation of the cluster that owns it (the
  /// cluster of its corner 0), border tets included: then the local step and the right-hand side
  /// come from precomputed per-cluster-pair matrices and cost O(cluster pairs), not O(tets).
  /// Without, tets across cluster borders get their own rotation (the exact subspace energy).
  ReducedLevel(const RestTets& rest, const Eigen::MatrixXd& rest_vertices, const std::vector<int>& cluster_of_base,
               int num_clusters, const Eigen::SparseMatrix<double>& L, const std::vector<int>& constrained,
               double weight, bool cluster_rotations);

  int num_clusters() const { return m_; }
  void reset();                                   ///< identity maps (the rest shape)
  const Eigen::MatrixXd& parameters() const { return Z_; }
  Eigen::MatrixXd& parameters() { return Z_; }
  Eigen::Matrix3d map(int cluster) const { return Z_.block(4 * cluster, 0, 3, 3).transpose(); }
  Eigen::Vector3d translation(int cluster) const { return Z_.row(4 * cluster + 3).transpose(); }
  Eigen::Vector3d position(int v) const;
  Eigen::MatrixXd positions() const;              ///< B z, all 2n vertices
  Eigen::MatrixXd positions(const Eigen::MatrixXd& parameters) const; ///< B z for other parameters
  int cluster_of_vertex(int v) const { return cluster_[v]; }

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
  /// Parameters <- the least-squares affine fit of every cluster to positions X (2n x 3).
  void fit(const Eigen::MatrixXd& X);
  /// B^T g for a per-vertex field g (2n x 3): how a fine-level force acts on the affine maps.
  Eigen::MatrixXd restrict_field(const Eigen::MatrixXd& g) const;

  /// Per-cluster rigid change from parameters `before` to the current ones.
  std::vector<RigidChange> changes_since(const Eigen::MatrixXd& before) const;
  /// Adds the parent level's affine change since `parent_before` to this level's maps (the
  /// exact embedding: the parent's subspace lies inside this one).
  void apply_affine(const ReducedLevel& parent, const Eigen::MatrixXd& parent_before, const std::vector<int>& parent_of);
  /// Applies each parent's rigid change to this level's clusters (parent_of[c] = parent cluster).
  void apply(const std::vector<RigidChange>& parent_change, const std::vector<int>& parent_of);

private:
  const RestTets& rest_;
  int N_, m_;
  std::vector<int> cluster_;                 // per shell vertex
  Eigen::MatrixXd local_coords_;             // u_v - c_cluster(v)
  Eigen::VectorXd interior_volume_;          // per cluster
  struct BorderTet {                          // a tet spanning several clusters
    int tet;
    int cluster[4];
    Eigen::Vector3d coords[4];                // corner's u - c_cluster
  };
  std::vector<BorderTet> border_;
  Eigen::MatrixXd centroid_;                  // rest centroid per cluster
  std::vector<int> constrained_;
  double weight_;
  Eigen::SparseMatrix<double> A_;
  std::vector<Eigen::Matrix4d> fit_inverse_;  // per cluster (sum_v [u_v - c; 1][u_v - c; 1]^T)^-1
  SpdSolver solver_;
  Eigen::MatrixXd Z_, Z_rest_;

  // Cluster rotations: sum over the tets owned by cluster j of vol F_t = sum_i Z_i^T W_ji, with
  // W_ji = sum over those tets' corners k in cluster i of vol [u_k - c_i; 1] g_k^T (4x3).
  struct Pair {
    int cluster; // i
    Eigen::Matrix<double, 4, 3> W;
  };
  bool cluster_rotations_;
  std::vector<int> pair_start_;  // per owner cluster j, into pairs_
  std::vector<Pair> pairs_;
  Eigen::SparseMatrix<double> A_elastic_; // B^T L B: sum vol ||F_t||^2 = tr(Z^T A_elastic Z)
  double total_volume_ = 0;
  void build_pairs();
  void local_cluster_rotations(LocalCache& cache, bool with_energy) const;
};

} // namespace gshell::detail
