// bench_pose_guard: the cost of valid pose steps (issue 14). The bowl drag of bench_pose (rigid
// shell at thickness ratio 0.02 of the bounding radius; hold the rim at x < -0.5 R, pull the rim
// at x > 0.7 R by R * (0.8, 0.2, 0.5)) in K steps, guarded (the default: every step certified
// valid, stopping at contact) against unguarded (--allow-invalid), runs interleaved.
//
//   bench_pose_guard [--steps K=20] [--runs R=3] [--solver hierarchical|single] [--goal]
//   bench_pose_guard --mend SHELL_DIR HANDLES.json [--steps K=20] [--runs R=3] [--solver S]
//
// Prints the shell's size, then per mode: median step time over the drag (median over runs), the
// slowest step (the snap-through), valid steps, steps blocked by contact, guarded steps. Each step
// is solved to the pose tolerance (1e-6), as `gshell pose` does.
//
// --goal: bench_pose's drag protocol and stopping rule instead, so that the figures compare with
// its 10 ms goal: reference minima E*_k of every step (single level + Anderson, relative change <
// 1e-10); step k starts from the reference states of steps k-1 and k-2 continued
// (predict_start) and runs until E <= 1.001 E*_k. The unguarded step is timed so (as bench_pose
// does); the guarded step is PoseSolver::solve_valid from the reference state of step k-1 with
// the same number of iterations (tolerance 0), i.e. the same solve plus the guard (tet step bound
// and certificate, or the guarded drag when those refuse the solve). Both solvers, --runs runs.
// Also printed: the largest vertex motion per drag step (against the mean base edge and the
// thickness), the CPU time of the median step (all threads, steadier than wall time on a loaded
// machine) and the certificate's median wall time inside the guarded step.
//
// --mend: a shell folder (gshell generate's) posed by a handle file, guarded, with refused steps
// mended in place (GuardOptions::mend_rings, the default) against dragged from the last pose
// (mend_rings = -1), runs interleaved: per step the method, median wall seconds, guarded
// iterations and energy of each, and the energies' relative difference.
#include "bench_main.h"
#include "bench_common.h"

#include <gshell/deform/pose.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/run/drag_session.h>
#include <gshell/run/pose_run.h>
#include <gshell/run/shell_folder.h>
#include <gshell/deform/handles.h>
#include <gshell/shell/generate_shell.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <time.h>

using namespace gshell;
using gshell::bench::median;

