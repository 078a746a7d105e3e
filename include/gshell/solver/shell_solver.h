#pragma once
// The local/global solver for E(x) = sum_t vol_t ||F_t(x) - R_t||_F^2 (+ soft constraints),
// docs/design.md "The energy" and "The solver". Precompute once from rest shapes and the
// constrained vertex set, then solve from many start states (generation, every frame of a
// deformation, every drag step).
#include <gshell/solver/aggregation_multigrid.h>
#include <gshell/solver/rest_tets.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace gshell {

struct SolveOptions {
  int max_iterations = 50;
  double tolerance = 1e-5; ///< stop when |E_k - E_{k-1}| / E_{k-1} < tolerance
  /// Called after every iteration with (iteration, energy, seconds since solve started).
  std::function<void(int, double, double)> progress;
  /// Anderson acceleration of the local/global iterations: the last anderson_history iterates
  /// are combined, and the combination is kept only when it lowers the energy (so the energy
  /// still never rises). 0: plain local/global (the paper's iteration). At most
  /// kMaxAndersonHistory.
  int anderson_history = 0;
  /// Solves in stages (guarded generation: "paper", then "repair" and "relax" where the start
  /// thinned a top) call this with the stage's name before its iterations; `progress` counts
  /// iterations from 1 again in every stage, and reports each stage's own energy (the repair's and
  /// the relaxation's is E_guard of the part they move, barriers included). Generation also names
  /// its phases without iterations when they begin ("curvature prisms"; "setup": the ideal prisms,
  /// extrusion directions and the smoothed start; "factor": the system's factorisation or
  /// multigrid; "start": the valid start; "metrics"; "certificate"), which take tens of seconds at
  /// millions of faces. Whatever it throws ends the call.
  std::function<void(const char*)> stage = nullptr;
};

/// Longest Anderson history a solver accepts. Each iterate kept costs two vectors of the free
/// values (63 MB each at sphere:9) and the least-squares combination a depth x depth Gram matrix
/// (--anderson 1000000000 ran out of memory); far below this the combination is already
/// ill-conditioned and gains nothing (the default is 5).
constexpr int kMaxAndersonHistory = 100;
/// The one range check of every Anderson history a caller sets (generation, the solvers, the
/// guard, the hierarchy). \throws InputError "WHAT must be in [0, 100] (got N)" outside it.
void check_anderson_history(int history, const std::string& what);
/// The limits every solve checks (ShellSolver::solve, HierarchicalSolver::solve). \throws
/// InputError "CALLER: negative iteration count" or "CALLER: the tolerance must be a number >= 0"
/// (a NaN tolerance never held: such a solve ran to its last iteration and said "converged").
void check_solve_limits(const SolveOptions& options, const std::string& caller);

/// How the global step's linear system (L_ff X_f = B, one matrix for the three coordinates) is
/// solved; docs/scale.md has the measurements behind the defaults.
enum class LinearSolver {
  Auto,              ///< ConjugateGradient for large systems (see below), else Direct
  Direct,            ///< sparse Cholesky factor (CHOLMOD), computed in the constructor
  ConjugateGradient, ///< preconditioned CG warm-started from the current iterate; no factor
};

/// The preconditioner of the ConjugateGradient path.
enum class CgPreconditioner {
  Multigrid, ///< one smoothed-aggregation V-cycle (AggregationMultigrid): iterations flat in the size
  Jacobi,    ///< the diagonal: no setup, but iterations grow like the inverse edge length
};

/// "auto", "direct", "cg".
std::string to_string(LinearSolver solver);
/// Inverse of to_string; throws InputError "unknown linear solver 'X' (expected auto, direct or cg)".
LinearSolver parse_linear_solver(const std::string& name);

struct LinearSolverOptions {
  LinearSolver kind = LinearSolver::Auto;
  /// Auto takes CG from this many free vertices on, if at least half of them are anchored (share
  /// a tet with a kept vertex or carry a soft constraint), as in generation where the whole base
  /// is kept: then the system is a Laplacian shifted by a mass-like term, whose Jacobi-scaled
  /// condition number does not grow with the vertex count at a fixed thickness-to-edge ratio,
  /// while a factor's cost grows like n^1.5. Below it the factor pays.
  int cg_min_rows = 50000;
  /// Auto takes CG for a loosely anchored system (a pose held at its handles) from this many free
  /// vertices on, and only with the Multigrid preconditioner (Jacobi's iterations grow with the
  /// size there). Measured on drag settles (CG / factor time: 1.5x at 55K free rows, 1.2x at
  /// 159K, 0.9x at 222K) and poses (the same time per iteration from 225K rows on, with most of
  /// the setup and a sixth to a fifth of the peak memory saved). Never below cg_min_rows.
  int cg_loose_min_rows = 200000;
  /// CG stops when ||b - L_ff x|| <= cg_tolerance ||b|| holds for each of the 3 columns, or
  /// when that column's residual has fallen to cg_relative_tolerance times its value at the warm
  /// start (the current iterate). A global step needs only to lower its quadratic, and near the
  /// fixed point the warm start's residual goes to zero, so the iterations reach the same fixed
  /// point with a third of the CG work (in [0, 1); 0: the absolute test alone).
  double cg_tolerance = 1e-9;
  double cg_relative_tolerance = 1e-2;
  /// CG iterations per global step. If Auto's CG has not converged by then, the solver factors
  /// the matrix once and solves directly from then on; a forced ConjugateGradient keeps the last
  /// CG iterate (still an energy descent: CG from the current iterate never raises the energy).
  int cg_max_iterations = 500;
  CgPreconditioner preconditioner = CgPreconditioner::Multigrid;
  MultigridOptions multigrid; ///< the hierarchy's parameters (Multigrid preconditioner)
};

