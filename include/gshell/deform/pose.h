#pragma once
// Direct shell deformation with handles (paper §4.2, second type): both surfaces move, the rest
// shape is the given shell, handles pull vertices of either surface. Precompute once per shell
// and handle vertex set (`PoseSolver`), then solve for any targets of those vertices (a fraction
// of the handles' motion, or whatever an interactive drag asks for). The pose job and the drag
// session (run/pose_run.h, run/drag_session.h) drive it.
#include <gshell/deform/handles.h>
#include <gshell/deform/shell_deformer.h>
#include <gshell/guard/guarded_shell.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/shell/shell.h>
#include <gshell/solver/hierarchical_solver.h>
#include <gshell/solver/rest_tets.h>
#include <gshell/solver/shell_solver.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <memory>
#include <vector>

namespace gshell {

enum class PoseSolverKind {
  Hierarchical, ///< HierarchicalSolver (paper §5)
  Single,       ///< ShellSolver over all 2n vertices (plain local/global)
};

/// What made a guarded pose step (PoseSolver::solve_valid) valid.
struct ValidStep {
  /// Bounded: the solver's own result, accepted through the tet step bound and the certificate;
  /// Guarded: the guarded solver from the previous step (hard handles); Failed: nothing valid
  /// was found, the state was left as it was before the step.
  FrameMethod method = FrameMethod::Bounded;
  /// The handles force a collision: the step stopped at contact, short of the targets (valid).
  bool blocked_by_contact = false;
  int guarded_iterations = 0;
  /// Where the guard took over from a refused solver step, as a fraction of the straight path from
  /// the previous state to that step's result: hard handles, where the drag began; soft handles,
  /// where the step was cut back to (0: the previous state itself).
  double drag_start = 0;
  bool valid = false;            ///< the certificate holds (base/base pairs included)
  /// Not valid, but only where the rest shell is not valid itself (FrameGuard::only_rest_faults:
  /// what the guard leaves out; the posed base not crossing itself), the step not Failed.
  bool rest_faults_only = false;
  ShellCertificate certificate;  ///< of the step's result, base/base pairs included
  /// Building the validity guard, which the first guarded step does (and a step whose guard
  /// options differ from the last): setup, like setup_seconds(), not the step's own work.
  double guard_setup_seconds = 0;
};

class PoseSolver {
public:
  /// Builds the rest tets of `rest` and the chosen solver (tree, assembly, factorisations). The
  /// rest tets are the deformer's (deformation_rest_tets): a generated shell's few flat or
  /// inverted tets take their ideal shape. Only the handles' vertex sets, mode and weight matter
  /// here; their motions only give targets(fraction).
  /// \throws InputError when there is no handle vertex or a connected part of the shell carries
  ///         no handle (it could float away).
  PoseSolver(const Shell& rest, const HandleSet& handles, PoseSolverKind kind,
             const HierarchyOptions& hierarchy = {});
  ~PoseSolver();
  /// A moved-from PoseSolver may only be destroyed or assigned to.
  PoseSolver(PoseSolver&&) noexcept;
  PoseSolver& operator=(PoseSolver&&) noexcept;

  /// Solves for the handle vertices at `targets` (one row per constrained_vertices() entry) from
  /// the state X (2n x 3, updated in place). The hierarchical solver keeps its levels' state from
  /// the previous call. options.stage, where set, is told "paper" first.
  /// \throws InputError when X or targets have the wrong shape.
  SolveResult solve(Eigen::MatrixXd& X, const Eigen::MatrixXd& targets, const SolveOptions& options = {});
  /// The same for the handles at `fraction` of their motion: solve(X, targets(fraction), options).
  /// \throws InputError as solve().
  SolveResult solve(Eigen::MatrixXd& X, double fraction, const SolveOptions& options = {});

  /// solve() from the start X, kept valid (docs/valid-deformation.md): from `from` (a valid
  /// state, e.g. the rest shell or the last valid step; X may be a prediction made from it), the
  /// solver's result (either kind; the hierarchy's coarse
  /// corrections included) is taken only when the straight path to it keeps every tet above the
  /// guard's keep_fraction (step bound) and its exact certificate (base/base pairs included:
  /// the base moves too) holds. Otherwise, with hard handles, the guarded solver drags the
  /// handles there from X, stopping at contact when they force a collision
  /// (step->blocked_by_contact); with soft handles, the straight path is halved until its end is
  /// valid (blocked_by_contact if it had to be). Never leaves X invalid when it started valid.
  /// Returns the solver's result; where X is not the solver's state, its energy gets one more
  /// entry, the energy of X (so energy.back() is the returned state's), and a step short of its
  /// targets or left where it was is not `converged`. options.progress counts on through the
  /// guard's iterations; options.stage, where set, names them: "mend", then "drag K/N" (the drag's
  /// sub-steps; "drag" for one).
  /// \throws InputError when `from`, X or targets have the wrong shape, or as GuardedSolver.
  SolveResult solve_valid(const Eigen::MatrixXd& from, Eigen::MatrixXd& X, const Eigen::MatrixXd& targets,
                          const SolveOptions& options, const GuardOptions& guard, ValidStep* step);

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
  HierarchicalSolver* hierarchical(); ///< for its interactive previews (anchor_preview, preview)

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace gshell
