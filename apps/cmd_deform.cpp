// gshell deform: drive a generated shell by a sequence of deformed bases (paper §4.2, Fig. 6, 8).
#include "command_registry.h"

#include <gshell/deform/base_frames.h>
#include <gshell/deform/embedding.h>
#include <gshell/deform/shell_deformer.h>
#include <gshell/deform/staged_folder.h>
#include <gshell/error.h>
#include <gshell/io/atomic_file.h>
#include <gshell/io/read_mesh.h>
#include <gshell/io/tet_mesh_io.h>
#include <gshell/io/write_mesh.h>
#include <gshell/quality/stretch.h>
#include <gshell/render/camera.h>
#include <gshell/render/scene.h>
#include <gshell/render/shell_render.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/shell/shell_dir.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <numeric>
#include <regex>

namespace {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

struct DeformArgs {
  std::string shell;
  std::vector<std::string> frames;
  std::string out;
  double tolerance = 1e-4;
  int iterations = 50;
  std::string warm_start = "extrapolated";
  bool compare_offset = false;
  std::string embed;
  bool render = false;
  std::string view = "iso";
};

std::string frame_folder(int k) {
  char name[32];
  std::snprintf(name, sizeof name, "frame_%04d", k);
  return name;
}

json stretch_json(const gshell::StretchStats& s) {
  return json{{"mean", s.mean}, {"volume_mean", s.volume_mean}, {"max", s.max}, {"p99", s.p99}};
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t h = v.size() / 2;
  return v.size() % 2 ? v[h] : 0.5 * (v[h - 1] + v[h]);
}

bool holds_deform_output(const fs::path& dir) {
  static const std::regex frame_dir(R"(frame_\d{4,})");
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name != "report.json" && name != "preview.png" && !std::regex_match(name, frame_dir)) return false;
  }
  return true;
}

void run_deform(const DeformArgs& args) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const bool quiet = gshell::cli::global_options().quiet;
  if (!(args.tolerance >= 0) || !std::isfinite(args.tolerance)) throw gshell::InputError("--tolerance must be >= 0");
  if (args.iterations < 0) throw gshell::InputError("--iterations must be >= 0");
  const gshell::ViewDirection view = gshell::parse_view(args.view); // fails before the solve, not after
  if (args.render && !gshell::offscreen_rendering_available())
    throw gshell::InputError("--render: gshell was built without OSMesa");
  gshell::DeformOptions options;
  options.tolerance = args.tolerance;
  options.max_iterations = args.iterations;
  options.warm_start = gshell::parse_warm_start(args.warm_start);

  // Everything that can be wrong with the input is found before any work or output.
  gshell::TriMesh uv_source;
  const gshell::Shell shell = gshell::load_shell_dir(args.shell, &uv_source);
  const int n = shell.num_base_vertices();
  const std::vector<Eigen::MatrixXd> frames = gshell::load_base_frames(args.frames, shell.F, n);
  gshell::TriMesh detail;
  if (!args.embed.empty()) {
    detail = gshell::read_mesh(args.embed);
    if (!detail.V.allFinite()) throw gshell::InputError(gshell::with_file(args.embed, "has a non-finite coordinate"));
  }

  gshell::ShellDeformer deformer(shell);
  const Eigen::MatrixXi tets = gshell::build_prism_tets(shell.F, n);
  gshell::Embedding embedding;
  if (!args.embed.empty()) embedding = gshell::embed_points(shell.vertices(), tets, detail.V);
  const double setup_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (!quiet) {
    std::cerr << "deform: shell " << n << " base vertices, " << tets.rows() << " tets, factored in "
              << deformer.factor_seconds() << " s; " << frames.size() << " frames\n";
    if (deformer.replaced_rest_tets() > 0)
      std::cerr << "deform: " << deformer.replaced_rest_tets()
                << " flat or inverted shell tets use their normal prism as rest shape\n";
    if (!args.embed.empty())
      std::cerr << "deform: embedded " << embedding.size() << " detail vertices, " << embedding.outside.size()
                << " outside the shell\n";
  }

  gshell::StagedFolder staged(args.out);
  json frame_reports = json::array();
  std::vector<double> seconds, iterations;
  gshell::StretchStats worst;
  double volume_mean_sum = 0, offset_volume_mean_sum = 0, offset_worst_max = 0;
  int inverted_total = 0, offset_inverted_total = 0, unconverged = 0;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const gshell::FrameResult r = deformer.solve(frames[k], options);
    const fs::path dir = staged.path() / frame_folder(static_cast<int>(k + 1));
    fs::create_directory(dir);

    gshell::TriMesh top;
    top.V = r.top;
    top.F = shell.F;
    if (uv_source.has_uv()) {
      top.UV = uv_source.UV;
      top.FUV = uv_source.FUV;
    }
    gshell::write_mesh((dir / "top.obj").string(), top);
    gshell::TetMesh tet_mesh;
    tet_mesh.X = deformer.current();
    tet_mesh.T = tets;
    tet_mesh.cell_data.emplace_back("stretch", gshell::tet_stretch(deformer.rest_tets(), tet_mesh.X));
    tet_mesh.cell_data.emplace_back("det_F", gshell::tet_deformation_determinants(deformer.rest_tets(), tet_mesh.X));
    gshell::write_tet_mesh((dir / "shell.vtu").string(), tet_mesh);
    if (!args.embed.empty()) {
      gshell::TriMesh carried = detail;
      carried.V = gshell::carry(embedding, deformer.current());
      gshell::write_mesh((dir / "detail.obj").string(), carried);
    }

    json report{{"frame", k + 1},
                {"base", args.frames[k]},
                {"iterations", r.iterations},
                {"converged", r.converged},
                {"energy", r.energy},
                {"stretch", stretch_json(r.stretch)},
                {"inverted_tets", r.stretch.inverted},
                {"seconds", r.seconds}};
    seconds.push_back(r.seconds);
    iterations.push_back(r.iterations);
    worst.max = std::max(worst.max, r.stretch.max);
    volume_mean_sum += r.stretch.volume_mean;
    inverted_total += r.stretch.inverted;
    unconverged += r.converged ? 0 : 1;
    std::string offset_note;
    if (args.compare_offset) {
      Eigen::MatrixXd X(2 * n, 3);
      X << frames[k], gshell::offset_top(frames[k], shell.F, shell.thickness);
      const gshell::StretchStats o = gshell::stretch_stats(deformer.rest_tets(), X);
      report["offset"] = json{{"stretch", stretch_json(o)}, {"inverted_tets", o.inverted}};
      offset_volume_mean_sum += o.volume_mean;
      offset_worst_max = std::max(offset_worst_max, o.max);
      offset_inverted_total += o.inverted;
      char note[96];
      std::snprintf(note, sizeof note, " | offset %.3g, %d inverted", o.volume_mean, o.inverted);
      offset_note = note;
    }
    frame_reports.push_back(std::move(report));
    if (!quiet) {
      char line[160];
      std::snprintf(line, sizeof line, "deform: frame %zu/%zu: %d iterations, %.1f ms, stretch %.3g, %d inverted",
                    k + 1, frames.size(), r.iterations, 1e3 * r.seconds, r.stretch.volume_mean, r.stretch.inverted);
      std::cerr << line << offset_note << "\n";
    }
  }

  const double frames_count = static_cast<double>(frames.size());
  json summary{{"frames", frames.size()},
               {"median_seconds", median(seconds)},
               {"total_seconds", std::accumulate(seconds.begin(), seconds.end(), 0.0)},
               {"median_iterations", median(iterations)},
               {"max_iterations", *std::max_element(iterations.begin(), iterations.end())},
               {"unconverged_frames", unconverged},
               {"mean_volume_stretch", volume_mean_sum / frames_count},
               {"max_stretch", worst.max},
               {"inverted_tets", inverted_total}};
  if (args.compare_offset)
    summary["offset"] = json{{"mean_volume_stretch", offset_volume_mean_sum / frames_count},
                             {"max_stretch", offset_worst_max},
                             {"inverted_tets", offset_inverted_total}};
  json report{{"command", "deform"},
              {"shell", args.shell},
              {"base_vertices", n},
              {"tets", tets.rows()},
              {"thickness", shell.thickness},
              {"tolerance", options.tolerance},
              {"max_iterations", options.max_iterations},
              {"warm_start", gshell::warm_start_name(options.warm_start)},
              {"replaced_rest_tets", deformer.replaced_rest_tets()},
              {"factor_seconds", deformer.factor_seconds()},
              {"setup_seconds", setup_seconds}};
  if (!args.embed.empty())
    report["embed"] = json{{"detail", args.embed},
                           {"points", embedding.size()},
                           {"outside", embedding.outside.size()},
                           {"max_outside_distance", embedding.max_outside_distance}};
  report["summary"] = summary;
  report["frames"] = frame_reports;
  gshell::write_file_atomically((staged.path() / "report.json").string(),
                                [&](std::ostream& os) { os << report.dump(2) << "\n"; });
  // Rendered inside the staged folder, so the preview arrives together with the frames or not at all.
  if (args.render) gshell::render_shell_preview(staged.path().string(), args.out, view);
  staged.commit(holds_deform_output);
  if (!quiet)
    std::cerr << "deform: " << frames.size() << " frames, median " << 1e3 * median(seconds) << " ms and "
              << median(iterations) << " iterations per frame; wrote " << args.out << "\n";
  if (args.render && !quiet) std::cerr << "deform: wrote " << (fs::path(args.out) / "preview.png").string() << "\n";
}