struct SolveResult {
  int iterations = 0;             ///< local/global iterations done
  int linear_iterations = 0;      ///< CG iterations summed over the global steps (0 if direct)
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
  double weight = 0; ///< > 0 whenever `vertices` is not empty (ShellSolver refuses 0)
};

/// Threads: one solver may be used from several threads (its solves take turns); solvers of their
/// own run in parallel. While CHOLMOD factors a small system (below 1e8 flops), OpenBLAS's
/// process-wide thread count is set to 1 and then restored (its threads would only contend with
/// TBB's): BLAS calls the host makes from other threads at that moment run on one thread
/// (docs/design.md, "Speed"). A process forked after the first factorisation (Python
/// multiprocessing's default) runs CHOLMOD's OpenMP parts on one thread: GNU OpenMP's thread pool
/// does not survive fork, and its parallel regions would hang there.

class ShellSolver {
public:
  /// \throws InputError when `rest` is incomplete (no Dm_inv in any form, or volumes missing),
  ///         a tet, fixed or soft vertex id is outside [0, num_vertices), or the system is singular (a connected part
  ///         of the tets has no fixed or constrained vertex). std::runtime_error when CHOLMOD
  ///         fails otherwise (out of memory).
  /// `num_vertices` = rows of the state; `fixed` vertices keep their start positions exactly
  /// (eliminated from the system). The system matrix is assembled and factored here, once.
  /// `linear` chooses how the global steps are solved (a factor here, or CG at every step).
  /// `rest` is kept (pass a temporary or std::move it to avoid a copy on big meshes).
  ShellSolver(RestTets rest, int num_vertices, const std::vector<int>& fixed,
              const SoftConstraints& soft = {}, const LinearSolverOptions& linear = {});
  /// The same, sharing `rest` instead of holding its own copy (the solver reads the tets in
  /// place). A caller that outlives the solver can pass a non-owning pointer,
  /// `std::shared_ptr<const RestTets>(std::shared_ptr<void>(), &tets)`.
  /// \throws InputError also when `rest` is null.
  ShellSolver(std::shared_ptr<const RestTets> rest, int num_vertices, const std::vector<int>& fixed,
              const SoftConstraints& soft = {}, const LinearSolverOptions& linear = {});
  ~ShellSolver();
  /// A moved-from ShellSolver may only be destroyed or assigned to.
  ShellSolver(ShellSolver&&) noexcept;
  ShellSolver& operator=(ShellSolver&&) noexcept;

  /// Local/global iterations from X (num_vertices x 3, fixed rows hold their prescribed
  /// positions); X is overwritten with the result. `soft_targets` (|soft.vertices| x 3) is
  /// required iff soft constraints were given. The energy never increases between iterations.
  /// \throws InputError when X is not num_vertices x 3, soft_targets has the wrong shape or
  ///         options.max_iterations or options.anderson_history < 0 (X is then unchanged).
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

  /// The system matrix A (the energy's Hessian for fixed rotations, halved: E's quadratic part is
  /// x^T A x), for drivers that build their own steps (the guarded solver's Newton directions).
  /// They work on the free rows only, in the order of free_vertices() (nf x 3 arrays): ascending
  /// vertex ids on the direct path, breadth first over the system's graph on the CG path (rows
  /// whose neighbours lie close in memory, whatever the input's vertex order).
  const std::vector<int>& free_vertices() const;
  /// B <- A_ff^-1 B (nf x k, k >= 1; A_ff is the same for the three axes, so any columns, e.g.
  /// columns of A_ff^-1 itself): one back-substitution with the factor (a solver on the CG path
  /// factors at its first call). \throws InputError when B does not have nf rows.
  void apply_inverse(Eigen::MatrixXd& B) const;
  /// A_ff P (P: nf x 3).
  Eigen::MatrixXd multiply_free(const Eigen::MatrixXd& P) const;
  /// Rows of A for the given free vertices over all vertices, one row per entry of `vertices`
  /// (|vertices| x num_vertices, free columns only): a local piece of the system, e.g. for a
  /// direct solve on a small neighbourhood.
  Eigen::SparseMatrix<double, Eigen::RowMajor> system_rows(const std::vector<int>& vertices) const;

  double factor_seconds() const; ///< time spent assembling and factoring in the constructor
  /// Direct or ConjugateGradient: the path the constructor chose (Auto resolved). A CG solver
  /// that fell back to a factor reports Direct from then on.
  LinearSolver linear_solver() const;
  const RestTets& rest() const;
  int num_vertices() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace gshell