namespace {

struct Stats {
  std::vector<double> step_ms;
  int valid = 0, blocked = 0, guarded = 0, mended = 0, steps = 0;
};

Stats run(const Shell& shell, const HandleSet& handles, PoseOptions options, bool allow_invalid) {
  options.allow_invalid = allow_invalid;
  const PoseResult r = run_pose(shell, handles, options);
  Stats s;
  for (const PoseStepReport& step : r.steps) {
    s.step_ms.push_back(1e3 * step.seconds);
    s.valid += step.valid ? 1 : 0;
    s.blocked += step.blocked_by_contact ? 1 : 0;
    s.guarded += step.method == FrameMethod::Guarded ? 1 : 0;
    s.mended += step.method == FrameMethod::Mended ? 1 : 0;
    ++s.steps;
  }
  return s;
}

/// Thrown from the progress callback at the first iteration that reaches the goal.
struct GoalReached {
  int iteration;
};

/// Iterations until E <= goal from X0 (cap if not reached).
int iterations_to_goal(PoseSolver& solver, const Eigen::MatrixXd& X0, const Eigen::MatrixXd& P, double goal, int cap) {
  Eigen::MatrixXd X = X0;
  SolveOptions options;
  options.max_iterations = cap;
  options.tolerance = 0;
  options.progress = [&](int it, double e, double) {
    if (e <= goal) throw GoalReached{it};
  };
  try {
    return solver.solve(X, P, options).iterations;
  } catch (const GoalReached& g) {
    return g.iteration;
  }
}

/// CPU seconds of the whole process (all threads): steadier than wall time on a loaded machine.
double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// bench_pose's drag, unguarded and guarded (see --goal above), for one solver kind.
void goal_drag(const Shell& shell, const HandleSet& handles, PoseSolverKind kind, int steps, int runs,
               const std::vector<Eigen::MatrixXd>& Xref, const std::vector<double>& Eref) {
  constexpr int kCap = 600;
  std::vector<double> plain_median, guarded_median, guarded_max, plain_cpu_median, guarded_cpu_median;
  std::vector<double> plain_ms, guarded_ms, iterations, plain_cpu, guarded_cpu, certificate_ms;
  int valid = 0, bounded = 0, missed = 0;
  for (int r = 0; r < runs; ++r) {
    PoseSolver counter(shell, handles, kind), plain(shell, handles, kind), guarded(shell, handles, kind);
    plain_ms.clear();
    guarded_ms.clear();
    plain_cpu.clear();
    guarded_cpu.clear();
    certificate_ms.clear();
    iterations.clear();
    valid = bounded = missed = 0;
    for (int k = 1; k <= steps; ++k) {
      const double f = static_cast<double>(k) / steps;
      const Eigen::MatrixXd P = counter.targets(f);
      const Eigen::MatrixXd X0 =
          k >= 2 ? counter.predict_start(Xref[k - 2], (k - 2.0) / steps, Xref[k - 1], (k - 1.0) / steps, f) : Xref[k - 1];
      const int count = iterations_to_goal(counter, X0, P, 1.001 * Eref[k], kCap);
      missed += count >= kCap ? 1 : 0;
      iterations.push_back(count);
      SolveOptions options;
      options.max_iterations = count;
      options.tolerance = 0;
      auto t0 = std::chrono::steady_clock::now();
      double c0 = cpu_seconds();
      Eigen::MatrixXd X = k >= 2 ? plain.predict_start(Xref[k - 2], (k - 2.0) / steps, Xref[k - 1], (k - 1.0) / steps, f)
                                 : Xref[k - 1];
      plain.solve(X, P, options);
      plain_ms.push_back(1e3 * seconds_since(t0));
      plain_cpu.push_back(1e3 * (cpu_seconds() - c0));
      t0 = std::chrono::steady_clock::now();
      c0 = cpu_seconds();
      Eigen::MatrixXd Y = k >= 2 ? guarded.predict_start(Xref[k - 2], (k - 2.0) / steps, Xref[k - 1], (k - 1.0) / steps, f)
                                 : Xref[k - 1];
      ValidStep step;
      guarded.solve_valid(Xref[k - 1], Y, P, options, frame_guard_options(), &step);
      guarded_ms.push_back(1e3 * seconds_since(t0));
      guarded_cpu.push_back(1e3 * (cpu_seconds() - c0));
      certificate_ms.push_back(1e3 * step.certificate.seconds);
      valid += step.valid ? 1 : 0;
      bounded += step.method == FrameMethod::Bounded ? 1 : 0;
    }
    plain_median.push_back(median(plain_ms));
    guarded_median.push_back(median(guarded_ms));
    plain_cpu_median.push_back(median(plain_cpu));
    guarded_cpu_median.push_back(median(guarded_cpu));
    guarded_max.push_back(*std::max_element(guarded_ms.begin(), guarded_ms.end()));
  }
  const auto slowest = std::max_element(guarded_ms.begin(), guarded_ms.end()) - guarded_ms.begin();
  std::printf("[%s] to E <= 1.001 E*_k (bench_pose's rule), %d steps, medians of %d runs:\n"
              "  unguarded: median step %.2f ms\n"
              "  guarded:   median step %.2f ms, slowest step %.2f ms (step %d, the snap-through: %.2f ms unguarded, %.0f iterations); "
              "%d/%d steps valid, %d taken as solved (bounded), %d not reaching the goal in %d iterations\n",
              kind == PoseSolverKind::Single ? "single" : "hierarchical", steps, runs, median(plain_median),
              median(guarded_median), median(guarded_max), static_cast<int>(slowest) + 1, plain_ms[slowest],
              iterations[slowest], valid, steps, bounded, missed, kCap);
  std::printf("  CPU (all threads): median step %.2f ms unguarded, %.2f ms guarded (%.2fx)\n", median(plain_cpu_median),
              median(guarded_cpu_median), median(guarded_cpu_median) / median(plain_cpu_median));
  std::printf("  certificate inside the guarded step (wall, last run): median %.2f ms\n", median(certificate_ms));
  std::printf("  iterations per step:");
  for (double i : iterations) std::printf(" %.0f", i);
  std::printf("\n  guarded step ms:");
  for (double ms : guarded_ms) std::printf(" %.1f", ms);
  std::printf("\n  unguarded step ms:");
  for (double ms : plain_ms) std::printf(" %.1f", ms);
  std::printf("\n");
}

/// Reference minima of every drag step: single level + Anderson(5) to relative change < 1e-10.
void references(const Shell& shell, const HandleSet& handles, int steps, std::vector<Eigen::MatrixXd>& Xref,
                std::vector<double>& Eref) {
  PoseSolver reference = bench::reference_pose_solver(shell, handles);
  SolveOptions options;
  options.max_iterations = 3000;
  options.tolerance = 1e-10;
  Xref.assign(steps + 1, reference.rest_vertices());
  Eref.assign(steps + 1, 0.0);
  for (int k = 1; k <= steps; ++k) {
    Xref[k] = Xref[k - 1];
    Eref[k] = reference.solve(Xref[k], static_cast<double>(k) / steps, options).energy.back();
  }
}

} // namespace

