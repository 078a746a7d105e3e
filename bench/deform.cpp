// bench_deform: base-driven deformation of the bunny shell through a 30-frame bend or twist (issues 5, 14).
// Usage: bench_deform [MESH=models/bunny00.off] [--runs R=5] [--frames K=30] [--bend DEG=60 | --twist DEG]
//                     [--ratio R=0.01] [--validity-only] [--mend-rings N]
// Prints the rest shell's size, the one-off factorization time, then guarded (valid by
// construction, the default) against unguarded (--allow-invalid) frames, runs interleaved: median
// time per frame, valid frames and inverted tets per frame by the exact certificate (not timed);
// then (unless --validity-only) for each warm start the unguarded per-frame time and iterations
// (medians over frames, then median over runs) to a relative energy tolerance of 1e-4, and the
// stretch against the rest shell compared with offset re-extrusion.
#include "bench_main.h"
#include "bench_common.h"

#include <gshell/deform/shell_deformer.h>
#include <gshell/deform/synthetic_motion.h>
#include <gshell/error.h>
#include <gshell/io/load_mesh.h>
#include <gshell/quality/stretch.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/solver/shell_solver.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <numeric>
#include <string>
#include <vector>

using namespace gshell;
using gshell::bench::median;

namespace {

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
  options.allow_invalid = true; // the warm starts compared on the paper's solve alone
  options.certify = false;
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

struct ValidityStats {
  std::vector<double> ms, cpu_ms; // wall, and CPU summed over threads (steadier on a loaded machine)
  std::vector<double> certificate_ms; // the exact certificate inside the guard's acceptance (part of ms)
  std::vector<double> energy; // the frame's (E of the state returned)
  std::vector<double> paper_energy; // the paper's solve's, before the guard replaced it (if it did)
  std::vector<int> inverted, substeps, intersections, guarded_iterations;
  std::vector<std::string> methods;
  int valid = 0;
};

ValidityStats run_validity(ShellDeformer& deformer, const std::vector<Eigen::MatrixXd>& frames, bool allow_invalid,
                           bool certify, int mend_rings) {
  ValidityStats s;
  deformer.reset();
  DeformOptions options;
  options.allow_invalid = allow_invalid;
  options.guard.mend_rings = mend_rings;
  options.measure_stretch = false;
  options.certify = certify;
  for (const Eigen::MatrixXd& base : frames) {
    const std::clock_t cpu0 = std::clock();
    const FrameResult r = deformer.solve(base, options);
    const std::clock_t cpu1 = std::clock();
    // CPU of the frame without the (untimed) certificate and its share of the run's wall time.
    s.cpu_ms.push_back(1e3 * static_cast<double>(cpu1 - cpu0) / CLOCKS_PER_SEC *
                       (r.seconds / std::max(1e-12, r.seconds + r.certificate_seconds)));
    s.ms.push_back(1e3 * r.seconds);
    if (r.certified) s.certificate_ms.push_back(1e3 * r.certificate.seconds);
    s.valid += r.valid ? 1 : 0;
    s.inverted.push_back(r.certificate.inverted_tets);
    s.intersections.push_back(r.certificate.top_self_intersections + r.certificate.top_base_intersections +
                              r.certificate.wall_intersections);
    s.substeps.push_back(r.substeps);
    s.guarded_iterations.push_back(r.guarded_iterations);
    s.energy.push_back(r.energy.back());
    s.paper_energy.push_back(r.energy[r.iterations]); // energy[0] is the warm start's
    s.methods.push_back(frame_method_name(r.method));
  }
  return s;
}

void print_list(const char* name, const std::vector<int>& v) {
  std::printf("    %s:", name);
  for (int x : v) std::printf(" %d", x);
  std::printf("\n");
}

} // namespace

constexpr const char* kUsage = "usage: bench_deform [MESH=models/bunny00.off] [--runs R=5] [--frames K=30] "
                                "[--bend DEG=60 | --twist DEG] [--ratio R=0.01] [--validity-only] [--mend-rings N]\n"
                                "  --mend-rings N  the guard's mend of a refused frame over N rings (-1: drag only; "
                                "default: DeformOptions{}'s)\n";

