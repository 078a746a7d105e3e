// Times validate_mesh and mesh_stats on a real model (default models/bunny00.off) or a builtin.
// Usage: bench_validate_mesh [MESH] [RUNS]; prints sizes and median wall times.
#include "bench_main.h"
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/geometry/mesh_topology.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/read_mesh.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <string>
#include <vector>

namespace {

double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

struct Timing {
  double wall_ms, cpu_ms; ///< medians
};

/// Wall and CPU time medians; CPU time is also given because the machine may be shared.
template <class F>
Timing median_ms(int runs, F&& f) {
  std::vector<double> wall, cpu;
  for (int i = 0; i < runs; ++i) {
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = thread_cpu_ms();
    f();
    cpu.push_back(thread_cpu_ms() - cpu_start);
    wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  }
  std::sort(wall.begin(), wall.end());
  std::sort(cpu.begin(), cpu.end());
  return {wall[wall.size() / 2], cpu[cpu.size() / 2]};
}

} // namespace

constexpr const char* kUsage =
    "usage: bench_validate_mesh [MESH=models/bunny00.off] [RUNS=7]\n";

int bench_main(int argc, char** argv) {
  std::string input = argc > 1 ? argv[1] : "models/bunny00.off";
  const int runs = argc > 2 ? std::max(1, std::atoi(argv[2])) : 7;
  // Only the default model falls back (a fresh checkout before scripts/fetch-models); a path
  // given on the command line is read as given (a missing one is an error).
  if (argc <= 1 && !std::filesystem::exists(input)) {
    std::printf("%s not found (run scripts/fetch-models); using builtin:sphere:6\n", input.c_str());
    input = "builtin:sphere:6";
  }
  const gshell::TriMesh mesh = gshell::is_builtin_spec(input) ? gshell::make_builtin(input) : gshell::read_mesh(input);
  std::size_t problems = 0;
  const Timing validate = median_ms(runs, [&] { problems = gshell::validate_mesh(mesh).size(); });
  int edges = 0;
  const Timing stats = median_ms(runs, [&] { edges = gshell::mesh_stats(mesh).edges; });
  std::printf("%s: %d vertices, %d faces, %d edges, %zu problems\n", input.c_str(), mesh.num_vertices(),
              mesh.num_faces(), edges, problems);
  std::printf("validate_mesh: median %.2f ms wall, %.2f ms CPU over %d runs\n", validate.wall_ms, validate.cpu_ms, runs);
  std::printf("mesh_stats:    median %.2f ms wall, %.2f ms CPU over %d runs\n", stats.wall_ms, stats.cpu_ms, runs);
  return 0;
}

int main(int argc, char** argv) { return gshell::bench::run_benchmark(argc, argv, kUsage, bench_main); }
