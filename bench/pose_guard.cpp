// bench_pose_guard: the cost of valid pose steps (issue 14). The bowl drag of bench_pose (rigid
// shell at thickness ratio 0.02 of the bounding radius; hold the rim at x < -0.5 R, pull the rim
// at x > 0.7 R by R * (0.8, 0.2, 0.5)) in K steps, guarded (the default: every step certified
// valid, stopping at contact) against unguarded (--allow-invalid), runs interleaved.
//
//   bench_pose_guard [--steps K=20] [--runs R=3] [--solver hierarchical|single]
//
// Prints the shell's size, then per mode: median step time over the drag (median over runs), the
// slowest step (the snap-through), valid steps, steps blocked by contact, guarded steps.
#include "bench_common.h"

#include <gshell/geometry/builtin_mesh.h>
#include <gshell/run/drag_session.h>
#include <gshell/run/pose_run.h>
#include <gshell/shell/generate_shell.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

using namespace gshell;
using gshell::bench::median;

namespace {

struct Stats {
  std::vector<double> step_ms;
  int valid = 0, blocked = 0, guarded = 0, steps = 0;
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
    ++s.steps;
  }
  return s;
}

} // namespace

int main(int argc, char** argv) {
  int steps = 20, runs = 3;
  std::string solver = "hierarchical";
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--steps") && i + 1 < argc) steps = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) runs = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--solver") && i + 1 < argc) solver = argv[++i];
  }
  const TriMesh mesh = make_bowl();
  GenerateOptions generate;
  generate.method = ShellMethod::Rigid;
  generate.thickness = thickness_from_ratio(mesh.V, 0.02);
  generate.count_intersections = false;
  const Shell shell = generate_shell(mesh.V, mesh.F, generate).shell;
  const HandleSet handles = bench::pull_handles(shell, true);
  PoseOptions options;
  options.solver = parse_pose_solver(solver);
  options.steps = steps;
  std::printf("bowl: %d shell vertices, %d tets, eta %.4g; handle vertices %zu + %zu; %d-step drag, %s solver\n",
              2 * shell.num_base_vertices(), 3 * static_cast<int>(shell.F.rows()), shell.thickness,
              handles.handles[0].vertices.size(), handles.handles[1].vertices.size(), steps, solver.c_str());
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
              "%d/%d steps valid, %d blocked by contact, %d by the guarded drag\n",
              median(guarded_median), median(guarded_max), runs, g.valid, g.steps, g.blocked, g.guarded);
  std::printf("unguarded (--allow-invalid): median step %.1f ms, slowest step %.1f ms (medians of %d runs)\n",
              median(unguarded_median), median(unguarded_max), runs);
  std::printf("    guarded step ms:");
  for (double ms : g.step_ms) std::printf(" %.1f", ms);
  std::printf("\n");
  return 0;
}
