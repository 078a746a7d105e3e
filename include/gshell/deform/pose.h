#pragma once
// Direct shell deformation with handles (paper §4.2, second type): both surfaces move, the rest
// shape is the given shell, handles pull vertices of either surface. Precompute once per shell
// and handle set (`PoseSolver`), then solve for any fraction of the handles' motion.
#include <gshell/deform/handles.h>
#include <gshell/shell/shell.h>
#include <gshell/solver/hierarchical_solver.h>
#include <gshell/solver/rest_tets.h>
#include <gshell/solver/shell_solver.h>

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <vector>

namespace gshell {

enum class PoseSolverKind {
  Hierarchical, ///< HierarchicalSolver (paper §5)
  Single,       ///< ShellSolver over all 2n vertices (plain local/global)
};

class PoseSolver {
public:
  /// Builds the rest tets of `rest` and the chosen solver (tree, assembly, factorisations).
  /// Throws InputError when a connected part of the shell carries no handle (it could float away).
  PoseSolver(const Shell& rest, const HandleSet& handles, PoseSolverKind kind,
             const HierarchyOptions& hierarchy = {});
  ~PoseSolver();
  PoseSolver(PoseSolver&&) noexcept;
  PoseSolver& operator=(PoseSolver&&) noexcept;

  /// Solves for the handles at `fraction` of their motion from the state X (2n x 3, updated in
  /// place). The hierarchical solver keeps its levels' state from the previous call.
  SolveResult solve(Eigen::MatrixXd& X, double fraction, const SolveOptions& options = {});
  /// Start state for a drag step to `fraction`: the previous step's motion continued,
  /// X_prev + s (X_prev - X_before), s = (fraction - f_prev) / (f_prev - f_before) (a solved path
  /// is smooth, so this is second-order close to the new minimum while X_prev is first-order), with
  /// hard handle rows at their targets. Not checked against X_prev: that would cost two local
  /// steps, and the solve that follows cannot raise the energy anyway. Returns X_prev when s is
  /// not in (0, 2] (a jump or reversal, where a straight continuation is no good guess).
  Eigen::MatrixXd predict_start(const Eigen::MatrixXd& X_before, double f_before, const Eigen::MatrixXd& X_prev,
                                double f_prev, double fraction) const;

  /// Energy of X for the handles at `fraction` (springs included in soft mode).
  double energy(const Eigen::MatrixXd& X, double fraction) const;

  Eigen::MatrixXd targets(double fraction) const;   ///< handle targets, rows of constrained_vertices()
  const std::vector<int>& constrained_vertices() const;
  const Eigen::MatrixXd& rest_vertices() const;     ///< the 2n rest shell vertices
  const RestTets& rest_tets() const;
  PoseSolverKind kind() const;
  double setup_seconds() const;
  /// The hierarchical solver (null for the single-level one), e.g. to read its levels.
  const HierarchicalSolver* hierarchical() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct PoseOptions {
  PoseSolverKind solver = PoseSolverKind::Hierarchical;
  HierarchyOptions hierarchy;
  int steps = 1;              ///< handles move from rest to target in this many equal steps
  /// Start every step after the second from the previous steps' motion continued
  /// (PoseSolver::predict_start) instead of from the previous result.
  bool extrapolate = true;
  SolveOptions solve;         ///< per step; `progress` is replaced by `step_progress`
  /// Called after every iteration with (step 1..steps, iteration, energy, seconds in this step).
  std::function<void(int, int, double, double)> step_progress;
};

struct PoseStepReport {
  double fraction = 0;   ///< of the handles' motion
  int iterations = 0;
  double energy = 0;     ///< at the end of the step
  double seconds = 0;    ///< wall time of the step's solve
  bool converged = false;
};

struct PoseResult {
  Eigen::MatrixXd X;                ///< final 2n shell vertices
  std::vector<PoseStepReport> steps;
  double setup_seconds = 0;         ///< rest tets, tree, factorisations
};

/// Moves the handles of `rest` in `options.steps` steps, solving after each (an interactive drag).
PoseResult run_pose(const Shell& rest, const HandleSet& handles, const PoseOptions& options = {});

} // namespace gshell