void add_deform_command(CLI::App& parent) {
  auto args = std::make_shared<DeformArgs>();
  auto* cmd = parent.add_subcommand(
      "deform", "Deform a shell by a sequence of deformed bases; the top follows with the least stretch");
  cmd->add_option("--shell", args->shell, "Shell folder written by `gshell generate`")->required();
  cmd->add_option("--base", args->frames, "Deformed base frames (same vertex count and faces as the shell's base)")
      ->required()
      ->expected(1, -1);
  cmd->add_option("-o,--output", args->out,
                  "Output folder: frame_NNNN/top.obj, frame_NNNN/shell.vtu (per-tet stretch), report.json")
      ->required();
  cmd->add_option("--tolerance", args->tolerance, "Relative energy change that ends a frame")->capture_default_str();
  cmd->add_option("--iterations", args->iterations, "Maximum local/global iterations per frame")
      ->capture_default_str();
  cmd->add_option("--warm-start", args->warm_start, "Start of each frame: extrapolated, rotated, translated or previous")
      ->capture_default_str();
  cmd->add_flag("--compare-offset", args->compare_offset,
                "Also report the stretch of re-extruding each frame by the plain vertex-normal offset");
  cmd->add_option("--embed", args->embed,
                  "Detail mesh in the rest shell's space, carried along: frame_NNNN/detail.obj");
  CLI::Option* render = cmd->add_flag("--render", args->render,
                                      "Also write OUT/preview.png: first, middle and last frame side by side, "
                                      "colored by stretch against the rest shell");
  cmd->add_option("--view", args->view,
                  "Preview direction: front|back|left|right|top|bottom|iso or AZIMUTH,ELEVATION (y up)")
      ->needs(render);
  cmd->callback([args] { run_deform(*args); });
}

const gshell::cli::CommandRegistrar reg{50, add_deform_command};

} // namespace
