// Curvature timing and the groove figures of the curvature-sensitive method (issue 4, paper Fig. 1).
// Usage: bench_curvature [MESH=models/bunny00.off] [RUNS=5] [--no-sweep | --timing-only]
// Prints: face/vertex curvature times; for thickness ratios 0.03 and 0.05 and methods rigid and
// curvature the per-vertex thickness / eta (min, 1st percentile, and the same over the 5% of
// vertices with the largest |kappa_1|), stretch against the normal prisms (and the own prisms),
// inverted tets, intersections, clamp counts and generation time; then a sweep of the clamps.
#include "bench_main.h"
#include <gshell/geometry/curvature.h>
#include <gshell/io/read_mesh.h>
#include <gshell/shell/generate_shell.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <functional>
#include <string>
#include <vector>

using namespace gshell;

namespace {

double seconds_of(const std::function<void()>& fn) {
  const auto t0 = std::chrono::steady_clock::now();
  fn();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// CPU seconds of the whole process (all threads): the cost without other processes' load.
double cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

/// Nearest-rank percentile (p in [0,1]; 0 = minimum) of the selected entries.
double percentile(const Eigen::VectorXd& values, double p, const std::vector<int>& select) {
  std::vector<double> v;
  for (int i : select) v.push_back(values(i));
  const std::size_t rank = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(p * v.size()))) - 1;
  std::nth_element(v.begin(), v.begin() + rank, v.end());
  return v[rank];
}

struct Run {
  GenerateResult result;
  CurvaturePrismStats prisms;
  StretchStats own;
  double seconds = 0;
};

Run generate(const TriMesh& mesh, ShellMethod method, double eta, double s_min, double s_max, bool intersections) {
  GenerateOptions options;
  options.method = method;
  options.thickness = eta;
  options.s_min = s_min;
  options.s_max = s_max;
  options.count_intersections = intersections;
  Run run;
  run.seconds = seconds_of([&] {
    run.result = generate_shell(mesh.V, mesh.F, options);
    run.own = run.result.curvature ? run.result.curvature->own_stretch : run.result.metrics.stretch;
    if (run.result.curvature) run.prisms = run.result.curvature->prisms;
  });
  return run;
}

void print_header() {
  std::printf("%-5s %-9s %-9s %6s %6s %6s %6s %6s | %7s %7s %6s %6s %4s %5s %5s | %6s %5s %7s | %4s %6s\n", "ratio",
              "method", "clamps", "min", "p1", "r.min", "r.p1", "r.med", "str.vol", "str.p99", "str.mx", "mean",
              "inv", "selfX", "baseX", "clamp", "limit", "own.vol", "iter", "time");
}

void print_row(double ratio, const char* method, double s_min, double s_max, const Run& run,
               const std::vector<int>& all, const std::vector<int>& ridge, double seconds) {
  const ShellMetrics& m = run.result.metrics;
  const Eigen::VectorXd& t = m.vertex_thickness; // relative to eta
  char clamps[32];
  std::snprintf(clamps, sizeof clamps, "%.2g..%.2g", s_min, s_max);
  std::printf("%-5.2f %-9s %-9s %6.3f %6.3f %6.3f %6.3f %6.3f | %7.4f %7.4f %6.3f %6.4f %4d %5d %5d | %6d %5d %7.4f | "
              "%4d %6.2f\n",
              ratio, method, clamps, percentile(t, 0, all), percentile(t, 0.01, all), percentile(t, 0, ridge),
              percentile(t, 0.01, ridge), percentile(t, 0.5, ridge), m.stretch.volume_mean, m.stretch.p99,
              m.stretch.max, m.stretch.mean, m.certificate.inverted_tets, m.certificate.top_self_intersections,
              m.certificate.top_base_intersections, run.prisms.clamped, run.prisms.limited, run.own.volume_mean,
              run.result.solve.iterations, seconds);
}

} // namespace

constexpr const char* kUsage =
    "usage: bench_curvature [MESH=models/bunny00.off] [RUNS=5] [--no-sweep | --timing-only]\n";

