#include <gshell/deform/pose.h>

#include "frame_guard.h"

#include <gshell/deform/shell_deformer.h>
#include <gshell/error.h>
#include <gshell/guard/guarded_shell.h>
#include <gshell/seconds_since.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <optional>
#include <string>

namespace gshell {

namespace {

using Clock = std::chrono::steady_clock;

// A drag starts at the previous state rather than closer than this to it along the straight path
// to a refused step: the tries below it would cost certificates and save next to nothing.
constexpr double kMinDragStart = 0.05;
// The least part of a soft step kept (below it the step stays where it began): about 2^-20.
constexpr double kMinSoftStep = 1e-6;

} // namespace

struct PoseSolver::Impl {
  PoseSolverKind kind;
  HandleSet handles;
  Eigen::MatrixXd rest_vertices;
  std::shared_ptr<const RestTets> rest; // one copy, read in place by the solvers and the guard
  std::vector<int> constrained;
  double soft_weight = 0; // absolute
  std::unique_ptr<HierarchicalSolver> hierarchical;
  std::shared_ptr<ShellSolver> single;
  double setup_seconds = 0;
  Shell rest_shell;
  std::unique_ptr<FrameGuard> guard; ///< built at the first solve_valid
};

PoseSolver::PoseSolver(const Shell& rest, const HandleSet& handles, PoseSolverKind kind,
                       const HierarchyOptions& hierarchy)
    : impl_(std::make_unique<Impl>()) {
  const auto start = Clock::now();
  Impl& s = *impl_;
  s.kind = kind;
  s.handles = handles;
  s.rest_vertices = rest.vertices();
  s.rest_shell = rest;
  const int n = rest.num_base_vertices();
  check_handles(handles, 2 * n); // a set built in code: an id past 2n wrote out of bounds
  s.constrained = handles.constrained_vertices();
  if (s.constrained.empty()) throw InputError("no handle vertices");
  check_handles_hold_every_part(handles, rest.F, n);
  // As the deformer's: a generated shell's few flat or inverted tets (next to unextrudable vertices
  // or base crossings) take their ideal shape, so such shells can be posed too. One matrix per
  // tet, not the deformer's positions form: a pose is not the millions of tets that form is for.
  s.rest = std::make_shared<const RestTets>(with_matrix_per_tet(deformation_rest_tets(rest)));
  const bool hard = handles.mode == ConstraintMode::Hard;
  if (!hard) s.soft_weight = handles.weight * mean_stiffness(*s.rest, 2 * n);

  PositionConstraints c;
  c.vertices = s.constrained;
  c.hard = hard;
  c.weight = s.soft_weight;
  if (kind == PoseSolverKind::Hierarchical)
    s.hierarchical = std::make_unique<HierarchicalSolver>(s.rest, s.rest_vertices, rest.F, c, hierarchy);
  else
    s.single = make_shell_solver(s.rest, 2 * n, c);
  s.setup_seconds = seconds_since(start);
}

PoseSolver::~PoseSolver() = default;
PoseSolver::PoseSolver(PoseSolver&&) noexcept = default;
PoseSolver& PoseSolver::operator=(PoseSolver&&) noexcept = default;

Eigen::MatrixXd PoseSolver::targets(double fraction) const {
  return impl_->handles.targets(impl_->rest_vertices, fraction);
}

namespace {

void check_state(const Eigen::MatrixXd& X, const Eigen::MatrixXd& rest_vertices) {
  if (X.rows() != rest_vertices.rows() || X.cols() != 3)
    throw InputError("pose: the state must be " + std::to_string(rest_vertices.rows()) + " x 3 (got " +
                     std::to_string(X.rows()) + " x " + std::to_string(X.cols()) + ")");
}

void check_targets(const Eigen::MatrixXd& P, const std::vector<int>& constrained) {
  if (P.rows() != static_cast<Eigen::Index>(constrained.size()) || P.cols() != 3)
    throw InputError("pose: targets must be " + std::to_string(constrained.size()) + " x 3, one row per handle vertex (got " +
                     std::to_string(P.rows()) + " x " + std::to_string(P.cols()) + ")");
  if (!P.allFinite()) throw InputError("pose: a handle target is not finite");
}

} // namespace

SolveResult PoseSolver::solve(Eigen::MatrixXd& X, const Eigen::MatrixXd& P, const SolveOptions& options) {
  Impl& s = *impl_;
  check_state(X, s.rest_vertices);
  check_targets(P, s.constrained);
  if (options.stage) options.stage("paper");
  if (s.hierarchical) return s.hierarchical->solve(X, P, options);
  if (s.handles.mode == ConstraintMode::Hard) {
    for (size_t r = 0; r < s.constrained.size(); ++r) X.row(s.constrained[r]) = P.row(r);
    return s.single->solve(X, options);
  }
  return s.single->solve(X, options, P);
}

SolveResult PoseSolver::solve(Eigen::MatrixXd& X, double fraction, const SolveOptions& options) {
  return solve(X, targets(fraction), options);
}

SolveResult PoseSolver::solve_valid(const Eigen::MatrixXd& from, Eigen::MatrixXd& X, const Eigen::MatrixXd& P,
                                    const SolveOptions& options, const GuardOptions& guard, ValidStep* step) {
  Impl& s = *impl_;
  check_state(X, s.rest_vertices);
  check_state(from, s.rest_vertices);
  check_targets(P, s.constrained);
  check_guard_options(guard);
  ValidStep local;
  ValidStep& out = step ? *step : local;
  out = ValidStep{};
  const bool hard = s.handles.mode == ConstraintMode::Hard;
  if (!s.guard || !s.guard->built_with(guard)) {
    if (options.stage) options.stage("guard setup"); // the first step's: tens of seconds at 655K vertices
    const auto setup_start = std::chrono::steady_clock::now();
    // Hard handles are the guard's fixed vertices: its system is the full level's, shared.
    std::shared_ptr<const ShellSolver> arap;
    if (hard) arap = s.hierarchical ? s.hierarchical->full_level() : s.single;
    s.guard = std::make_unique<FrameGuard>(s.rest_shell, s.rest, guard, s.constrained, true, std::move(arap));
    out.guard_setup_seconds = seconds_since(setup_start);
  }
  const Eigen::MatrixXd start = from;
  SolveResult result = solve(X, P, options);
  // The guarded solver's iterations (a mend's, then a drag's) can be many times the solve's: they
  // are reported as the solve's continued (energy: E with the barriers), so progress does not stop.
  GuardedSolveOptions solve;
  solve.max_iterations = options.max_iterations;
  solve.tolerance = options.tolerance;
  int continued = 0;
  const auto solved = std::chrono::steady_clock::now();
  if (options.progress)
    solve.progress = [&](int, double e, double) {
      options.progress(result.iterations + ++continued, e, result.seconds + seconds_since(solved));
    };
  // A mend well above the solve's energy is kept aside while the drag runs, and the valid state
  // of lower energy is returned (GuardOptions::mend_max_rise; as for deformation frames).
  FrameMend mended; // X empty: none kept aside
  std::optional<double> returned_energy; // of the state returned, where already evaluated
  const auto take_mended = [&] { // the step returns the mend (its guarded iterations counted apart)
    X = std::move(mended.X);
    returned_energy = mended.energy;
    out.method = FrameMethod::Mended;
    out.drag_start = 0;
  };
  // Settled by the solve's own step, or by its mend.
  bool settled = s.guard->accepts(start, X, s.guard->guards_contacts(), &out.certificate);
  if (settled) {
    out.method = FrameMethod::Bounded;
  } else if (guard.mend_rings >= 0) {
    // Soft handles too, their vertices held where the solve put them (the guarded solver has no
    // springs); the mend is weighed with the springs' energy, as every mend is weighed.
    if (options.stage) options.stage("mend");
    mended = s.guard->weighed_mend(X, guard.mend_rings, guard.mend_max_rise, solve, &out.certificate,
                                   [&](const Eigen::MatrixXd& Y) { return energy(Y, P); });
    if (mended.within_rise) {
      out.guarded_iterations = mended.iterations;
      take_mended();
      settled = true;
    }
  }
  if (!settled && hard) {
    Eigen::MatrixXd targets = start;
    for (std::size_t r = 0; r < s.constrained.size(); ++r) targets.row(s.constrained[r]) = P.row(static_cast<Eigen::Index>(r));
    // The drag starts as far along the straight path to the refused step as the guard accepts:
    // where that step went wrong late and in few places, little is left to drag (a bowl of 204 K
    // shell vertices pulled by its rim, 2 tets inverted at the solver's end: 572 guarded
    // iterations from the start, 51 from 0.72 of the way; docs/valid-deformation.md).
    Eigen::MatrixXd Y = start;
    out.drag_start = s.guard->accepted_fraction(start, X, s.guard->guards_contacts(), kMinDragStart, Y);
    const DeformOptions schedule; // the deformation frames' sub-steps
    const auto drag = [&] { // Y from where it is to the targets
      return s.guard->drag(Y, targets, s.guard->substeps_between(Y, X, schedule), s.guard->guards_contacts(), false,
                           solve, schedule.substep_tolerance, {}, options.stage);
    };
    FrameGuard::Outcome outcome = drag();
    if (outcome.method == FrameMethod::Failed && out.drag_start > 0) { // then the drag from the start
      const int spent = outcome.iterations;
      Y = start;
      out.drag_start = 0;
      outcome = drag();
      outcome.iterations += spent;
    }
    out.guarded_iterations = mended.iterations + outcome.iterations;
    const bool reached = outcome.method == FrameMethod::Guarded && !outcome.blocked;
    if (mended.X.rows() > 0 && reached) returned_energy = energy(Y, P);
    if (mended.X.rows() > 0 && (!reached || *returned_energy > mended.energy)) {
      take_mended();
    } else {
      out.method = outcome.method;
      out.blocked_by_contact = outcome.blocked;
      X = outcome.method == FrameMethod::Failed ? start : std::move(Y);
    }
  } else if (!settled) {
    // Soft handles: no guarded solver holds springs; the step is cut back along its straight path
    // to as much of it as the guard accepts (nothing of it when not even kMinSoftStep is).
    Eigen::MatrixXd Y = start;
    out.drag_start =
        s.guard->accepted_fraction(start, X, s.guard->guards_contacts(), kMinSoftStep, Y, &out.certificate);
    if (mended.X.rows() > 0 && energy(Y, P) > mended.energy) { // a mend above the rise beats a cut
      out.guarded_iterations = mended.iterations;
      take_mended();
    } else {
      X = std::move(Y);
      out.method = FrameMethod::Bounded;
      out.blocked_by_contact = true;
    }
  }
  if (out.method == FrameMethod::Mended) {
    out.certificate = std::move(mended.certificate);
  } else if (out.method != FrameMethod::Bounded) {
    out.certificate = s.guard->certify(X);
  }
  out.valid = out.certificate.valid() && out.certificate.base_self_intersections == 0;
  out.rest_faults_only =
      !out.valid && out.method != FrameMethod::Failed && s.guard->only_rest_faults(out.certificate);
  // The result describes the state returned: where the guard replaced the solver's state, its
  // last energy is that of the valid state, and a step short of its targets has not converged.
  if (out.method != FrameMethod::Bounded || out.blocked_by_contact) {
    result.energy.push_back(returned_energy ? *returned_energy : energy(X, P));
    result.converged = result.converged && !out.blocked_by_contact && out.method != FrameMethod::Failed;
  }
  return result;
}

Eigen::MatrixXd PoseSolver::predict_start(const Eigen::MatrixXd& X_before, const Eigen::MatrixXd& X_prev, double s,
                                          const Eigen::MatrixXd& P) const {
  if (X_before.rows() != X_prev.rows() || X_before.cols() != X_prev.cols()) return X_prev;
  // Far beyond the last step the straight continuation is no longer a good guess.
  if (!(s > 0 && s <= 2)) return X_prev;
  check_targets(P, impl_->constrained);
  Eigen::MatrixXd X = X_prev + s * (X_prev - X_before);
  if (impl_->handles.mode == ConstraintMode::Hard)
    for (size_t r = 0; r < impl_->constrained.size(); ++r) X.row(impl_->constrained[r]) = P.row(r);
  return X;
}

Eigen::MatrixXd PoseSolver::predict_start(const Eigen::MatrixXd& X_before, double f_before, const Eigen::MatrixXd& X_prev,
                                          double f_prev, double fraction) const {
  if (f_prev == f_before) return X_prev;
  const double s = (fraction - f_prev) / (f_prev - f_before);
  if (!(s > 0 && s <= 2)) return X_prev;
  return predict_start(X_before, X_prev, s, targets(fraction));
}

double PoseSolver::energy(const Eigen::MatrixXd& X, const Eigen::MatrixXd& P) const {
  const Impl& s = *impl_;
  check_state(X, s.rest_vertices);
  check_targets(P, s.constrained);
  if (s.hierarchical) return s.hierarchical->energy(X, P);
  return s.handles.mode == ConstraintMode::Hard ? s.single->energy(X) : s.single->energy(X, P);
}

double PoseSolver::energy(const Eigen::MatrixXd& X, double fraction) const { return energy(X, targets(fraction)); }

const std::vector<int>& PoseSolver::constrained_vertices() const { return impl_->constrained; }
const Eigen::MatrixXd& PoseSolver::rest_vertices() const { return impl_->rest_vertices; }
const RestTets& PoseSolver::rest_tets() const { return *impl_->rest; }
PoseSolverKind PoseSolver::kind() const { return impl_->kind; }
double PoseSolver::setup_seconds() const { return impl_->setup_seconds; }
const HierarchicalSolver* PoseSolver::hierarchical() const { return impl_->hierarchical.get(); }
HierarchicalSolver* PoseSolver::hierarchical() { return impl_->hierarchical.get(); }

} // namespace gshell
