#pragma once
// A smoothed-aggregation algebraic multigrid V-cycle for symmetric positive definite sparse
// matrices with the graph of a mesh, used as the conjugate gradient preconditioner of the shell
// solver's global step (docs/scale.md "The multigrid preconditioner"). Precompute the hierarchy
// once from the matrix, then apply one V-cycle to many residuals, several columns at once (the
// shell system has one matrix for the x, y and z columns).
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <vector>

namespace gshell {

struct MultigridOptions {
  /// Coarsening stops at this many rows (or when a level no longer shrinks by a quarter); that
  /// level is solved exactly by a sparse Cholesky factor.
  int coarsest_rows = 2000;
  /// Connection i-j is strong, and may join i and j into one aggregate, when
  /// |a_ij| >= strength sqrt(a_ii a_jj). Halved on every coarser level (their stencils are wider).
  double strength = 0.08;
  /// Degree of the Chebyshev polynomial in D^-1 A used as smoother, once before and once after
  /// the coarse correction (the same polynomial both times, so the V-cycle is symmetric).
  int smoothing_degree = 2;
};

/// Per level: rows and stored non-zeros of its matrix (level 0 is the input).
struct MultigridLevelInfo {
  int rows = 0;
  long long nonzeros = 0;
};

class AggregationMultigrid {
public:
  /// `A`: symmetric positive definite, both triangles stored, kept as the finest level: the
  /// rvalue overload takes its storage over (swapped out, `A` is left empty), the other copies it.
  /// (Eigen 3.4's SparseMatrix has no move constructor: std::move alone would copy it.) Each
  /// level aggregates the strongly
  /// connected neighbourhoods of the previous one's matrix graph; the prolongation is the
  /// piecewise-constant one smoothed by a damped Jacobi step, (I - 4/3 rho^-1 D^-1 A) P_tent, and
  /// the coarse matrix is the Galerkin product P^T A P.
  /// \throws InputError when A is not square or has a non-positive diagonal entry, or the options
  ///         are out of range (coarsest_rows < 1, strength outside [0, 1), degree < 1);
  ///         std::runtime_error when the coarsest matrix is not positive definite.
  explicit AggregationMultigrid(Eigen::SparseMatrix<double, Eigen::RowMajor>&& A,
                                const MultigridOptions& options = {});
  explicit AggregationMultigrid(const Eigen::SparseMatrix<double, Eigen::RowMajor>& A,
                                const MultigridOptions& options = {});
  ~AggregationMultigrid();
  AggregationMultigrid(AggregationMultigrid&&) noexcept;
  AggregationMultigrid& operator=(AggregationMultigrid&&) noexcept;

  /// Z <- M^-1 R for one V-cycle M^-1 (a fixed linear map, symmetric positive definite for an SPD
  /// A), every column of R independently. R and Z are n x k (k >= 1) and must not alias.
  /// Calls are serialised (the cycle's work vectors are shared).
  /// \throws InputError when R does not have n rows or Z is not R's shape.
  void apply(const Eigen::Ref<const Eigen::MatrixXd>& R, Eigen::Ref<Eigen::MatrixXd> Z) const;

  int rows() const;
  /// The finest level's matrix: A as given (compressed). A caller that handed its matrix over
  /// reads it here rather than keeping a copy.
  const Eigen::SparseMatrix<double, Eigen::RowMajor>& matrix() const;
  std::vector<MultigridLevelInfo> levels() const;
  double setup_seconds() const; ///< wall time of the constructor

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace gshell
