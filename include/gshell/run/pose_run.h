#pragma once
// The pose job (`gshell pose`, Python `gshell.Poser`): direct shell deformation with handles
// (paper §4.2, second type), solved in K steps along the handles' motion. Its options hold the
// only defaults; a DragSession (run/drag_session.h) does the solving.
//
// Output folder: a shell folder (run/shell_folder.h) of the posed shell, shell.vtu with cell data
// stretch and det_F against the rest shell, and report.json (PoseResult::to_json).
#include <gshell/deform/handles.h>
#include <gshell/deform/pose.h>
#include <gshell/deform/shell_deformer.h>
#include <gshell/quality/stretch.h>
#include <gshell/shell/shell.h>
#include <gshell/solver/hierarchical_solver.h>
#include <gshell/solver/shell_solver.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <functional>
#include <string>
#include <vector>

namespace gshell {

/// "hierarchical" / "single".
const char* pose_solver_name(PoseSolverKind kind);
/// Inverse of pose_solver_name. \throws InputError "unknown solver ..." otherwise.
PoseSolverKind parse_pose_solver(const std::string& name);

/// The only source of pose defaults: the CLI's help and Python's keyword defaults read PoseOptions{}.
struct PoseStepReport;

struct PoseOptions {
  PoseSolverKind solver = PoseSolverKind::Hierarchical;
  HierarchyOptions hierarchy; ///< `levels` is the one a user sets
  int steps = 1;              ///< handles move from rest to target in this many equal steps
  /// Start every step after the first from the previous steps' motion continued
  /// (PoseSolver::predict_start) instead of from the previous result.
  bool extrapolate = true;
  /// Per step (a drag event solves with these too unless told otherwise): up to 500 iterations,
  /// until the relative energy change per iteration is below 1e-6.
  SolveOptions solve = {500, 1e-6, {}};
  /// The paper's unguarded steps (may invert tets or pass the shell through itself), for comparison;
  /// run_pose still certifies each step's state and says which are not valid. Off (the
  /// default): every step is valid (PoseSolver::solve_valid), stopping at contact when
  /// the handles force a collision.
  bool allow_invalid = false;
  /// With the guard on: DragSession::drag() steps are guarded too. Off (the viewer's choice, where
  /// a drag event must answer within a frame): a drag step is an unguarded preview, and settle()
  /// solves guarded from the last valid state, so the state a drag comes to rest in is valid.
  bool guard_drag_steps = true;
  /// The guard's barriers, bounds and directions: the deformation frames' (frame_guard_options:
  /// generation's Hessians and 4-ring local solve). GuardOptions{}'s plainer directions made a
  /// dragged step creep, every iteration cut by its bounds (docs/valid-deformation.md).
  GuardOptions guard = frame_guard_options();
  /// Called after every iteration with (step 1..steps, iteration, energy, seconds in this step);
  /// replaces solve.progress.
  std::function<void(int, int, double, double)> step_progress;
  /// Called as each step ends with (step 1..steps, its report), so a long run shows each step's
  /// outcome when it has it rather than after the last.
  std::function<void(int, const PoseStepReport&)> step_done;

