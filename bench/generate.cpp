// bench_generate [MESH] (default models/bunny00.off; get it with scripts/fetch-models):
// times of the shell generation pieces on all cores (medians of 5) and every report figure for
// the offset and rigid methods at thickness ratios 0.01 and 0.03.
#include "bench_main.h"
#include <gshell/io/load_mesh.h>
#include <gshell/shell/generate_report.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/polar_decomposition.h>
#include <gshell/solver/shell_solver.h>
#include <gshell/solver/simd_level.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <ctime>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <numeric>
#include <random>
#include <vector>

using namespace gshell;
using Clock = std::chrono::steady_clock;

namespace {

double process_cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Wall time of f; also adds the CPU time of all threads to *cpu, because the benchmark machine
// is shared and wall times alone mix our work with other processes'.
double seconds(const std::function<void()>& f, double* cpu = nullptr) {
  const double c0 = process_cpu_seconds();
  const auto t0 = Clock::now();
  f();
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  if (cpu) *cpu = process_cpu_seconds() - c0;
  return wall;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double median_of(int runs, const std::function<double()>& f) {
  std::vector<double> v;
  for (int i = 0; i < runs; ++i) v.push_back(f());
  return median(v);
}

// Deformation gradients of the shell's tets at positions X (what a local step sees).
std::vector<Eigen::Matrix3d> shell_gradients(const RestTets& rest, const Eigen::MatrixXd& X) {
  std::vector<Eigen::Matrix3d> F(rest.size());
  tbb::parallel_for(0, rest.size(), [&](int t) {
    Eigen::Matrix3d D;
    for (int j = 0; j < 3; ++j) D.col(j) = (X.row(rest.T(t, j + 1)) - X.row(rest.T(t, 0))).transpose();
    F[t] = D * rest.dm_inv(t);
  });
  return F;
}

double polar_rate(const std::vector<Eigen::Matrix3d>& F, double* per_cpu_second = nullptr) {
  // Written once before timing: first-touch page faults on the output are not decompositions.
  std::vector<Eigen::Matrix3d> R(F.size(), Eigen::Matrix3d::Zero());
  double cpu = 0;
  const double s = seconds([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, F.size(), 4096),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        closest_rotations(F.data() + r.begin(), R.data() + r.begin(), r.size());
                      });
  }, &cpu);
  if (per_cpu_second) *per_cpu_second = static_cast<double>(F.size()) / cpu;
  return static_cast<double>(F.size()) / s;
}

} // namespace

constexpr const char* kUsage =
    "usage: bench_generate [MESH=models/bunny00.off]\n"
    "(times of the generation pieces, medians of 5, and the report figures of offset and rigid at ratios 0.01 and 0.03)\n";