constexpr const char* kUsage =
    "usage: bench_pose_guard [--steps K=20] [--runs R=3] [--solver hierarchical|single] [--goal]\n"
    "       bench_pose_guard --mend SHELL_DIR HANDLES.json [--steps K=20] [--runs R=3] [--solver S]\n";

// Refused steps mended in place against dragged, on a shell folder and handle file.
int mend_against_drag(const std::string& dir, const std::string& handle_file, PoseOptions options, int runs) {
  const Shell shell = read_shell_folder(dir).shell;
  const HandleSet handles = read_handles(handle_file, shell);
  std::printf("%s: %d shell vertices, %d tets; %s; %d steps\n", dir.c_str(), 2 * shell.num_base_vertices(),
              3 * static_cast<int>(shell.F.rows()), handle_file.c_str(), options.steps);
  struct Mode {
    const char* name;
    int rings;
    std::vector<std::vector<double>> seconds; // per step, per run
    PoseResult last;
  };
  Mode modes[2] = {{"mended", options.guard.mend_rings, {}, {}}, {"dragged", -1, {}, {}}};
  for (int r = 0; r < runs; ++r)
    for (Mode& m : modes) {
      options.guard.mend_rings = m.rings;
      m.last = run_pose(shell, handles, options);
      m.seconds.resize(m.last.steps.size());
      for (std::size_t k = 0; k < m.last.steps.size(); ++k) m.seconds[k].push_back(m.last.steps[k].seconds);
    }
  double total[2] = {0, 0};
  for (std::size_t k = 0; k < modes[0].last.steps.size() && k < modes[1].last.steps.size(); ++k) {
    std::printf("step %zu:", k + 1);
    for (int i = 0; i < 2; ++i) {
      const PoseStepReport& s = modes[i].last.steps[k];
      total[i] += median(modes[i].seconds[k]);
      std::printf("  %s: %s%s %.3f s, %d guarded it, E %.9g;", modes[i].name, frame_method_name(s.method),
                  s.valid ? "" : " INVALID", median(modes[i].seconds[k]), s.guarded_iterations, s.energy);
    }
    const double e0 = modes[0].last.steps[k].energy, e1 = modes[1].last.steps[k].energy;
    std::printf("  E mended / dragged - 1 = %+.2e\n", e0 / e1 - 1);
  }
  std::printf("total (sum of step medians over %d runs): mended %.2f s, dragged %.2f s\n", runs, total[0], total[1]);
  return 0;
}

