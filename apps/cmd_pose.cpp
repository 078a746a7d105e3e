// `gshell pose`: direct shell deformation with handles (paper §4.2, second type), solved by the
// hierarchical solver (paper §5) or the single-level one; optionally as a drag in K steps.
#include "command_registry.h"

#include <gshell/deform/handles.h>
#include <gshell/deform/pose.h>
#include <gshell/deform/staged_folder.h>
#include <gshell/error.h>
#include <gshell/io/atomic_file.h>
#include <gshell/io/tet_mesh_io.h>
#include <gshell/io/write_mesh.h>
#include <gshell/quality/stretch.h>
#include <gshell/render/camera.h>
#include <gshell/render/scene.h>
#include <gshell/render/shell_render.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/shell/shell_dir.h>
#include <gshell/solver/rest_tets.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct PoseCliOptions {
  std::string shell_dir, handles, output, solver = "hierarchical";
  int levels = 5, steps = 1, iterations = 500; // as the Python Poser.solve defaults
  double tolerance = 1e-6;
  bool render = false;
  std::string view = "iso";
};

/// An existing -o folder is replaced only if it holds nothing but an earlier pose output.
bool holds_pose_output(const fs::path& dir) {
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name != "top.obj" && name != "base.obj" && name != "shell.vtu" && name != "report.json" && name != "preview.png")
      return false;
  }
  return true;
}

nlohmann::json stretch_json(const gshell::StretchStats& s) {
  return {{"mean", s.mean}, {"volume_mean", s.volume_mean}, {"max", s.max}, {"p99", s.p99}, {"inverted", s.inverted}};
}

void run(const PoseCliOptions& o) {
  using namespace gshell;
  const bool quiet = cli::global_options().quiet;
  if (o.steps < 1) throw InputError("--steps must be >= 1");
  if (o.levels < 1) throw InputError("--levels must be >= 1");
  if (o.iterations < 1) throw InputError("--iterations must be >= 1");
  if (!(o.tolerance >= 0)) throw InputError("--tolerance must be >= 0");
  if (o.render && !offscreen_rendering_available()) throw InputError("--render: gshell was built without OSMesa");
  const ViewDirection view = parse_view(o.view); // a bad view fails before the solve, not after

  TriMesh base_mesh;
  const Shell rest = load_shell_dir(o.shell_dir, &base_mesh);
  const HandleSet handles = read_handles(o.handles, rest);
  StagedFolder staging(o.output); // fail on a bad output path before the long part
  auto staged = [&](const char* name) { return (staging.path() / name).string(); };

  PoseOptions options;
  options.solver = o.solver == "single" ? PoseSolverKind::Single : PoseSolverKind::Hierarchical;
  options.hierarchy.levels = o.levels;
  options.steps = o.steps;
  options.solve.max_iterations = o.iterations;
  options.solve.tolerance = o.tolerance;
  auto last_print = std::make_shared<Clock::time_point>(Clock::now());
  if (!quiet)
    options.step_progress = [last_print, &o](int step, int it, double energy, double) {
      if (Clock::now() - *last_print < std::chrono::milliseconds(500)) return;
      *last_print = Clock::now();
      std::cerr << "gshell pose: step " << step << "/" << o.steps << " iteration " << it << " energy " << energy << "\n";
    };
  if (!quiet)
    std::cerr << "gshell pose: " << rest.num_base_vertices() * 2 << " shell vertices, "
              << handles.constrained_vertices().size() << " handle vertices ("
              << (handles.mode == ConstraintMode::Hard ? "hard" : "soft") << "), " << o.solver << " solver\n";
  const PoseResult result = run_pose(rest, handles, options);

  const int n = rest.num_base_vertices();
  const RestTets tets = rest_tets_from_positions(rest.vertices(), build_prism_tets(rest.F, n));
  const StretchStats stats = stretch_stats(tets, result.X);
  if (!quiet)
    for (size_t k = 0; k < result.steps.size(); ++k) {
      const auto& s = result.steps[k];
      std::cerr << "gshell pose: step " << k + 1 << "/" << result.steps.size() << ": " << s.iterations
                << " iterations, energy " << s.energy << ", " << std::fixed << std::setprecision(3) << s.seconds
                << " s" << std::defaultfloat << (s.converged ? "" : " (not converged)") << "\n";
    }

  TriMesh base = base_mesh, top = base_mesh;
  base.V = result.X.topRows(n);
  top.V = result.X.bottomRows(n);
  write_mesh(staged("base.obj"), base);
  write_mesh(staged("top.obj"), top);
  TetMesh shell_mesh;
  shell_mesh.X = result.X;
  shell_mesh.T = tets.T;
  shell_mesh.cell_data.emplace_back("stretch", tet_stretch(tets, result.X));
  shell_mesh.cell_data.emplace_back("det_F", tet_deformation_determinants(tets, result.X));
  write_tet_mesh(staged("shell.vtu"), shell_mesh);

  nlohmann::json report;
  report["command"] = "pose";
  report["shell"] = o.shell_dir;
  report["handles"] = o.handles;
  report["solver"] = o.solver;
  report["levels"] = options.solver == PoseSolverKind::Hierarchical ? o.levels : 1;
  report["mode"] = handles.mode == ConstraintMode::Hard ? "hard" : "soft";
  if (handles.mode == ConstraintMode::Soft) report["weight"] = handles.weight;
  report["thickness"] = rest.thickness; // OUT is a shell folder too
  report["vertices"] = 2 * n;
  report["tets"] = tets.size();
  report["handle_vertices"] = handles.constrained_vertices().size();
  report["setup_seconds"] = result.setup_seconds;
  report["tolerance"] = o.tolerance;
  report["max_iterations"] = o.iterations;
  nlohmann::json steps = nlohmann::json::array();
  for (const auto& s : result.steps)
    steps.push_back({{"fraction", s.fraction}, {"iterations", s.iterations}, {"energy", s.energy},
                     {"seconds", s.seconds}, {"converged", s.converged}});
  report["steps"] = steps;
  report["stretch"] = stretch_json(stats);
  write_file_atomically(staged("report.json"), [&](std::ostream& out) { out << report.dump(2) << "\n"; });
  if (o.render) // inside the staging folder: the preview lands with the rest or not at all
    render_shell_preview(staging.path().string(), o.output, view);
  staging.commit(holds_pose_output);
  if (!quiet)
    std::cerr << "gshell pose: wrote " << o.output << " (top.obj, base.obj, shell.vtu, report.json"
              << (o.render ? ", preview.png" : "") << ")\n";
}