int bench_main(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : "models/bunny00.off";
  const int runs = argc > 2 ? std::max(1, std::atoi(argv[2])) : 5;
  const std::string mode = argc > 3 ? argv[3] : "";
  const bool sweep = mode.empty(), shells = mode != "--timing-only";
  TriMesh mesh;
  try {
    mesh = read_mesh(path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_curvature: %s (run scripts/fetch-models)\n", e.what());
    return 1;
  }
  const int n = mesh.num_vertices();
  std::printf("%s: %d vertices, %d faces; times are medians of %d runs\n", path.c_str(), n, mesh.num_faces(), runs);

  std::vector<double> tf, tv, cf, cv;
  FaceCurvature fc;
  VertexCurvature vc;
  for (int r = 0; r < runs; ++r) {
    double c0 = cpu_seconds();
    tf.push_back(seconds_of([&] { fc = face_curvature(mesh.V, mesh.F); }));
    double c1 = cpu_seconds();
    tv.push_back(seconds_of([&] { vc = vertex_curvature(mesh.V, mesh.F); }));
    double c2 = cpu_seconds();
    cf.push_back(c1 - c0);
    cv.push_back(c2 - c1);
  }
  std::printf("face_curvature   (2-ring) %.4f s wall, %.4f s CPU (all threads)\n", median(tf), median(cf));
  std::printf("vertex_curvature (2-ring) %.4f s wall, %.4f s CPU (all threads)\n", median(tv), median(cv));
  if (!shells) return 0;

  // The ridges of Fig. 1: the 5% of vertices with the largest |kappa_1| (vertex curvature).
  std::vector<int> all(n);
  for (int i = 0; i < n; ++i) all[i] = i;
  std::vector<int> order = all;
  std::sort(order.begin(), order.end(), [&](int a, int b) { return std::abs(vc.k1(a)) > std::abs(vc.k1(b)); });
  const std::vector<int> ridge(order.begin(), order.begin() + std::max(1, n / 20));
  const double radius = thickness_from_ratio(mesh.V, mesh.F, 1.0);
  std::printf("ridge set: %zu vertices with |k1| >= %.4g (radius of curvature <= %.4g; bounding radius %.4g)\n",
              ridge.size(), std::abs(vc.k1(ridge.back())), 1 / std::abs(vc.k1(ridge.back())), radius);
  std::printf("thickness columns are per-vertex thickness / eta: min, p1 = 1st percentile, r.* = over the ridge "
              "set;\nstretch against the normal prisms (own.vol: against the method's own ideal prisms)\n\n");

  print_header();
  for (double ratio : {0.03, 0.05}) {
    const double eta = ratio * radius;
    for (ShellMethod method : {ShellMethod::Rigid, ShellMethod::Curvature}) {
      std::vector<double> times;
      Run run;
      for (int r = 0; r < runs; ++r) {
        run = generate(mesh, method, eta, kDefaultCurvatureSMin, kDefaultCurvatureSMax, true);
        times.push_back(run.seconds);
      }
      print_row(ratio, to_string(method).c_str(), kDefaultCurvatureSMin, kDefaultCurvatureSMax, run, all, ridge,
                median(times));
    }
  }
  if (!sweep) return 0;
  std::printf("\nclamp sweep (curvature method, one run each; time includes intersection counts)\n");
  print_header();
  for (double ratio : {0.03, 0.05})
    for (auto [s_min, s_max] : {std::pair{1.0, 1.0}, {0.67, 1.5}, {0.5, 2.0}, {0.33, 3.0}, {0.25, 4.0}}) {
      const Run run = generate(mesh, ShellMethod::Curvature, ratio * radius, s_min, s_max, true);
      print_row(ratio, "curvature", s_min, s_max, run, all, ridge, run.seconds);
    }
  return 0;
}

int main(int argc, char** argv) { return gshell::bench::run_benchmark(argc, argv, kUsage, bench_main); }