  /// \throws InputError naming the parameter (steps, levels, iterations, tolerance) out of range.
  void check() const;
  /// The levels asked for, the full one included: hierarchy.levels for the hierarchical solver, 1
  /// for the single-level one (a small mesh may hold fewer: DragSession::solver_levels).
  int levels_asked() const { return solver == PoseSolverKind::Hierarchical ? hierarchy.levels : 1; }
};

struct PoseStepReport {
  double fraction = 0;   ///< of the handles' motion
  int iterations = 0;
  double energy = 0;     ///< at the end of the step
  double seconds = 0;    ///< wall time of the step: start prediction and solve
  bool converged = false;
  bool guarded = false;            ///< made by solve_valid (not allow_invalid)
  /// valid and the certificate's counts below hold: guarded steps, and run_pose's unguarded ones
  bool certified = false;
  bool valid = false;              ///< certified: the step's certificate holds
  bool blocked_by_contact = false; ///< guarded: the handles forced a collision; the step stopped at contact
  FrameMethod method = FrameMethod::Unguarded;
  int guarded_iterations = 0;
  double drag_start = 0; ///< guarded: ValidStep::drag_start
  /// guarded: building the validity guard at this step (ValidStep::guard_setup_seconds), not
  /// counted in `seconds`
  double guard_setup_seconds = 0;
  int inverted_tets = -1, intersections = -1; ///< certified: the certificate's counts (all pair kinds)
  /// certified: the pairs by kind, as deform's frames and generate report them (-1 = not tested)
  int top_self_intersections = -1, top_base_intersections = -1, wall_intersections = -1;
  int nested_parts = -1;                      ///< certified: sheets inside another part's layer
  /// certified: face pairs where the posed base crosses itself (-1 = not tested); a step is valid
  /// only without them
  int base_self_intersections = -1;
  /// guarded, not valid: only where the rest shell is not valid itself (ValidStep::rest_faults_only)
  bool rest_faults_only = false;
  /// Sets `certified` and what the certificate of the step's state says (valid: conditions 1-4
  /// hold and the base does not cross itself).
  void record_certificate(const ShellCertificate& certificate);
  /// {fraction, iterations, energy, seconds, converged}; certified, {valid, method ("unguarded"
  /// where not guarded)}; guarded, {blocked_by_contact, guarded_iterations, drag_start, guard_setup_seconds};
  /// certified, {certificate {inverted_tets, top_self_intersections, top_base_intersections,
  /// wall_intersections, intersections (every kind, base/base too), nested_parts},
  /// base_self_intersections};
  /// guarded, {rest_faults_only}
  nlohmann::ordered_json to_json() const;
};

/// A posed shell and what its report says.
struct PoseResult {
  Eigen::MatrixXd X;                 ///< 2n shell vertices, base rows then top rows
  std::vector<PoseStepReport> steps;
  double setup_seconds = 0;          ///< rest tets, tree, factorisations (the last build)
  StretchStats stretch;              ///< per-tet stretch against the rest shell
  std::string shell, handles;        ///< how the report names the rest shell and the handle source
  PoseSolverKind solver = PoseSolverKind::Hierarchical;
  int levels = 1;                    ///< built by the hierarchical solver (1 for the single-level one)
  ConstraintMode mode = ConstraintMode::Hard;
  double weight = 0;                 ///< soft mode's weight
  double thickness = 0;              ///< the rest shell's eta: the output is a shell folder too
  int tets = 0, handle_vertices = 0;
  double tolerance = 0;
  int max_iterations = 0;

  /// What a user must hear even with progress off: one line per guarded step the handles blocked
  /// (stopped at contact, short of them), and one naming the guarded steps that are not valid and
  /// why (the posed base crosses itself, or the guard could not make them valid).
  std::vector<std::string> warnings() const;

  /// report.json: command, shell, handles, solver, levels, mode, weight (soft only), thickness,
  /// vertices, tets, handle_vertices, setup_seconds, tolerance, max_iterations, steps [...],
  /// valid, certificate {...} and base_self_intersections (the last step's, when it was
  /// certified), warnings [warnings()], stretch {mean, volume_mean, max, p99}, inverted_tets.
  /// (A drag session's save adds rest_shell, the folder of the rest shell.)
  nlohmann::ordered_json to_json() const;
};

class DragSession;

/// Moves the session's handles from the fraction of their motion where they are to `to_fraction`
/// in options.steps equal steps, solving after each (options.solve, with options.step_progress),
/// and returns the result with these steps. The solver kind, hierarchy and extrapolation are the
/// session's (fixed when it was made).
/// \throws InputError on bad options or handles that leave a part of the shell free.
PoseResult run_pose(DragSession& session, const PoseOptions& options, double to_fraction = 1.0);

/// The same on a fresh session of `rest` with `handles`.
/// \throws InputError as DragSession's constructor and set_handles, or as above.
PoseResult run_pose(const Shell& rest, const HandleSet& handles, const PoseOptions& options = {});

} // namespace gshell
