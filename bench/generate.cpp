// bench_generate [MESH] (default models/bunny00.off; get it with scripts/fetch-models):
// times of the shell generation pieces on 2 cores (medians of 5) and every report figure for the
// offset and rigid methods at thickness ratios 0.01 and 0.03.
#include <gshell/io/load_mesh.h>
#include <gshell/shell/generate_report.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/polar_decomposition.h>
#include <gshell/solver/shell_solver.h>

#include <tbb/parallel_for.h>

#include <algorithm>
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

double seconds(const std::function<void()>& f) {
  const auto t0 = Clock::now();
  f();
  return std::chrono::duration<double>(Clock::now() - t0).count();
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

// Deformation gradients of the shell at the offset start (what the first local step sees).
std::vector<Eigen::Matrix3d> shell_gradients(const RestTets& rest, const Eigen::MatrixXd& X) {
  std::vector<Eigen::Matrix3d> F(rest.size());
  tbb::parallel_for(0, rest.size(), [&](int t) {
    Eigen::Matrix3d D;
    for (int j = 0; j < 3; ++j) D.col(j) = (X.row(rest.T(t, j + 1)) - X.row(rest.T(t, 0))).transpose();
    F[t] = D * rest.Dm_inv[t];
  });
  return F;
}

double polar_rate(const std::vector<Eigen::Matrix3d>& F) {
  std::vector<Eigen::Matrix3d> R(F.size());
  const double s = seconds([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, F.size(), 4096), [&](const tbb::blocked_range<std::size_t>& r) {
      closest_rotations(F.data() + r.begin(), R.data() + r.begin(), r.size());
    });
  });
  return static_cast<double>(F.size()) / s;
}

} // namespace

int main(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : "models/bunny00.off";
  if (!std::filesystem::exists(path) && path.rfind("builtin:", 0) != 0) {
    std::cerr << "bench_generate: " << path << " not found (run scripts/fetch-models, or pass a mesh)\n";
    return 1;
  }
  const TriMesh mesh = load_mesh(path);
  const int n = mesh.num_vertices(), m = mesh.num_faces();
  std::printf("mesh %s: %d vertices, %d faces, %d tets; %d threads\n", path.c_str(), n, m, 3 * m,
              tbb::this_task_arena::max_concurrency());
  const int runs = 5;

  for (double ratio : {0.01, 0.03}) {
    const double eta = thickness_from_ratio(mesh.V, ratio);
    std::printf("\n== ratio %.2f (eta %.6g)\n", ratio, eta);
    const RestTets rest = prism_rest_tets(mesh.F, n, normal_prisms(mesh.V, mesh.F, eta));
    Eigen::MatrixXd X0(2 * n, 3);
    X0 << mesh.V, offset_top(mesh.V, mesh.F, eta);

    // Polar decompositions of the real gradients (replicated to ~2M) and of random near-rotations.
    std::vector<Eigen::Matrix3d> F = shell_gradients(rest, X0);
    while (F.size() < 2000000) F.insert(F.end(), F.begin(), F.begin() + std::min(F.size(), 2000000 - F.size()));
    std::mt19937 rng(1);
    std::normal_distribution<double> g(0, 0.1);
    std::vector<Eigen::Matrix3d> Frand(2000000);
    for (auto& M : Frand) {
      M.setIdentity();
      for (int k = 0; k < 9; ++k) M(k / 3, k % 3) += g(rng);
    }
    std::printf("polar decompositions: %.1f M/s (shell gradients), %.1f M/s (I + N(0, 0.1) noise)\n",
                median_of(runs, [&] { return polar_rate(F); }) / 1e6,
                median_of(runs, [&] { return polar_rate(Frand); }) / 1e6);

    std::vector<int> base(n);
    std::iota(base.begin(), base.end(), 0);
    std::vector<double> factor_times;
    for (int i = 0; i < runs; ++i) factor_times.push_back(ShellSolver(rest, 2 * n, base).factor_seconds());
    std::printf("assemble + factor: %.3f s\n", median(factor_times));

    const ShellSolver solver(rest, 2 * n, base);
    SolveOptions ten;
    ten.max_iterations = 10;
    ten.tolerance = 0;
    std::printf("one local/global iteration: %.1f ms (median over %d solves of 10 iterations)\n",
                1e3 * median_of(runs, [&] {
                  Eigen::MatrixXd X = X0;
                  return solver.solve(X, ten).seconds / 10;
                }),
                runs);
    std::printf("energy evaluation (one local step): %.1f ms\n",
                1e3 * median_of(runs, [&] { return seconds([&] { solver.energy(X0); }); }));

    GenerateOptions options;
    options.thickness = eta;
    options.solve = ten;
    options.count_intersections = false;
    std::printf("generate end to end, 10 iterations, no file I/O or intersection counts: %.3f s\n",
                median_of(runs, [&] { return seconds([&] { generate_shell(mesh.V, mesh.F, options); }); }));

    for (ShellMethod method : {ShellMethod::Offset, ShellMethod::Rigid}) {
      GenerateOptions o;
      o.method = method;
      o.thickness = eta;
      o.count_intersections = true;
      const GenerateResult r = generate_shell(mesh.V, mesh.F, o);
      nlohmann::json report = generate_report(r, path, ratio);
      if (report["energy"].size() > 6) { // keep the screen short: first 3 and last 3
        auto e = report["energy"];
        report["energy"] = nlohmann::json::array({e[0], e[1], e[2], "...", e[e.size() - 3], e[e.size() - 2], e.back()});
      }
      std::printf("-- %s (default options: <= 50 iterations, tolerance 1e-5)\n%s%s\n", to_string(method).c_str(),
                  generate_summary(r, path).c_str(), report.dump().c_str());
    }
  }
}
