#pragma once
// The local/global solver for E(x) = sum_t vol_t ||F_t(x) - R_t||_F^2 (+ soft constraints),
// docs/design.md "The energy" and "The solver". Precompute once from rest shapes and the
// constrained vertex set, then solve from many start states (generation, every frame of a
// deformation, every drag step).
#include <gshell/solver/rest_tets.h>

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <vector>

namespace gshell {

struct SolveOptions {
  int max_iterations = 50;
  double tolerance = 1e-5; ///< stop when |E_k - E_{k-1}| / E_{k-1} < tolerance
  /// Called after every iteration with (iteration, energy, seconds since solve started).
  std::function<void(int, double, double)> progress;
};

struct SolveResult {
  int iterations = 0;             ///< local/global iterations done
  std::vector<double> energy;     ///< energy[0] = start state, then one per iteration
  bool converged = false;         ///< stopped by tolerance (not by max_iterations)
  double seconds = 0;
  double local_seconds = 0;  ///< of which local steps (rotations, energy, right-hand sides)
  double global_seconds = 0; ///< of which global steps (gather, back-substitution, scatter)
};

/// The rotations found by one local step, folded into the operands of the next global step.
struct LocalStep {
  std::vector<double> Q; ///< per tet, vol * Dm_inv * R^T (row-major 3x3)
  double energy = 0;     ///< E at the state the step was taken at (soft term included)
};

/// Soft positional constraints: w * sum_c ||x_c - p_c||^2 over `vertices` (targets at solve).
struct SoftConstraints {
  std::vector<int> vertices;
  double weight = 0;
};

class ShellSolver {
public:
  /// \throws InputError when `rest` is incomplete (Dm_inv or volume missing), a tet, fixed or soft
  ///         vertex id is outside [0, num_vertices), or the system is singular (a connected part
  ///         of the tets has no fixed or constrained vertex). std::runtime_error when CHOLMOD
  ///         fails otherwise (out of memory).
  /// `num_vertices` = rows of the state; `fixed` vertices keep their start positions exactly
  /// (eliminated from the system). The system matrix is assembled and factored here, once.
  ShellSolver(const RestTets& rest, int num_vertices, const std::vector<int>& fixed,
              const SoftConstraints& soft = {});
  ~ShellSolver();
  ShellSolver(ShellSolver&&) noexcept;
  ShellSolver& operator=(ShellSolver&&) noexcept;

  /// Local/global iterations from X (num_vertices x 3, fixed rows hold their prescribed
  /// positions); X is overwritten with the result. `soft_targets` (|soft.vertices| x 3) is
  /// required iff soft constraints were given. The energy never increases between iterations.
  /// \throws InputError when X is not num_vertices x 3, soft_targets has the wrong shape or
  ///         options.max_iterations < 0 (X is then unchanged).
  SolveResult solve(Eigen::MatrixXd& X, const SolveOptions& options = {},
                    const Eigen::MatrixXd& soft_targets = {}) const;

  /// E(X) including the soft term (if soft_targets are given).
  /// \throws InputError when X is not num_vertices x 3 or soft_targets has the wrong shape (this and
  ///         the three functions below).
  double energy(const Eigen::MatrixXd& X, const Eigen::MatrixXd& soft_targets = {}) const;

  /// The two halves of an iteration, for drivers that combine iterates (Anderson acceleration,
  /// the hierarchical solver's coarse corrections). local_step: rotations and E at X.
  void local_step(const Eigen::MatrixXd& X, LocalStep& step, const Eigen::MatrixXd& soft_targets = {}) const;
  /// X's free rows <- the minimiser of E for the rotations of `step`; the kept rows are only read.
  /// \throws InputError also when `step` was not taken by this solver (wrong size); so does
  ///         half_gradient.
  void global_step(Eigen::MatrixXd& X, const LocalStep& step, const Eigen::MatrixXd& soft_targets = {}) const;
  /// Half the gradient of E at X (`step` taken at X); rows of kept vertices are 0.
  Eigen::MatrixXd half_gradient(const Eigen::MatrixXd& X, const LocalStep& step,
                                const Eigen::MatrixXd& soft_targets = {}) const;

  double factor_seconds() const; ///< time spent assembling and factoring in the constructor
  const RestTets& rest() const;
  int num_vertices() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace gshell