int bench_main(int argc, char** argv) {
  std::string path = "models/bunny00.off";
  int runs = 5, frame_count = 30;
  double degrees = 60, ratio = 0.01;
  bool twisting = false; // else bending
  bool validity_only = false;
  int mend_rings = DeformOptions{}.guard.mend_rings;
  // A bad option is one line and exit 1, not a load_mesh exception for a "mesh" named --help.
  const auto bad = [&](const char* what, const char* arg) {
    std::fprintf(stderr, "bench_deform: %s '%s' (see --help)\n", what, arg);
    std::exit(1);
  };
  const auto number = [&](int& i) {
    if (i + 1 >= argc) bad("missing value for", argv[i]);
    char* end = nullptr;
    const double v = std::strtod(argv[++i], &end);
    if (end == argv[i] || *end || !std::isfinite(v)) bad("not a number:", argv[i]);
    return v;
  };
  for (int i = 1; i < argc; ++i) {
    const char* a = argv[i];
    if (!std::strcmp(a, "--runs")) runs = static_cast<int>(number(i));
    else if (!std::strcmp(a, "--frames")) frame_count = static_cast<int>(number(i));
    else if (!std::strcmp(a, "--bend")) degrees = number(i), twisting = false;
    else if (!std::strcmp(a, "--twist")) degrees = number(i), twisting = true;
    else if (!std::strcmp(a, "--ratio")) ratio = number(i);
    else if (!std::strcmp(a, "--validity-only")) validity_only = true;
    else if (!std::strcmp(a, "--mend-rings")) mend_rings = static_cast<int>(number(i));
    else if (a[0] == '-') bad("unknown option", a);
    else path = a;
  }
  if (runs < 1) bad("--runs must be >= 1, got", std::to_string(runs).c_str());
  if (frame_count < 1) bad("--frames must be >= 1, got", std::to_string(frame_count).c_str());
  if (!(ratio > 0)) bad("--ratio must be > 0, got", std::to_string(ratio).c_str());
  if (mend_rings < -1) bad("--mend-rings must be >= -1, got", std::to_string(mend_rings).c_str());
  TriMesh mesh;
  try {
    mesh = load_mesh(path);
  } catch (const InputError& e) {
    std::fprintf(stderr, "bench_deform: %s\n", e.what());
    return 1;
  }
  const GenerateResult generated = gshell::bench::rigid_rest_shell(mesh, ratio);
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
  for (int k = 1; k <= frame_count; ++k) {
    const double at = degrees * ramp(k, frame_count);
    frames.push_back(twisting ? twist(rest.base, frame, at) : bend(rest.base, frame, at));
  }
  std::printf("%d frames: smooth %s to %.0f degrees about the bounding box's %s axis (thickness ratio %g)\n",
              frame_count, twisting ? "twist" : "bend", degrees, twisting ? "long" : "middle", ratio);

  {
    // Certified once per mode (not timed), then timed runs interleaved guarded / unguarded.
    const ValidityStats guarded = run_validity(deformer, frames, false, true, mend_rings);
    const ValidityStats unguarded = run_validity(deformer, frames, true, true, mend_rings);
    std::vector<double> guarded_ms{median(guarded.ms)}, unguarded_ms{median(unguarded.ms)};
    std::vector<double> guarded_cpu{median(guarded.cpu_ms)}, unguarded_cpu{median(unguarded.cpu_ms)};
    std::vector<double> certificate_ms{guarded.certificate_ms.empty() ? 0.0 : median(guarded.certificate_ms)};
    for (int r = 1; r < runs; ++r) {
      const ValidityStats u = run_validity(deformer, frames, true, false, mend_rings);
      const ValidityStats g = run_validity(deformer, frames, false, false, mend_rings);
      unguarded_ms.push_back(median(u.ms));
      unguarded_cpu.push_back(median(u.cpu_ms));
      guarded_ms.push_back(median(g.ms));
      guarded_cpu.push_back(median(g.cpu_ms));
      if (!g.certificate_ms.empty()) certificate_ms.push_back(median(g.certificate_ms));
    }
    std::printf("CPU per frame (summed over threads), median: guarded %.1f ms, unguarded %.1f ms (ratio %.2f)\n",
                median(guarded_cpu), median(unguarded_cpu), median(guarded_cpu) / median(unguarded_cpu));
    const auto total = [](const std::vector<int>& v) { return std::accumulate(v.begin(), v.end(), 0); };
    std::printf("guarded (default):     median %.1f ms/frame over %d runs (max frame %.1f ms); %d/%d frames valid; "
                "inverted tets summed over frames %d, intersecting pairs %d\n",
                median(guarded_ms), runs, *std::max_element(guarded.ms.begin(), guarded.ms.end()), guarded.valid,
                frame_count, total(guarded.inverted), total(guarded.intersections));
    std::printf("unguarded (--allow-invalid): median %.1f ms/frame over %d runs; %d/%d frames valid; inverted tets "
                "summed over frames %d, intersecting pairs %d\n",
                median(unguarded_ms), runs, unguarded.valid, frame_count, total(unguarded.inverted),
                total(unguarded.intersections));
    std::printf("    exact certificate inside the guard (frames accepted by the step bound): median %.1f ms/frame "
                "over %zu of %d frames\n",
                median(certificate_ms), guarded.certificate_ms.size(), frame_count);
    print_list("inverted tets per frame, guarded", guarded.inverted);
    print_list("inverted tets per frame, unguarded", unguarded.inverted);
    print_list("intersecting boundary pairs per frame, unguarded", unguarded.intersections);
    print_list("sub-steps per frame, guarded", guarded.substeps);
    print_list("guarded iterations per frame", guarded.guarded_iterations);
    std::printf("    ms per frame, guarded (first run):");
    for (double ms : guarded.ms) std::printf(" %.0f", ms);
    std::printf("\n    energy per frame, guarded:");
    for (double e : guarded.energy) std::printf(" %.6g", e);
    std::printf("\n    energy of the paper's solve per frame, guarded:");
    for (double e : guarded.paper_energy) std::printf(" %.6g", e);
    std::printf("\n    guarded frame methods:");
    for (const std::string& m : guarded.methods) std::printf(" %s", m.c_str());
    std::printf("\n");
  }
  if (validity_only) return 0;

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

int main(int argc, char** argv) { return gshell::bench::run_benchmark(argc, argv, kUsage, bench_main); }
