// `gshell pose`: direct shell deformation with handles (paper §4.2, second type), solved by the
// hierarchical solver (paper §5) or the single-level one; optionally as a drag in K steps (the run
// layer's pose job on a DragSession).
#include "command_registry.h"
#include "parameter_flags.h"
#include "preview_option.h"
#include "progress.h"
#include "warnings.h"

#include <gshell/quality/certificate_report.h>
#include <gshell/run/drag_session.h>
#include <gshell/run/pose_run.h>
#include <gshell/run/staged_folder.h>

#include <cstdio>
#include <memory>

namespace {

struct PoseArgs {
  std::string shell_dir, handles, output, solver = gshell::pose_solver_name(gshell::PoseOptions{}.solver);
  gshell::PoseOptions options;
  bool render = false;
  std::string view = "iso";
};

/// One step's outcome, as it ends: iterations, energy, time and validity.
std::string step_line(int step, int steps, const gshell::PoseStepReport& s) {
  char text[200], dragged[48] = "";
  if (s.guarded_iterations > 0) // the solver's result was not valid: the guard dragged the handles there
    std::snprintf(dragged, sizeof dragged, " + %d guarded", s.guarded_iterations);
  std::snprintf(text, sizeof text, "step %d/%d: %d iterations%s, energy %g, %.3f s%s%s", step, steps, s.iterations,
                dragged, s.energy, s.seconds, s.converged ? "" : " (not converged)",
                !s.certified ? "" : s.valid ? ", valid" : ", INVALID");
  std::string line = text;
  if (s.guard_setup_seconds > 0) { // kept out of the step's seconds, as the solver's setup is
    std::snprintf(text, sizeof text, " (and %.3f s setting up the guard)", s.guard_setup_seconds);
    line += text;
  }
  if (s.certified && !s.valid) {
    line += " (" + std::to_string(s.inverted_tets) + " inverted tets, " + std::to_string(s.intersections) +
            " intersecting face pairs";
    const std::string faults = gshell::unavoidable_faults(s.base_self_intersections);
    line += (faults.empty() ? "" : "; " + faults) + ")";
  }
  return line;
}

void run(const CLI::App& cmd, PoseArgs& a) {
  using namespace gshell;
  cli::check_flags(cmd, [&] {
    a.options.solver = parse_pose_solver(a.solver);
    a.options.check();
  });
  cli::check_applies(cmd, "--levels", a.options.solver == PoseSolverKind::Hierarchical, "--solver hierarchical");
  const ViewDirection view = cli::check_preview_flags(cmd, a.render, a.view); // before the solve, not after

  cli::Progress progress("pose", 0.5);
  progress.terminal_status("reading " + a.shell_dir + "..."); // seconds at millions of faces
  const ShellFolder rest = read_shell_folder(a.shell_dir);
  const HandleSet handles = read_handles(a.handles, rest.shell);
  check_pose_output_folder(a.output, a.shell_dir); // fail on a bad output path before the long part
  progress.finish_status();

  const std::string rest_warning = invalid_rest_shell_warning(a.shell_dir, rest.report, "pose step");
  if (!rest_warning.empty()) cli::print_warning("pose", rest_warning);

  progress.line(std::to_string(rest.shell.num_base_vertices() * 2) + " shell vertices, " +
                std::to_string(handles.constrained_vertices().size()) + " handle vertices (" +
                (handles.mode == ConstraintMode::Hard ? "hard" : "soft") + "), " + a.solver + " solver");
  std::string stage; // "paper", "mend", "drag 3/17" (PoseSolver::solve_valid): the energy of a drag climbs
  if (progress.enabled()) {
    a.options.solve.stage = [&](const char* name) {
      stage = name;
      if (cli::is_setup_stage(stage)) progress.update("setting up the guard (the first step's)...", true);
    };
    a.options.step_progress = [&](int step, int it, double energy, double) {
      char text[160];
      std::snprintf(text, sizeof text, "step %d/%d %s: iteration %d energy %.6g", step, a.options.steps, stage.c_str(),
                    it, energy);
      progress.update(text);
    };
  }
  DragSession session(rest.shell, a.options, rest.surface);
  session.set_names(a.shell_dir, a.handles);
  session.set_handles(handles);
  // The solver is built at the first step: its factor (and the hierarchy's levels) take seconds
  // on large shells, which the first iteration's line would leave silent.
  progress.update("setting up the " + a.solver + " solver");
  a.options.step_done = [&](int step, const PoseStepReport& s) { progress.line(step_line(step, a.options.steps, s)); };
  const PoseResult result = run_pose(session, a.options);
  // Even with --quiet: a pose short of its handles, or not valid, is not what was asked for.
  cli::print_warnings("pose", result.warnings());
  session.write(a.output, 0, cli::preview_writer(a.render, a.output, view));
  progress.line("wrote " + a.output + " (top.obj, base.obj, shell.vtu, report.json" + (a.render ? ", preview.png" : "") +
                ")");
}

void add_pose_command(CLI::App& app) {
  auto a = std::make_shared<PoseArgs>();
  CLI::App* cmd = app.add_subcommand(
      "pose", "Deform a shell directly with handles (both surfaces move; paper §4.2) using the hierarchical "
              "solver (paper §5) or the single-level one. Writes OUT/top.obj, base.obj, shell.vtu (per-tet "
              "stretch against the input shell) and report.json (per step: iterations, energy, seconds).");
  cmd->add_option("--shell", a->shell_dir, "Shell folder (from gshell generate: base.obj, top.obj, report.json)")
      ->required();
  cmd->add_option("--handles", a->handles, "Handle file (JSON, see docs/handles.md)")->required();
  cmd->add_option("--solver", a->solver, "hierarchical or single")
      ->check(CLI::IsMember({"hierarchical", "single"}))
      ->capture_default_str();
  cmd->add_option("--levels", a->options.hierarchy.levels, "Levels of the hierarchical solver including the full one")
      ->capture_default_str();
  cmd->add_option("--steps", a->options.steps, "Move the handles from rest to target in K equal steps, solving after each")
      ->capture_default_str();
  cmd->add_option("--tolerance", a->options.solve.tolerance,
                  "Stop a step when the relative energy change per iteration is below this")
      ->capture_default_str();
  cmd->add_option("--iterations", a->options.solve.max_iterations, "Maximum iterations per step, at least 1")->capture_default_str();
  cmd->add_flag("--allow-invalid", a->options.allow_invalid,
                "The paper's unguarded steps (may invert tets or pass the shell through itself), for comparison; by "
                "default every step is valid and stops at contact when the handles force a collision");
  cmd->add_option("-o,--output", a->output,
                  "Output folder (an earlier pose output there is replaced; a folder of other files is an error)")
      ->required();
  gshell::cli::add_preview_flags(*cmd, a->render, a->view, "the rest and the posed shell, colored by stretch");
  cmd->callback([a, cmd] { run(*cmd, *a); });
}

const gshell::cli::CommandRegistrar reg{70, add_pose_command};

} // namespace
