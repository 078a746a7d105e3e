// `gshell view INPUT...`: an interactive viewer in the browser, served by gshell itself: look around
// a shell, play a deform sequence, or pick handles and drag them while the pose solver follows
// (the library's ViewSession and ViewServer, view/; protocol in docs/viewer.md).
#include "command_registry.h"
#include "parameter_flags.h"
#include "interrupts.h"
#include "progress.h"
#include "thickness_flags.h"
#include "warnings.h"

#include <gshell/deform/handles.h>
#include <gshell/error.h>
#include <gshell/run/pose_run.h>
#include <gshell/view/view_input.h>
#include <gshell/view/view_server.h>
#include <gshell/view/view_session.h>

#include <cstdlib>
#include <iostream>
#include <memory>

namespace {

struct ViewArgs {
  std::vector<std::string> inputs;
  std::string handles, solver = gshell::pose_solver_name(gshell::PoseOptions{}.solver);
  gshell::ViewInputOptions input;
  gshell::ViewSessionOptions session;
  gshell::ViewServerOptions server;
  bool full_events = false; ///< --full-events: session.reduced_events off
};

void run(const CLI::App& cmd, ViewArgs& a) {
  using namespace gshell;
  cli::check_flags(cmd, [&] {
    if (a.full_events) a.session.reduced_events = false;
    a.session.pose.solver = parse_pose_solver(a.solver);
    cli::check_applies(cmd, "--levels", a.session.pose.solver == PoseSolverKind::Hierarchical, "--solver hierarchical");
    a.session.check();
    a.server.check();
    if (a.input.generate.thickness.thickness || a.input.generate.thickness.thickness_ratio)
      a.input.generate.thickness.check();
  });

  // What can be checked before the shell exists is, so that a typo does not wait for a generation.
  std::string handles_text;
  if (!a.handles.empty()) {
    handles_text = read_handle_file(a.handles);
    check_handle_file_syntax(handles_text, a.handles);
  }
  a.server.check_address();

  cli::Progress progress("view", 0.2);
  if (progress.enabled()) {
    cli::show_solve_progress(progress, a.input.generate.generate.solve, "generating the shell: ");
    a.input.frame_progress = [&progress](int done, int total) {
      progress.update("read frame " + std::to_string(done) + "/" + std::to_string(total));
    };
  }
  ViewInput input = load_view_input(a.inputs, a.input);
  progress.finish_status();
  if (!a.handles.empty() && !input.posable())
    throw InputError(with_file(a.handles, "handles pose a single shell, and " + a.inputs.front() +
                                              " is a sequence of frames (a deform output)"));
  cli::print_warnings("view", input.warnings);
  if (!input.frames_held)
    progress.line(std::to_string(input.frames.size()) + " frames take more than " +
                  std::to_string(a.input.held_frame_bytes >> 20) + " MiB together: each is read when shown");
  const int n = input.shell.num_base_vertices();
  const std::string what = std::to_string(2 * n) + " shell vertices, " + std::to_string(3 * input.shell.F.rows()) +
                           " tets" +
                           (input.posable() ? "" : ", " + std::to_string(input.frames.size()) + " frames");
  ViewSession session(std::move(input), a.session);
  if (!a.handles.empty()) session.load_handles(handles_text, a.handles, [](ViewOutgoing) {});

  a.server.log = [&progress](const std::string& line) { progress.line(line); };
  ViewServer server(std::move(session), a.server);
  std::cout << server.url() << std::endl; // the first line on stdout, for scripts
  progress.line("serving " + a.inputs.front() + (a.inputs.size() > 1 ? " ..." : "") + " (" + what + ") at " +
                server.url() + "; Ctrl-C stops");
  cli::on_next_interrupt([&server] { server.stop(); }); // Ctrl-C stops the server; a second one ends the process
  server.run();
  cli::on_next_interrupt({});
  // A solver build or a validity check cannot be interrupted; do not keep the user waiting for it.
  if (!server.wait_finished(std::chrono::milliseconds(500))) {
    progress.line("stopped");
    std::cout.flush();
    std::_Exit(0);
  }
  progress.line("stopped");
}

void add_view_command(CLI::App& app) {
  auto a = std::make_shared<ViewArgs>();
  CLI::App* cmd = app.add_subcommand(
      "view", "Interactive viewer in the browser: look around a shell (colored by stretch or thickness, cut away), "
              "play a deform sequence, or select handles and drag them while the shell follows (pose solver). "
              "Prints the page's URL as the first line on stdout; Ctrl-C stops.");
  cmd->add_option("inputs", a->inputs,
                  "A shell folder (generate, pose), a deform output folder, several shell folders (played as frames), "
                  "or a surface file / builtin:NAME[:RES] (a shell is generated first)")
      ->required();
  cmd->add_option("--port", a->server.port, "Port to serve on (0: any free port)")->capture_default_str();
  cmd->add_option("--host", a->server.host,
                  "Address to bind; the page accepts only requests naming this address or localhost")
      ->capture_default_str();
  cmd->add_option("--handles", a->handles, "Handle file (docs/handles.md) to start with; its motions are solved");
  cmd->add_option("--output-dir", a->session.output_dir,
                  "Folder where the page's \"save shell\" writes (only new folders, named on the page)")
      ->capture_default_str();
  gshell::cli::add_thickness_flags(*cmd, a->input.generate.thickness);
  cmd->add_option("--solver", a->solver, "Pose solver: hierarchical or single")
      ->check(CLI::IsMember({"hierarchical", "single"}))
      ->capture_default_str();
  cmd->add_option("--levels", a->session.pose.hierarchy.levels, "Levels of the hierarchical solver including the full one")
      ->capture_default_str();
  cmd->add_option("--tolerance", a->session.pose.solve.tolerance,
                  "Settle until the energy still to lose (estimated from how fast it falls) is below this fraction of it")
      ->capture_default_str();
  cmd->add_option("--iterations", a->session.pose.solve.max_iterations, "Maximum iterations of a settle")
      ->capture_default_str();
  cmd->add_option("--event-iterations", a->session.event_iterations,
                  "Iterations per drag event before the page gets the shell: of the hierarchy's finest reduced level, "
                  "or with --full-events of the full solver (the settle finishes the job)")
      ->capture_default_str();
  cmd->add_flag("--full-events", a->full_events,
                "Answer drag events with full-level iterations from the drag-extrapolated start (as pose --steps) "
                "instead of the reduced level's preview (slower on big shells)");
  cmd->callback([a, cmd] { run(*cmd, *a); });
}

const gshell::cli::CommandRegistrar reg{85, add_view_command};

} // namespace
