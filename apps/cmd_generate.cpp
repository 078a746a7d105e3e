// `gshell generate INPUT -o DIR`: builds the shell of a surface and writes top.obj, base.obj,
// shell.vtu and report.json into DIR (paper §4.1; DESIGN.md "Shell generation").
#include "command_registry.h"
#include "thickness_option.h"
#include "shell_output.h"

#include <gshell/error.h>
#include <gshell/io/load_mesh.h>
#include <gshell/shell/curvature_shell.h>
#include <gshell/render/shell_render.h>
#include <gshell/shell/generate_report.h>
#include <gshell/shell/generate_shell.h>

#include <cmath>
#include <iostream>
#include <memory>
#include <optional>

namespace {

struct GenerateCliOptions {
  std::string input, output, method = "rigid";
  gshell::cli::ThicknessOption thickness;
  int iterations = 50;
  double tolerance = 1e-5;
  double s_min = gshell::kDefaultCurvatureSMin, s_max = gshell::kDefaultCurvatureSMax;
  bool render = false;
};

void run_generate(const GenerateCliOptions& o) {
  using namespace gshell;
  // Every parameter is checked before anything is read or written.
  o.thickness.check();
  if (o.iterations < 0) throw InputError("--iterations must not be negative");
  if (!(o.tolerance >= 0) || !std::isfinite(o.tolerance)) throw InputError("--tolerance must be a non-negative number");
  check_curvature_clamp(o.s_min, o.s_max);
  GenerateOptions options;
  options.method = parse_shell_method(o.method);
  options.s_min = o.s_min;
  options.s_max = o.s_max;
  cli::check_output_dir(o.output);

  const TriMesh mesh = load_mesh(o.input);
  options.thickness = o.thickness.eta(mesh.V);
  options.solve.max_iterations = o.iterations;
  options.solve.tolerance = o.tolerance;
  const bool quiet = cli::global_options().quiet;
  if (!quiet) {
    std::cerr << "gshell generate: " << o.input << " (" << mesh.num_vertices() << " vertices, " << mesh.num_faces()
              << " faces), method " << o.method << ", eta " << options.thickness << "\n";
    options.solve.progress = [](int it, double energy, double seconds) {
      std::cerr << "  iteration " << it << "  energy " << energy << "  " << seconds << " s\n";
    };
  }
  // The curvature method reports its clamps and its stretch against its own prisms too.
  std::optional<CurvatureShellResult> curvature;
  if (options.method == ShellMethod::Curvature) curvature = generate_curvature_shell(mesh.V, mesh.F, options);
  const GenerateResult result = curvature ? curvature->result : generate_shell(mesh.V, mesh.F, options);
  nlohmann::json report = generate_report(result, o.input, o.thickness.ratio);
  if (curvature) add_curvature_report(report, *curvature);
  cli::write_shell_dir(o.output, mesh, result.shell, result.metrics, report);
  std::cout << generate_summary(result, o.input) << (curvature ? curvature_summary(*curvature) : "")
            << "wrote        " << o.output
            << "/{top.obj, base.obj, shell.vtu, report.json}\n";
  if (o.render) std::cout << "wrote        " << render_shell_preview(o.output) << "\n";
}

void add_generate_command(CLI::App& app) {
  auto o = std::make_shared<GenerateCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "generate", "Generate the shell of a surface: optimise the top surface so that every prism is as close "
                  "to its ideal (normal) prism as possible. Writes DIR/top.obj, base.obj, shell.vtu, report.json.");
  cmd->add_option("input", o->input, "Base surface: mesh file (.obj .off .ply .stl) or builtin:NAME[:RES]")
      ->required();
  cmd->add_option("-o,--output", o->output, "Output folder (created; existing files of the same names are replaced)")
      ->required();
  o->thickness.add_to(*cmd);
  cmd->add_option("--method", o->method, "rigid (optimised, default), offset (vertex-normal offset) or curvature");
  cmd->add_option("--iterations", o->iterations, "Maximum local/global iterations (default 50)");
  cmd->add_option("--tolerance", o->tolerance, "Stop when the relative energy change is below this (default 1e-5)");
  cmd->add_option("--s-min", o->s_min, "Curvature method: smallest in-plane scale of a top triangle (default 0.5)");
  cmd->add_option("--s-max", o->s_max, "Curvature method: largest in-plane scale of a top triangle (default 2)");
  cmd->add_flag("--render", o->render, "Also write DIR/preview.png: a headless render colored by stretch");
  cmd->callback([o] { run_generate(*o); });
}

const gshell::cli::CommandRegistrar reg{30, add_generate_command};

} // namespace
