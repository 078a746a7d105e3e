#include <gshell/run/pose_run.h>

#include <gshell/error.h>
#include <gshell/format_number.h>
#include <gshell/quality/certificate_report.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/quality/stretch_report.h>
#include <gshell/run/drag_session.h>

#include "invalid_items_warning.h"

#include <cmath>

namespace gshell {

const char* pose_solver_name(PoseSolverKind kind) {
  return kind == PoseSolverKind::Hierarchical ? "hierarchical" : "single";
}

PoseSolverKind parse_pose_solver(const std::string& name) {
  for (PoseSolverKind k : {PoseSolverKind::Hierarchical, PoseSolverKind::Single})
    if (name == pose_solver_name(k)) return k;
  throw InputError("unknown solver '" + name + "' (expected hierarchical or single)");
}

void PoseOptions::check() const {
  if (steps < 1) throw InputError("steps must be >= 1 (got " + std::to_string(steps) + ")");
  if (hierarchy.levels < 1) throw InputError("levels must be >= 1 (got " + std::to_string(hierarchy.levels) + ")");
  // Unlike generate's and deform's start, a pose's start has the handles still at rest: zero
  // iterations would leave every step's handles unmet.
  if (solve.max_iterations < 1)
    throw InputError("iterations must be >= 1 (got " + std::to_string(solve.max_iterations) +
                     "; the targets are reached by iterating)");
  if (!(solve.tolerance >= 0) || !std::isfinite(solve.tolerance)) throw InputError("tolerance must be a number >= 0");
  if (solver == PoseSolverKind::Hierarchical) hierarchy.check(); // the fields no flag sets, as the solver would
}

void PoseStepReport::record_certificate(const ShellCertificate& c) {
  certified = true;
  valid = c.valid() && c.base_self_intersections == 0;
  inverted_tets = c.inverted_tets;
  intersections = c.intersections_tested() ? static_cast<int>(c.intersections.size()) : -1;
  top_self_intersections = c.top_self_intersections;
  top_base_intersections = c.top_base_intersections;
  wall_intersections = c.wall_intersections;
  nested_parts = c.nested_parts;
  base_self_intersections = c.base_self_intersections;
}

nlohmann::ordered_json PoseStepReport::to_json() const {
  nlohmann::ordered_json j{{"fraction", fraction}, {"iterations", iterations}, {"energy", energy}, {"seconds", seconds},
                           {"converged", converged}};
  if (certified) {
    j["valid"] = valid;
    j["method"] = frame_method_name(method);
  }
  if (guarded) {
    j["blocked_by_contact"] = blocked_by_contact;
    j["guarded_iterations"] = guarded_iterations;
    j["drag_start"] = drag_start;
    j["guard_setup_seconds"] = guard_setup_seconds;
  }
  if (certified) {
    j["certificate"] = {{"inverted_tets", inverted_tets},
                        {"top_self_intersections", count_or_null(top_self_intersections)},
                        {"top_base_intersections", count_or_null(top_base_intersections)},
                        {"wall_intersections", count_or_null(wall_intersections)},
                        {"intersections", count_or_null(intersections)},
                        {"nested_parts", count_or_null(nested_parts)}};
    j["base_self_intersections"] = count_or_null(base_self_intersections);
  }
  if (guarded) {
    j["rest_faults_only"] = rest_faults_only;
  }
  return j;
}

std::vector<std::string> PoseResult::warnings() const {
  std::vector<std::string> lines;
  detail::InvalidItems invalid;
  int certified = 0;
  bool unguarded = false;
  for (std::size_t k = 0; k < steps.size(); ++k) {
    const PoseStepReport& s = steps[k];
    if (!s.certified) continue;
    ++certified;
    unguarded = unguarded || !s.guarded;
    const int step = static_cast<int>(k) + 1;
    // Soft handles are cut back along the step rather than dragged, so contact is not the only
    // cause there: any fault the mend could not take out.
    if (s.blocked_by_contact && mode == ConstraintMode::Soft)
      lines.push_back("pose step " + std::to_string(step) + ": the solver's step was not valid and could not be " +
                      "mended, so " + format_number(100 * s.drag_start, 3) +
                      " % of it was kept, short of the handles' targets (soft handles are cut back, not dragged; "
                      "blocked_by_contact in report.json)");
    else if (s.blocked_by_contact)
      lines.push_back("pose step " + std::to_string(step) +
                      ": stopped short of the handles' targets, valid: the guarded drag stalled (the handles may "
                      "force the shell into itself or squeeze a tet between them flat; if they do not, more --steps "
                      "may reach them) (blocked_by_contact in report.json)");
    if (!s.valid) invalid.add(step, s.base_self_intersections > 0, false, s.rest_faults_only);
  }
  const std::string line = detail::invalid_items_warning(invalid, certified, "pose step", unguarded);
  if (!line.empty()) lines.push_back(line);
  // A step that ran out of iterations may lie far from the pose's minimum (the plain single-level
  // solver on a bowl swung about its held bottom: ten thicknesses away after 500 iterations). A
  // step stopped at contact or failed by the guard is not converged either, but more iterations
  // would not change it: its warning above says why it stopped.
  std::vector<int> capped;
  for (std::size_t k = 0; k < steps.size(); ++k)
    if (!steps[k].converged && !steps[k].blocked_by_contact && steps[k].method != FrameMethod::Failed)
      capped.push_back(static_cast<int>(k) + 1);
  const std::string unconverged = detail::unconverged_items_warning(
      "pose step", capped, max_iterations,
      solver == PoseSolverKind::Hierarchical
          ? "the shell may be short of the pose's minimum; more iterations get closer"
          : "the shell may be short of the pose's minimum; more iterations, or the hierarchical solver, get closer");
  if (!unconverged.empty()) lines.push_back(unconverged);
  return lines;
}

nlohmann::ordered_json PoseResult::to_json() const {
  nlohmann::ordered_json j;
  j["command"] = "pose";
  j["shell"] = shell;
  j["handles"] = handles;
  j["solver"] = pose_solver_name(solver);
  j["levels"] = levels;
  j["mode"] = mode == ConstraintMode::Hard ? "hard" : "soft";
  if (mode == ConstraintMode::Soft) j["weight"] = weight;
  j["thickness"] = thickness; // the output is a shell folder too
  j["vertices"] = X.rows();
  j["tets"] = tets;
  j["handle_vertices"] = handle_vertices;
  j["setup_seconds"] = setup_seconds;
  j["tolerance"] = tolerance;
  j["max_iterations"] = max_iterations;
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const PoseStepReport& s : steps) list.push_back(s.to_json());
  j["steps"] = list;
  // The shell written is the last step's: its validity also at the top, where generate, deform's
  // summary and metrics put theirs (a reader looking for `valid` found none).
  if (!steps.empty() && steps.back().certified) {
    const nlohmann::ordered_json last = list.back();
    j["valid"] = last["valid"];
    j["certificate"] = last["certificate"];
    j["base_self_intersections"] = last["base_self_intersections"];
  }
  j["warnings"] = warnings();
  j.update(stretch_report(stretch));
  return j;
}

PoseResult run_pose(DragSession& session, const PoseOptions& options, double to_fraction) {
  options.check();
  const double from = session.fraction();
  const std::size_t first = session.result_step_count();
  for (int step = 1; step <= options.steps; ++step) {
    SolveOptions so = options.solve;
    so.progress = nullptr;
    if (options.step_progress)
      so.progress = [&, step](int it, double e, double sec) { options.step_progress(step, it, e, sec); };
    const double fraction = from + (to_fraction - from) * (static_cast<double>(step) / options.steps);
    const PoseStepReport done = session.drag(fraction, so);
    if (options.step_done) options.step_done(step, done);
  }
  return session.result(first);
}

PoseResult run_pose(const Shell& rest, const HandleSet& handles, const PoseOptions& options) {
  DragSession session(rest, options);
  session.set_handles(handles);
  return run_pose(session, options);
}

} // namespace gshell
