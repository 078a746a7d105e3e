// Curvature timing and the groove figures of the curvature-sensitive method (issue 4).
// Usage: bench_curvature [MESH=models/bunny00.off] [RUNS=5]
#include <gshell/geometry/curvature.h>
#include <gshell/io/read_mesh.h>
#include <gshell/quality/stretch.h>
#include <gshell/quality/thickness.h>
#include <gshell/shell/curvature_prisms.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/rest_tets.h>
#include <gshell/solver/shell_solver.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
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

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

/// Nearest-rank percentile of the selected entries (all when `select` is empty).
double percentile(const Eigen::VectorXd& values, double p, const std::vector<int>& select = {}) {
  std::vector<double> v;
  if (select.empty()) v.assign(values.data(), values.data() + values.size());
  else for (int i : select) v.push_back(values(i));
  const std::size_t rank = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(p * v.size()))) - 1;
  std::nth_element(v.begin(), v.begin() + rank, v.end());
  return v[rank];
}

double bounding_sphere_radius(const Eigen::MatrixXd& V) {
  const Eigen::RowVector3d centre = 0.5 * (V.colwise().minCoeff() + V.colwise().maxCoeff());
  return (V.rowwise() - centre).rowwise().norm().maxCoeff();
}

struct Shell {
  Eigen::MatrixXd X; ///< 2n x 3: base rows, then top rows
  int clamped = 0;
  double seconds = 0;
  int iterations = 0;
};

/// Generation as in DESIGN.md: fixed base, offset start, local/global on the top vertices.
Shell generate(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta, bool curvature) {
  Shell s;
  const int n = static_cast<int>(V.rows());
  s.seconds = seconds_of([&] {
    const PrismCorners P = curvature ? curvature_prisms(V, F, eta, kDefaultCurvatureSMin,
                                                        kDefaultCurvatureSMax, &s.clamped)
                                     : normal_prisms(V, F, eta);
    const Eigen::MatrixXi C = prism_tet_corners(F);
    Eigen::MatrixXd corners(4 * C.rows(), 3);
    for (Eigen::Index t = 0; t < C.rows(); ++t)
      for (int k = 0; k < 4; ++k) corners.row(4 * t + k) = P.row(6 * (t / 3) + C(t, k));
    const RestTets rest = rest_tets_from_corners(build_prism_tets(F, n), corners);
    std::vector<int> fixed(n);
    for (int i = 0; i < n; ++i) fixed[i] = i;
    const ShellSolver solver(rest, 2 * n, fixed);
    s.X.resize(2 * n, 3);
    s.X << V, offset_top(V, F, eta);
    SolveOptions options;
    const SolveResult r = solver.solve(s.X, options);
    s.iterations = r.iterations;
  });
  return s;
}

RestTets rest_of(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const PrismCorners& P) {
  const Eigen::MatrixXi C = prism_tet_corners(F);
  Eigen::MatrixXd corners(4 * C.rows(), 3);
  for (Eigen::Index t = 0; t < C.rows(); ++t)
    for (int k = 0; k < 4; ++k) corners.row(4 * t + k) = P.row(6 * (t / 3) + C(t, k));
  return rest_tets_from_corners(build_prism_tets(F, static_cast<int>(V.rows())), corners);
}

} // namespace

int main(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : "models/bunny00.off";
  const int runs = argc > 2 ? std::atoi(argv[2]) : 5;
  TriMesh mesh;
  try {
    mesh = read_mesh(path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_curvature: %s (run scripts/fetch-models)\n", e.what());
    return 1;
  }
  const Eigen::MatrixXd& V = mesh.V;
  const Eigen::MatrixXi& F = mesh.F;
  const int n = mesh.num_vertices();
  std::printf("%s: %d vertices, %d faces; medians of %d runs\n", path.c_str(), n, mesh.num_faces(), runs);

  std::vector<double> tf, tv;
  FaceCurvature fc;
  VertexCurvature vc;
  for (int r = 0; r < runs; ++r) {
    tf.push_back(seconds_of([&] { fc = face_curvature(V, F); }));
    tv.push_back(seconds_of([&] { vc = vertex_curvature(V, F); }));
  }
  std::printf("face_curvature (2-ring)   %.4f s\nvertex_curvature (2-ring) %.4f s\n", median(tf), median(tv));

  // The 5% of vertices with the largest |kappa_1| (vertex curvature): the ridges of Fig. 1.
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](int a, int b) { return std::abs(vc.k1(a)) > std::abs(vc.k1(b)); });
  const std::vector<int> ridge(order.begin(), order.begin() + std::max(1, n / 20));
  std::printf("ridge set: %zu vertices, |k1| >= %.4g (radius of curvature <= %.4g)\n", ridge.size(),
              std::abs(vc.k1(ridge.back())), 1 / std::abs(vc.k1(ridge.back())));

  const double radius = bounding_sphere_radius(V);
  std::printf("\n%-6s %-9s %7s %7s %7s %7s %7s %8s %8s %8s %8s %6s %7s %9s %7s\n", "ratio", "method", "min",
              "p1", "ridgmin", "ridgp1", "ridgmed", "str.mean", "str.vol", "str.p99", "str.max", "inv",
              "clamped", "own.vol", "time");
  for (double ratio : {0.03, 0.05}) {
    const double eta = ratio * radius;
    const RestTets normal_rest = rest_of(V, F, normal_prisms(V, F, eta));
    for (bool curvature : {false, true}) {
      std::vector<double> times;
      Shell shell;
      for (int r = 0; r < runs; ++r) {
        shell = generate(V, F, eta, curvature);
        times.push_back(shell.seconds);
      }
      const Eigen::MatrixXd top = shell.X.bottomRows(n);
      const Eigen::VectorXd thick = vertex_thickness(V, F, top) / eta;
      const StretchStats st = stretch_stats(normal_rest, shell.X);
      double own = st.volume_mean;
      if (curvature) own = stretch_stats(rest_of(V, F, curvature_prisms(V, F, eta)), shell.X).volume_mean;
      std::printf("%-6.2f %-9s %7.4f %7.4f %7.4f %7.4f %7.4f %8.5f %8.5f %8.5f %8.4f %6d %7d %9.5f %7.3f\n",
                  ratio, curvature ? "curvature" : "rigid", thick.minCoeff(), percentile(thick, 0.01),
                  percentile(thick, 0.0, ridge), percentile(thick, 0.01, ridge), percentile(thick, 0.5, ridge),
                  st.mean, st.volume_mean, st.p99, st.max, st.inverted, shell.clamped, own, median(times));
    }
  }
  return 0;
}