void add_pose_command(CLI::App& app) {
  auto o = std::make_shared<PoseCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "pose", "Deform a shell directly with handles (both surfaces move; paper §4.2) using the hierarchical "
              "solver (paper §5) or the single-level one. Writes OUT/top.obj, base.obj, shell.vtu (per-tet "
              "stretch against the input shell) and report.json (per step: iterations, energy, seconds).");
  cmd->add_option("--shell", o->shell_dir, "Shell folder (from gshell generate: base.obj, top.obj, report.json)")
      ->required();
  cmd->add_option("--handles", o->handles, "Handle file (JSON, see docs/handles.md)")->required();
  cmd->add_option("--solver", o->solver, "hierarchical (default) or single")
      ->check(CLI::IsMember({"hierarchical", "single"}));
  cmd->add_option("--levels", o->levels, "Levels of the hierarchical solver including the full one (default 5)");
  cmd->add_option("--steps", o->steps, "Move the handles from rest to target in K equal steps, solving after each (default 1)");
  cmd->add_option("--tolerance", o->tolerance, "Stop a step when the relative energy change per iteration is below this (default 1e-6)");
  cmd->add_option("--iterations", o->iterations, "Maximum iterations per step (default 500)");
  cmd->add_option("-o,--output", o->output,
                  "Output folder (an earlier pose output there is replaced; a folder of other files is an error)")
      ->required();
  CLI::Option* render =
      cmd->add_flag("--render", o->render, "Also write OUT/preview.png: the rest and the posed shell, colored by stretch");
  cmd->add_option("--view", o->view, "Preview direction: front|back|left|right|top|bottom|iso or AZIMUTH,ELEVATION (y up)")
      ->needs(render);
  cmd->callback([o] { run(*o); });
}

const gshell::cli::CommandRegistrar reg{70, add_pose_command};

} // namespace