int bench_main(int argc, char** argv) {
  int steps = 20, runs = 3;
  std::string solver = "hierarchical";
  bool goal = false;
  std::string mend_dir, mend_handles;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--steps") && i + 1 < argc) steps = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) runs = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--solver") && i + 1 < argc) solver = argv[++i];
    else if (!std::strcmp(argv[i], "--goal")) goal = true;
    else if (!std::strcmp(argv[i], "--mend") && i + 2 < argc) {
      mend_dir = argv[++i];
      mend_handles = argv[++i];
    }
    else {
      std::fprintf(stderr, "bench_pose_guard: unknown argument %s\n%s", argv[i], kUsage);
      return 1;
    }
  }
  if (!mend_dir.empty()) {
    PoseOptions options;
    options.solver = parse_pose_solver(solver);
    options.steps = steps;
    return mend_against_drag(mend_dir, mend_handles, options, runs);
  }
  const TriMesh mesh = make_bowl();
  GenerateOptions generate;
  generate.method = ShellMethod::Rigid;
  generate.thickness = thickness_from_ratio(mesh.V, mesh.F, 0.02);
  generate.count_intersections = false;
  const Shell shell = generate_shell(mesh.V, mesh.F, generate).shell;
  const HandleSet handles = bench::pull_handles(shell, true);
  PoseOptions options;
  options.solver = parse_pose_solver(solver);
  options.steps = steps;
  std::printf("bowl: %d shell vertices, %d tets, eta %.4g; handle vertices %zu + %zu; %d-step drag, %s solver\n",
              2 * shell.num_base_vertices(), 3 * static_cast<int>(shell.F.rows()), shell.thickness,
              handles.handles[0].vertices.size(), handles.handles[1].vertices.size(), steps, solver.c_str());
  if (goal) {
    std::vector<Eigen::MatrixXd> Xref;
    std::vector<double> Eref;
    references(shell, handles, steps, Xref, Eref);
    // How far a drag step moves the shell, against its edges and thickness: what a cache of
    // candidate pairs with boxes grown by one step's motion would have to cover.
    double edge = 0;
    for (int f = 0; f < shell.F.rows(); ++f)
      for (int k = 0; k < 3; ++k) edge += (shell.base.row(shell.F(f, k)) - shell.base.row(shell.F(f, (k + 1) % 3))).norm();
    edge /= 3.0 * static_cast<double>(shell.F.rows());
    std::vector<double> motion;
    for (int k = 1; k <= steps; ++k) motion.push_back((Xref[k] - Xref[k - 1]).rowwise().norm().maxCoeff());
    std::printf("largest vertex motion per step: median %.3g (%.2f mean base edges, %.2f thicknesses), max %.3g\n",
                median(motion), median(motion) / edge, median(motion) / shell.thickness,
                *std::max_element(motion.begin(), motion.end()));
    for (PoseSolverKind kind : {PoseSolverKind::Single, PoseSolverKind::Hierarchical})
      goal_drag(shell, handles, kind, steps, runs, Xref, Eref);
    return 0;
  }
  std::vector<double> guarded_median, unguarded_median, guarded_max, unguarded_max;
  Stats g, u;
  for (int r = 0; r < runs; ++r) {
    u = run(shell, handles, options, true);
    g = run(shell, handles, options, false);
    unguarded_median.push_back(median(u.step_ms));
    guarded_median.push_back(median(g.step_ms));
    unguarded_max.push_back(*std::max_element(u.step_ms.begin(), u.step_ms.end()));
    guarded_max.push_back(*std::max_element(g.step_ms.begin(), g.step_ms.end()));
  }
  std::printf("guarded (default):           median step %.1f ms, slowest step %.1f ms (medians of %d runs); "
              "%d/%d steps valid, %d blocked by contact, %d by the guarded drag, %d mended\n",
              median(guarded_median), median(guarded_max), runs, g.valid, g.steps, g.blocked, g.guarded, g.mended);
  std::printf("unguarded (--allow-invalid): median step %.1f ms, slowest step %.1f ms (medians of %d runs)\n",
              median(unguarded_median), median(unguarded_max), runs);
  std::printf("    guarded step ms:");
  for (double ms : g.step_ms) std::printf(" %.1f", ms);
  std::printf("\n");
  return 0;
}

int main(int argc, char** argv) { return gshell::bench::run_benchmark(argc, argv, kUsage, bench_main); }
