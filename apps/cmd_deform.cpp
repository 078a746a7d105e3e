// gshell deform: drive a generated shell by a sequence of deformed bases (paper §4.2, Fig. 6, 8;
// the run layer's deform job).
#include "command_registry.h"
#include "parameter_flags.h"
#include "preview_option.h"
#include "progress.h"
#include "warnings.h"

#include <gshell/quality/certificate_report.h>
#include <gshell/run/deform_run.h>
#include <gshell/run/staged_folder.h>

#include <chrono>
#include <cstdio>
#include <memory>

namespace {

struct DeformArgs {
  std::string shell;
  std::vector<std::string> frames;
  std::string out;
  gshell::DeformRunOptions options;
  std::string warm_start = gshell::warm_start_name(gshell::DeformOptions{}.warm_start);
  std::string embed;
  bool render = false;
  std::string view = "iso";
};

void run(const CLI::App& cmd, DeformArgs& a) {
  using namespace gshell;
  cli::check_flags(cmd, [&] {
    a.options.frame.warm_start = parse_warm_start(a.warm_start);
    a.options.check();
    // An empty name (an unset shell variable) ran without detail and without a word.
    if (cmd.count("--embed") > 0 && a.embed.empty()) throw InputError("--embed: the detail mesh's name is empty");
  });
  const ViewDirection view = cli::check_preview_flags(cmd, a.render, a.view);
  // Everything that can be wrong with the input is found before any work or output.
  check_output_folder(a.out, holds_only_deform_output);
  cli::Progress progress("deform");
  progress.terminal_status("reading " + a.shell + "..."); // seconds at millions of faces
  const DeformInput input = load_deform_input(a.shell, a.frames, a.embed);
  progress.finish_status();
  if (!input.rest_warning.empty()) cli::print_warning("deform", input.rest_warning);
  cli::print_warnings("deform", input.detail_warnings);

  // A long frame (a guarded one of a large shell, one whose guard regenerates its top) shows its
  // iterations as well, once it has run a second and then at most once a second, so a terminal
  // or a log shows it is alive; short frames show only their summary line. The count runs over
  // all of the frame's solves (paper, guarded sub-steps, a fresh top's), which each restart theirs;
  // the line names the one running.
  using Clock = std::chrono::steady_clock;
  Clock::time_point frame_began = Clock::now(), last_shown = frame_began; // last_shown: the frame's start at first
  int frame_iterations = 0;
  std::string frame_label, frame_stage; // frame_stage: "paper", "drag 3/17", ... (DeformOptions::stage)
  DeformRunOptions options = a.options; // with the status callbacks, which refer to this call's locals
  if (progress.enabled()) {
    // The status of the frame's solve running now; `iteration` 0 names the stage alone (the guard's
    // setup and test run no iterations and took seconds of silence on large shells).
    const auto show = [&](int iteration, double energy, bool now_or_never = false) {
      const auto now = Clock::now();
      if (!now_or_never && now - last_shown < std::chrono::seconds(1)) return;
      last_shown = now;
      char text[160];
      const double seconds = std::chrono::duration<double>(now - frame_began).count();
      if (iteration > 0)
        std::snprintf(text, sizeof text, "%s %s: iteration %d  energy %.6g  %.1f s", frame_label.c_str(),
                      frame_stage.c_str(), iteration, energy, seconds);
      else
        std::snprintf(text, sizeof text, "%s %s  %.1f s", frame_label.c_str(), frame_stage.c_str(), seconds);
      progress.update(text);
    };
    // A setup (the guard's, on the first frame: a minute at 2.6M vertices) is shown at once.
    options.frame.stage = [&, show](const char* name) {
      frame_stage = name;
      show(0, 0, cli::is_setup_stage(name));
    };
    options.frame.progress = [&, show](int, double energy, double) { show(++frame_iterations, energy); };
  }
  auto report = [&](const DeformRun& run, int count) {
    frame_began = last_shown = Clock::now();
    frame_iterations = 0;
    frame_label = "frame " + std::to_string(run.frames.size() + 1) + "/" + std::to_string(count);
    if (run.frames.empty()) {
      char factored[32];
      std::snprintf(factored, sizeof factored, "%.2f", run.factor_seconds);
      progress.line("shell " + std::to_string(run.base_vertices) + " base vertices, " + std::to_string(run.tets) +
                    " tets, factored in " + factored + " s; " + std::to_string(count) + " frames");
      if (run.embed)
        progress.line("embedded " + std::to_string(run.embed->points) + " detail vertices, " +
                      std::to_string(run.embed->outside) + " outside the shell");
      return;
    }
    const DeformFrameRecord& f = run.frames.back();
    char text[200];
    // The paper's iterations, and the guard's after them (the status above counted both).
    std::string iterations = std::to_string(f.result.iterations);
    if (f.result.guarded_iterations > 0) iterations += " + " + std::to_string(f.result.guarded_iterations) + " guarded";
    char setup[48] = ""; // building the guard: kept out of the frame's time, as the factorisation is
    if (f.result.guard_setup_seconds > 0)
      std::snprintf(setup, sizeof setup, " and %.1f s setting up the guard", f.result.guard_setup_seconds);
    std::snprintf(text, sizeof text, "frame %d/%d: %s iterations, %.1f ms%s, stretch %.3g, %s (%s", f.frame, count,
                  iterations.c_str(), 1e3 * f.result.seconds, setup, f.result.stretch.volume_mean,
                  f.result.valid ? "valid" : "INVALID", frame_method_name(f.result.method));
    std::string line = text;
    if (f.result.substeps > 1) line += ", " + std::to_string(f.result.substeps) + " sub-steps";
    if ((f.result.method == FrameMethod::Failed || f.result.method == FrameMethod::TetsOnly) && f.result.fresh_top)
      line += ", fresh top";
    line += ")";
    if (f.result.certificate.inverted_tets > 0) line += ", " + std::to_string(f.result.certificate.inverted_tets) + " inverted";
    if (!f.result.valid) {
      const std::string faults = unavoidable_faults(f.result.certificate.base_self_intersections, f.result.unextrudable_vertices);
      if (!faults.empty()) line += "; " + faults;
      else if (f.result.base_nearly_touching) line += "; parts of its base nearly touch";
    }
    if (f.offset) {
      std::snprintf(text, sizeof text, " | offset %.3g, %d inverted", f.offset->volume_mean, f.offset->inverted);
      line += text;
    }
    progress.update(line);
  };
  progress.update("setting up the solver (" + std::to_string(input.shell.num_base_vertices()) + " base vertices)...");
  const DeformRun run = run_deform(input, options, a.out, report, cli::preview_writer(a.render, a.out, view));
  const auto summary = run.to_json()["summary"];
  char text[200];
  std::snprintf(text, sizeof text, "%zu frames (%d valid), median %.1f ms and %g iterations per frame; wrote %s",
                run.frames.size(), summary["valid_frames"].get<int>(), 1e3 * summary["median_seconds"].get<double>(),
                summary["median_iterations"].get<double>(), a.out.c_str());
  progress.line(text);
  if (a.render) progress.line("wrote " + a.out + "/preview.png");
  // Even with --quiet: frames that are not valid are otherwise named only in report.json.
  cli::print_warnings("deform", run.warnings());
}

void add_deform_command(CLI::App& parent) {
  auto a = std::make_shared<DeformArgs>();
  auto* cmd = parent.add_subcommand(
      "deform", "Deform a shell by a sequence of deformed bases; the top follows with the least stretch");
  cmd->add_option("--shell", a->shell, "Shell folder written by `gshell generate`")->required();
  cmd->add_option("--base", a->frames,
                  "Deformed base frames (same vertex count and faces as the shell's base), or folders of them "
                  "(frame_NNNN.obj, as `gshell animate` writes)")
      ->required()
      ->expected(1, -1);
  cmd->add_option("-o,--output", a->out,
                  "Output folder: frame_NNNN/top.obj, frame_NNNN/shell.vtu (per-tet stretch), report.json")
      ->required();
  cmd->add_option("--tolerance", a->options.frame.tolerance, "Relative energy change that ends a frame")
      ->capture_default_str();
  cmd->add_option("--iterations", a->options.frame.max_iterations, "Maximum local/global iterations per frame (0: the frame's start itself)")
      ->capture_default_str();
  cmd->add_option("--warm-start", a->warm_start, "Start of each frame: extrapolated, rotated, translated or previous")
      ->capture_default_str();
  cmd->add_flag("--allow-invalid", a->options.frame.allow_invalid,
                "The paper's unguarded frames (may hold inverted tets and intersections), for comparison; by default "
                "every frame is valid by construction (step bounds, guarded sub-steps)");
  cmd->add_flag("--compare-offset", a->options.compare_offset,
                "Also report the stretch of re-extruding each frame by the plain vertex-normal offset");
  cmd->add_option("--embed", a->embed, "Detail mesh in the rest shell's space, carried along: frame_NNNN/detail.obj");
  gshell::cli::add_preview_flags(*cmd, a->render, a->view,
                                 "first, middle and last frame side by side, colored by stretch against the rest shell");
  cmd->callback([a, cmd] { run(*cmd, *a); });
}

const gshell::cli::CommandRegistrar reg{50, add_deform_command};

} // namespace
