// bench_deform: base-driven deformation of the bunny shell through a 30-frame bend (issue 5).
// Usage: bench_deform [MESH=models/bunny00.off] [--runs R=5] [--frames K=30] [--bend DEG=60]
// Prints the rest shell's size, the one-off factorization time, then for each warm start the
// per-frame time and iterations (medians over frames, then median over runs) to a relative energy
// tolerance of 1e-4, and the stretch against the rest shell compared with offset re-extrusion.
#include <gshell/deform/shell_deformer.h>
#include <gshell/deform/synthetic_motion.h>
#include <gshell/io/load_mesh.h>
#include <gshell/quality/stretch.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/solver/shell_solver.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <string>
#include <vector>

using namespace gshell;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t h = v.size() / 2;
  return v.size() % 2 ? v[h] : 0.5 * (v[h - 1] + v[h]);
}

struct RunStats {
  std::vector<double> ms, warm_ms, iterations, stretch, offset_stretch, max_stretch, offset_max;
  int inverted = 0, offset_inverted = 0, unconverged = 0;
};

RunStats run_sequence(ShellDeformer& deformer, const std::vector<Eigen::MatrixXd>& frames, WarmStart warm,
                      bool compare_offset) {
  RunStats s;
  deformer.reset();
  DeformOptions options;
  options.warm_start = warm;
  options.tolerance = 1e-4;
  options.measure_stretch = compare_offset;
  const Shell& rest = deformer.rest_shell();
  for (const Eigen::MatrixXd& base : frames) {
    const FrameResult r = deformer.solve(base, options);
    s.ms.push_back(1e3 * r.seconds);
    s.warm_ms.push_back(1e3 * r.warm_start_seconds);
    s.iterations.push_back(r.iterations);
    s.unconverged += r.converged ? 0 : 1;
    if (!compare_offset) continue;
    s.stretch.push_back(r.stretch.volume_mean);
    s.max_stretch.push_back(r.stretch.max);
    s.inverted += r.stretch.inverted;
    Eigen::MatrixXd X(2 * base.rows(), 3);
    X << base, offset_top(base, rest.F, rest.thickness);
    const StretchStats o = stretch_stats(deformer.rest_tets(), X);
    s.offset_stretch.push_back(o.volume_mean);
    s.offset_max.push_back(o.max);
    s.offset_inverted += o.inverted;
  }
  return s;
}

} // namespace

int main(int argc, char** argv) {
  std::string path = "models/bunny00.off";
  int runs = 5, frame_count = 30;
  double degrees = 60;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) runs = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--frames") && i + 1 < argc) frame_count = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--bend") && i + 1 < argc) degrees = std::atof(argv[++i]);
    else path = argv[i];
  }
  const TriMesh mesh = load_mesh(path);
  // The rest shell as `gshell generate --method rigid --thickness-ratio 0.01` makes it.
  GenerateOptions generate;
  generate.method = ShellMethod::Rigid;
  generate.thickness = thickness_from_ratio(mesh.V, 0.01);
  generate.count_intersections = false;
  const GenerateResult generated = generate_shell(mesh.V, mesh.F, generate);
  const Shell& rest = generated.shell;
  const double eta = rest.thickness, generate_seconds = generated.seconds.total;
  std::printf("mesh %s: %d base vertices, %d faces; shell %d vertices, %d tets, eta %.4g (generated in %.2f s)\n",
              path.c_str(), mesh.num_vertices(), mesh.num_faces(), 2 * mesh.num_vertices(), 3 * mesh.num_faces(), eta,
              generate_seconds);

  const auto setup_start = std::chrono::steady_clock::now();
  ShellDeformer deformer(rest);
  const double setup = std::chrono::duration<double>(std::chrono::steady_clock::now() - setup_start).count();
  std::printf("deformer setup %.3f s (factorization %.3f s, once for all frames); %d flat/inverted rest tets "
              "replaced by their normal prism\n",
              setup, deformer.factor_seconds(), deformer.replaced_rest_tets());

  const MotionFrame frame = motion_frame(rest.base);
  std::vector<Eigen::MatrixXd> frames;
  for (int k = 1; k <= frame_count; ++k) frames.push_back(bend(rest.base, frame, degrees * ramp(k, frame_count)));
  std::printf("%d frames: smooth bend to %.0f degrees about the bounding box's middle axis\n", frame_count, degrees);

  for (WarmStart warm : {WarmStart::Extrapolated, WarmStart::RotatedOffset, WarmStart::Translated, WarmStart::PreviousTop}) {
    std::vector<double> run_ms, run_iterations, run_max_ms, last_iterations;
    int unconverged = 0;
    const int warm_runs = warm == WarmStart::Extrapolated ? runs : 1;
    for (int r = 0; r < warm_runs; ++r) {
      const RunStats s = run_sequence(deformer, frames, warm, false);
      run_ms.push_back(median(s.ms));
      run_iterations.push_back(median(s.iterations));
      run_max_ms.push_back(*std::max_element(s.ms.begin(), s.ms.end()));
      unconverged += s.unconverged;
      last_iterations = s.iterations;
    }
    std::printf("warm start %-10s: median %.1f ms/frame (max frame %.1f ms), median %.1f iterations/frame, "
                "%d unconverged frames  [%d run(s); per-run medians:",
                warm_start_name(warm), median(run_ms), median(run_max_ms), median(run_iterations), unconverged,
                warm_runs);
    for (double m : run_ms) std::printf(" %.1f", m);
    std::printf("]\n    iterations per frame:");
    for (double i : last_iterations) std::printf(" %.0f", i);
    std::printf("\n");
  }

  const RunStats s = run_sequence(deformer, frames, WarmStart::Extrapolated, true);
  std::printf("warm start (extrapolated) median %.1f ms/frame; energy evaluation (one local step) ", median(s.warm_ms));
  {
    Eigen::MatrixXd X = deformer.current();
    std::vector<int> fixed(X.rows() / 2);
    std::iota(fixed.begin(), fixed.end(), 0);
    const ShellSolver probe(deformer.rest_tets(), static_cast<int>(X.rows()), fixed);
    std::vector<double> e_ms;
    for (int k = 0; k < 5; ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      volatile double e = probe.energy(X);
      (void)e;
      e_ms.push_back(1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::printf("median %.1f ms\n", median(e_ms));
  }
  std::printf("stretch vs rest shell, volume-weighted mean per frame: ours median %.3g (last frame %.3g), "
              "offset median %.3g (last frame %.3g)\n",
              median(s.stretch), s.stretch.back(), median(s.offset_stretch), s.offset_stretch.back());
  std::printf("max stretch over frames: ours %.3g, offset %.3g; inverted tets summed over frames: ours %d, offset %d\n",
              *std::max_element(s.max_stretch.begin(), s.max_stretch.end()),
              *std::max_element(s.offset_max.begin(), s.offset_max.end()), s.inverted, s.offset_inverted);
  return 0;
}
