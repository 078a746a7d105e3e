// Times the quality measures on an offset shell (top = base + eta * area-weighted vertex normal):
// top self-intersections, top/base intersections and per-vertex thickness. Medians of 5 runs.
// Usage: bench_intersections [MESH ...]   (MESH = builtin spec or mesh file; default
//        builtin:sphere:6 and :7 and models/bunny00.off if present). Thickness ratios 0.01, 0.03.
#include "bench_main.h"
#include <gshell/io/load_mesh.h>
#include <gshell/quality/thickness.h>
#include <gshell/quality/triangle_intersections.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <sys/resource.h>

namespace {

using namespace gshell;

Eigen::MatrixXd offset_top(const TriMesh& mesh, double ratio, double* eta) {
  const Eigen::RowVector3d centre = (mesh.V.colwise().minCoeff() + mesh.V.colwise().maxCoeff()) / 2;
  const double radius = (mesh.V.rowwise() - centre).rowwise().norm().maxCoeff();
  *eta = ratio * radius;
  Eigen::MatrixXd normals = Eigen::MatrixXd::Zero(mesh.V.rows(), 3);
  for (int f = 0; f < mesh.num_faces(); ++f) {
    const Eigen::RowVector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)),
                             c = mesh.V.row(mesh.F(f, 2));
    const Eigen::RowVector3d area_normal = (b - a).cross(c - a); // length = 2 * area
    for (int k = 0; k < 3; ++k) normals.row(mesh.F(f, k)) += area_normal;
  }
  normals.rowwise().normalize();
  return mesh.V + *eta * normals;
}

double cpu_ms() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return (usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) * 1e3 +
         (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec) * 1e-3;
}

struct Timing {
  double wall_ms = 0; // median wall-clock time
  double cpu_ms = 0;  // median CPU time summed over threads (robust to a loaded machine)
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

Timing time_runs(const std::function<void()>& run, int repeats = 5) {
  std::vector<double> wall, cpu;
  for (int r = 0; r < repeats; ++r) {
    const double c0 = cpu_ms();
    const auto t0 = std::chrono::steady_clock::now();
    run();
    wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    cpu.push_back(cpu_ms() - c0);
  }
  return {median(wall), median(cpu)};
}

} // namespace

constexpr const char* kUsage =
    "usage: bench_intersections [MESH ...]\n"
    "(default builtin:sphere:6, builtin:sphere:7 and models/bunny00.off if present; thickness ratios 0.01, 0.03)\n";

int bench_main(int argc, char** argv) {
  std::vector<std::string> inputs(argv + 1, argv + argc);
  if (inputs.empty()) {
    inputs.push_back("builtin:sphere:6");
    inputs.push_back("builtin:sphere:7");
    if (std::filesystem::exists("models/bunny00.off")) inputs.push_back("models/bunny00.off");
  }
  std::printf("times: median of 5, wall ms (cpu ms summed over threads)\n");
  std::printf("%-20s %5s %7s %7s | %6s %16s | %8s %16s | %16s %7s %8s\n", "mesh", "ratio", "verts",
              "faces", "self", "time", "top/base", "time", "thickness time", "min/eta", "mean/eta");
  for (const std::string& input : inputs) {
    const TriMesh base = load_mesh(input);
    for (double ratio : {0.01, 0.03}) {
      double eta = 0;
      const Eigen::MatrixXd top = offset_top(base, ratio, &eta);
      int self = 0, between = 0;
      Eigen::VectorXd thickness;
      const Timing self_t = time_runs([&] { self = count_self_intersections(top, base.F); });
      const Timing between_t =
          time_runs([&] { between = count_intersections_between(top, base.F, base.V, base.F); });
      const Timing thick_t = time_runs([&] { thickness = vertex_thickness(base.V, base.F, top); });
      std::printf("%-20s %5.2f %7d %7d | %6d %7.1f (%6.1f) | %8d %7.1f (%6.1f) | %7.1f (%6.1f) %7.4f %8.4f\n",
                  input.c_str(), ratio, base.num_vertices(), base.num_faces(), self, self_t.wall_ms,
                  self_t.cpu_ms, between, between_t.wall_ms, between_t.cpu_ms, thick_t.wall_ms,
                  thick_t.cpu_ms, thickness.minCoeff() / eta, thickness.mean() / eta);
      std::fflush(stdout);
    }
  }
  return 0;
}

int main(int argc, char** argv) { return gshell::bench::run_benchmark(argc, argv, kUsage, bench_main); }
