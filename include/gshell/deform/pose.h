#pragma once
// Direct shell deformation with handles (paper §4.2, second type): both surfaces move, the rest
// shape is the given shell, handles pull vertices of either surface. Precompute once per shell
// and handle vertex set (`PoseSolver`), then solve for any targets of those vertices (a fraction
// of the handles' motion, or whatever an interactive drag asks for). The pose job and the drag
// session (run/pose_run.h, run/drag_session.h) drive it.
#include <gshell/deform/handles.h>
#include <gshell/shell/shell.h>
#include <gshell/solver/hierarchical_solver.h>
#include <gshell/solver/rest_tets.h>
#include <gshell/solver/shell_solver.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

namespace gshell {

enum class PoseSolverKind {
  Hierarchical, ///< HierarchicalSolver (paper §5)
  Single,       ///< ShellSolver over all 2n vertices (plain local/global)
};

class PoseSolver {
public:
  /// Builds the rest tets of `rest` and the chosen solver (tree, assembly, factorisations). Only
  /// the handles' vertex sets, mode and weight matter here; their motions only give targets(fraction).
  /// \throws InputError when there is no handle vertex or a connected part of the shell carries
  ///         no handle (it could float away).
  PoseSolver(const Shell& rest, const HandleSet& handles, PoseSolverKind kind,
             const HierarchyOptions& hierarchy = {});
  ~PoseSolver();
  PoseSolver(PoseSolver&&) noexcept;
  PoseSolver& operator=(PoseSolver&&) noexcept;

  /// Solves for the handle vertices at `targets` (one row per constrained_vertices() entry) from
  /// the state X (2n x 3, updated in place). The hierarchical solver keeps its levels' state from
  /// the previous call. \throws InputError when X or targets have the wrong shape.
  SolveResult solve(Eigen::MatrixXd& X, const Eigen::MatrixXd& targets, const SolveOptions& options = {});
  /// The same for the handles at `fraction` of their motion: solve(X, targets(fraction), options).
  SolveResult solve(Eigen::MatrixXd& X, double fraction, const SolveOptions& options = {});

  /// Start state for a drag step: the previous step's motion continued, X_prev + s (X_prev -
  /// X_before) (a solved path is smooth, so this is second-order close to the new minimum while
  /// X_prev is first-order), with hard handle rows at `targets`. `s` is how far the new targets
  /// lie along the previous step (1 = as far again). Not checked against X_prev: that would cost
  /// two local steps, and the solve that follows cannot raise the energy anyway. Returns X_prev
  /// when s is not in (0, 2] (a jump or reversal, where a straight continuation is no good guess).
  Eigen::MatrixXd predict_start(const Eigen::MatrixXd& X_before, const Eigen::MatrixXd& X_prev, double s,
                                const Eigen::MatrixXd& targets) const;
  /// The same along the handles' own motion: s = (fraction - f_prev) / (f_prev - f_before).
  Eigen::MatrixXd predict_start(const Eigen::MatrixXd& X_before, double f_before, const Eigen::MatrixXd& X_prev,
                                double f_prev, double fraction) const;

  /// Energy of X for the handles at `targets` / at `fraction` (springs included in soft mode).
  /// \throws InputError when X or targets have the wrong shape (predict_start: the targets).
  double energy(const Eigen::MatrixXd& X, const Eigen::MatrixXd& targets) const;
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

} // namespace gshell
