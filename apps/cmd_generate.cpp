// `gshell generate INPUT -o DIR`: builds the shell of a surface and writes top.obj, base.obj,
// shell.vtu and report.json into DIR (paper §4.1; the run layer's generate job).
#include "command_registry.h"
#include "parameter_flags.h"
#include "preview_option.h"
#include "progress.h"
#include "thickness_flags.h"
#include "warnings.h"

#include <gshell/error.h>
#include <gshell/io/load_mesh.h>
#include <gshell/run/generate_run.h>
#include <gshell/run/staged_folder.h>

#include <cstdio>
#include <iostream>
#include <memory>

namespace {

struct GenerateArgs {
  std::string input, output, method = gshell::to_string(gshell::GenerateOptions{}.method);
  gshell::GenerateRunOptions options;
  bool render = false;
  std::string view = "iso";
};

void run(const CLI::App& cmd, GenerateArgs& a) {
  using namespace gshell;
  // Every parameter is checked before anything is read or written.
  cli::check_flags(cmd, [&] {
    a.options.generate.method = parse_shell_method(a.method);
    a.options.check();
  });
  // Options a run would ignore are mistakes to be told of: the offset is not optimised, and the
  // unguarded run is the paper's plain iteration from the plain offset.
  const ShellMethod method = a.options.generate.method;
  for (const char* flag : {"--s-min", "--s-max"})
    cli::check_applies(cmd, flag, method == ShellMethod::Curvature, "--method curvature");
  for (const char* flag : {"--iterations", "--tolerance", "--anderson", "--start-smoothing", "--allow-invalid"})
    cli::check_applies(cmd, flag, method != ShellMethod::Offset, "--method rigid or curvature");
  for (const char* flag : {"--anderson", "--start-smoothing"})
    cli::check_applies(cmd, flag, !a.options.generate.allow_invalid, "guarded runs (not with --allow-invalid)");
  const ViewDirection view = cli::check_preview_flags(cmd, a.render, a.view);
  check_output_folder(a.output, [](const std::filesystem::path& d) { return gshell::holds_shell_output_of(d, "generate"); });
  cli::Progress progress("generate");
  progress.terminal_status("reading " + a.input + "..."); // seconds at millions of faces
  std::vector<std::string> input_warnings;
  TriMesh mesh = load_mesh(a.input, &input_warnings);
  const double eta_value = a.options.thickness.eta(mesh.V, mesh.F);
  check_thickness_scale(mesh.V, mesh.F, eta_value); // as generation would, but before a progress line
  char eta[32];
  std::snprintf(eta, sizeof eta, "%g", eta_value);
  progress.line(a.input + " (" + std::to_string(mesh.num_vertices()) + " vertices, " +
                std::to_string(mesh.num_faces()) + " faces), method " + a.method + ", eta " + eta);
  cli::show_solve_progress(progress, a.options.generate.solve);
  const GenerateRun result = run_generate(std::move(mesh), a.input, a.options, std::move(input_warnings));
  progress.finish_status();
  cli::print_warnings("generate", result.warnings());
  progress.update("writing " + a.output + "..."); // a 2.6M-vertex shell is 1.7 GB of files
  result.write(a.output, cli::preview_writer(a.render, a.output, view));
  progress.finish_status();
  std::cout << result.summary() << "wrote        " << a.output << "/{top.obj, base.obj, shell.vtu, report.json"
            << (a.render ? ", preview.png" : "") << "}\n";
}

void add_generate_command(CLI::App& app) {
  auto a = std::make_shared<GenerateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "generate", "Generate the shell of a surface: optimise the top surface so that every prism is as close "
                  "to its ideal (normal) prism as possible. Writes DIR/top.obj, base.obj, shell.vtu, report.json.");
  cmd->add_option("input", a->input, "Base surface: mesh file (.obj .off .ply .stl) or builtin:NAME[:RES]")
      ->required();
  cmd->add_option("-o,--output", a->output,
                  "Output folder (an earlier shell folder there is replaced; a folder of other files is an error)")
      ->required();
  gshell::cli::add_thickness_flags(*cmd, a->options.thickness);
  cmd->add_option("--method", a->method, "rigid (optimised), offset (vertex-normal offset) or curvature")
      ->capture_default_str();
  cmd->add_option("--iterations", a->options.generate.solve.max_iterations, "Maximum local/global iterations (0: the start itself)")
      ->capture_default_str();
  cmd->add_option("--tolerance", a->options.generate.solve.tolerance, "Stop when the relative energy change is below this")
      ->capture_default_str();
  cmd->add_option("--anderson", a->options.generate.solve.anderson_history,
                  "Anderson acceleration of the local/global iterations: iterates combined, 0 to 100 (0: the "
                  "paper's plain iteration; not with --allow-invalid, which runs the plain iteration)")
      ->capture_default_str();
  cmd->add_option("--start-smoothing", a->options.generate.guard.start_smoothing,
                  "Start the local/global iterations from the offset along vertex normals smoothed over this "
                  "fraction of the thickness (0: the raw normals, the paper's offset surface; not with "
                  "--allow-invalid, which starts there)")
      ->capture_default_str();
  cmd->add_flag("--allow-invalid", a->options.generate.allow_invalid,
                "Rigid and curvature: skip the guard and keep the paper's unguarded result, which may have inverted "
                "tets and intersections (the report certifies it either way)");
  cmd->add_option("--s-min", a->options.generate.s_min, "Curvature method: smallest in-plane scale of a top triangle")
      ->capture_default_str();
  cmd->add_option("--s-max", a->options.generate.s_max, "Curvature method: largest in-plane scale of a top triangle")
      ->capture_default_str();
  gshell::cli::add_preview_flags(*cmd, a->render, a->view, "a headless render colored by stretch");
  cmd->callback([a, cmd] { run(*cmd, *a); });
}

const gshell::cli::CommandRegistrar reg{30, add_generate_command};

} // namespace