int bench_main(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : "models/bunny00.off";
  if (path.rfind("builtin:", 0) != 0 && !std::filesystem::exists(path)) {
    std::cerr << "bench_generate: " << path << " not found (run scripts/fetch-models, or pass a mesh)\n";
    return 1;
  }
  const TriMesh mesh = load_mesh(path);
  const int n = mesh.num_vertices(), m = mesh.num_faces();
  std::printf("mesh %s: %d vertices, %d faces, %d tets; %d threads\n", path.c_str(), n, m, 3 * m,
              tbb::this_task_arena::max_concurrency());
  std::printf("SIMD kernels: %s (this CPU supports up to %s; GSHELL_SIMD=generic|avx2|avx512 caps it)\n",
              to_string(simd_level()).c_str(), to_string(simd_level_supported()).c_str());
  if (FILE* f = std::fopen("/proc/loadavg", "r")) { // the machine may be shared: say how busy it was
    char line[128] = {0};
    if (std::fgets(line, sizeof line, f)) std::printf("load average at start: %s", line);
    std::fclose(f);
  }
  const int runs = 5;

  for (double ratio : {0.01, 0.03}) {
    const double eta = thickness_from_ratio(mesh.V, mesh.F, ratio);
    std::printf("\n== ratio %.2f (eta %.6g)\n", ratio, eta);
    const RestTets rest = prism_rest_tets(mesh.F, n, normal_prisms(mesh.V, mesh.F, eta));
    Eigen::MatrixXd X0(2 * n, 3);
    X0 << mesh.V, offset_top(mesh.V, mesh.F, eta);
    std::vector<int> base(n);
    std::iota(base.begin(), base.end(), 0);

    std::vector<double> factor_times, factor_cpu;
    for (int i = 0; i < runs; ++i) {
      double cpu = 0, wall = 0;
      seconds([&] { wall = ShellSolver(rest, 2 * n, base).factor_seconds(); }, &cpu);
      factor_times.push_back(wall);
      factor_cpu.push_back(cpu);
    }
    std::printf("assemble + factor: %.3f s wall, %.3f s CPU\n", median(factor_times), median(factor_cpu));

    const ShellSolver solver(rest, 2 * n, base);
    SolveOptions ten;
    ten.max_iterations = 10;
    ten.tolerance = 0;
    Eigen::MatrixXd X10 = X0;
    solver.solve(X10, ten);
    std::vector<double> it_wall, it_cpu, it_local, it_global;
    for (int i = 0; i < runs; ++i) {
      Eigen::MatrixXd X = X0;
      SolveResult r;
      double cpu = 0;
      seconds([&] { r = solver.solve(X, ten); }, &cpu);
      it_wall.push_back(r.seconds / 10);
      it_cpu.push_back(cpu / 10);
      it_local.push_back(r.local_seconds / 11); // 11 local steps: the start energy's too
      it_global.push_back(r.global_seconds / 10);
    }
    std::printf("one local/global iteration: %.1f ms wall (local step %.1f ms, global step %.1f ms), %.1f ms CPU "
                "over all threads; median of %d solves of 10 iterations\n",
                1e3 * median(it_wall), 1e3 * median(it_local), 1e3 * median(it_global), 1e3 * median(it_cpu), runs);
    std::printf("energy evaluation alone (one local step without RHS): %.1f ms\n",
                1e3 * median_of(runs, [&] { return seconds([&] { solver.energy(X10); }); }));

    // Polar decompositions of the real gradients after 10 iterations (replicated to 2M) and of
    // random perturbations of the identity.
    std::vector<Eigen::Matrix3d> F = shell_gradients(rest, X10);
    while (F.size() < 2000000) F.insert(F.end(), F.begin(), F.begin() + std::min<std::size_t>(F.size(), 2000000 - F.size()));
    std::mt19937 rng(1);
    std::normal_distribution<double> g(0, 0.1);
    std::vector<Eigen::Matrix3d> Frand(2000000);
    for (auto& M : Frand) {
      M.setIdentity();
      for (int k = 0; k < 9; ++k) M(k / 3, k % 3) += g(rng);
    }
    std::vector<double> pr, pc, rr, rc;
    for (int i = 0; i < runs; ++i) {
      double c = 0;
      pr.push_back(polar_rate(F, &c));
      pc.push_back(c);
      rr.push_back(polar_rate(Frand, &c));
      rc.push_back(c);
    }
    std::printf("polar decompositions, all threads: %.1f M/s wall (%.1f M per CPU-second) on the shell's gradients; "
                "%.1f M/s wall (%.1f M per CPU-second) on I + N(0, 0.1^2) entries\n",
                median(pr) / 1e6, median(pc) / 1e6, median(rr) / 1e6, median(rc) / 1e6);

    GenerateOptions options;
    options.thickness = eta;
    options.solve = ten;
    options.count_intersections = false;
    std::vector<double> gen_wall, gen_cpu;
    for (int i = 0; i < runs; ++i) {
      double cpu = 0;
      gen_wall.push_back(seconds([&] { generate_shell(mesh.V, mesh.F, options); }, &cpu));
      gen_cpu.push_back(cpu);
    }
    std::printf("generate end to end, 10 iterations, no file I/O or intersection counts: %.3f s wall, %.3f s CPU\n",
                median(gen_wall), median(gen_cpu));

    for (ShellMethod method : {ShellMethod::Offset, ShellMethod::Rigid}) {
      GenerateOptions o;
      o.method = method;
      o.thickness = eta;
      o.count_intersections = true;
      const GenerateResult r = generate_shell(mesh.V, mesh.F, o);
      nlohmann::json report = generate_report(r, path, ratio);
      if (report["energy"].size() > 6) { // keep the screen short: first 3 and last 3
        const nlohmann::json e = report["energy"];
        const std::size_t k = e.size();
        report["energy"] = nlohmann::json::array({e[0], e[1], e[2], "...", e[k - 3], e[k - 2], e[k - 1]});
      }
      std::printf("-- %s (default options: <= 50 iterations, tolerance 1e-5)\n%s%s\n", to_string(method).c_str(),
                  generate_summary(r, path).c_str(), report.dump().c_str());
    }
  }
  return 0;
}

int main(int argc, char** argv) { return gshell::bench::run_benchmark(argc, argv, kUsage, bench_main); }
