// bench_contact [MESH] [RATIO] [DHAT ...] (default models/bunny00.off if present, else
// builtin:sphere:6; ratio 0.03; dhat 0.1 and 0.03, in units of eta): the contact guard's costs on
// a rigid shell (base fixed, top movable), slack = dhat. Medians of 5 on all cores, wall ms (CPU ms summed over threads: robust to a
// loaded machine). Speed goals (issue 13: guarded generation of bunny00 within 3x of the
// unguarded run): candidate build <= ~50 ms, energy+gradient and step bound <= ~10-30 ms.
#include "bench_main.h"
#include <gshell/guard/contact_guard.h>
#include <gshell/io/load_mesh.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/offset_shell.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

using namespace gshell;

namespace {

double cpu_ms() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}

struct Timing {
  double wall = 0, cpu = 0; // medians, ms
};

// `prepare` runs untimed before each of the 5 timed runs of `run`.
Timing time_runs(const std::function<void()>& prepare, const std::function<void()>& run) {
  std::vector<double> wall, cpu;
  for (int r = 0; r < 5; ++r) {
    prepare();
    const double c0 = cpu_ms();
    const auto t0 = std::chrono::steady_clock::now();
    run();
    wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    cpu.push_back(cpu_ms() - c0);
  }
  std::sort(wall.begin(), wall.end());
  std::sort(cpu.begin(), cpu.end());
  return {wall[2], cpu[2]};
}

void print(const char* what, const Timing& t, const std::string& note = "") {
  std::printf("  %-44s %8.2f ms (%8.2f cpu)  %s\n", what, t.wall, t.cpu, note.c_str());
  std::fflush(stdout);
}

// Two states within slack / 2 of X (the candidate list stays), so every pass measures a fresh X.
void run(const ShellBoundary& boundary, const std::vector<char>& movable, const ContactOptions& options,
         const Eigen::MatrixXd& X, const Eigen::MatrixXd& offset, double eta) {
  const int rows = static_cast<int>(X.rows());
  Eigen::MatrixXd Xa = X, Xb = X, far = X, D = offset - X;
  for (int i = 0; i < rows; ++i) {
    if (!movable[i]) {
      D.row(i).setZero();
      continue;
    }
    Xa.row(i).array() += 0.1 * options.slack;
    Xb.row(i).array() -= 0.1 * options.slack;
    far.row(i).array() += 0.6 * options.slack;
  }
  int flip = 0;
  auto next_state = [&]() -> const Eigen::MatrixXd& { return ++flip % 2 ? Xa : Xb; };
  const Eigen::MatrixXd* state = &X;
  {
    std::unique_ptr<ContactGuard> guard;
    const Timing t = time_runs([&] { guard = std::make_unique<ContactGuard>(boundary, rows, movable, options); },
                               [&] { guard->energy(X); });
    print("candidate build + first pass (rigid top)", t,
          std::to_string(guard->candidate_pairs().size()) + " candidates, min distance " +
              std::to_string(guard->min_distance(X) / eta) + " eta");
  }
  {
    ContactGuard guard(boundary, rows, movable, options);
    guard.energy(X);
    // Alternating X and a state moved by 0.6 slack: every pass rebuilds.
    const Timing t = time_runs([&] { state = &next_state() == &Xa ? &far : &X; }, [&] { guard.energy(*state); });
    print("rebuild + pass (guard kept)", t, std::to_string(guard.candidate_builds()) + " builds");
  }
  ContactGuard guard(boundary, rows, movable, options);
  guard.energy(X);
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(rows, 3);
  const Timing eg = time_runs([&] { state = &next_state(); }, [&] {
    guard.energy(*state);
    guard.add_gradient(*state, 1.0, G);
  });
  print("energy + gradient at a new X (no rebuild)", eg,
        std::to_string(guard.active_pairs()) + " active pairs, " + std::to_string(guard.candidate_builds()) + " builds");
  std::vector<Eigen::Triplet<double>> H;
  const Timing h = time_runs([&] { state = &next_state(); H.clear(); }, [&] { guard.add_hessian(*state, 1.0, H); });
  print("Hessian triplets at a new X", h, std::to_string(H.size()) + " triplets");

  // Steps between the rigid and the offset top (the solver's start) on the movable vertices: the
  // whole difference, and a tenth and a hundredth of it (steps of a converging solver).
  const double max_move = D.rowwise().norm().maxCoeff();
  for (double fraction : {1.0, 0.1, 0.01}) {
    double alpha = 0;
    const Eigen::MatrixXd Df = fraction * D;
    const Timing t = time_runs([&] { state = &next_state(); }, [&] { alpha = guard.step_bound(*state, Df, 1.0); });
    char what[96], note[96];
    std::snprintf(what, sizeof what, "step_bound, %.2g x (offset - rigid)", fraction);
    std::snprintf(note, sizeof note, "largest move %.3g eta, bound %.4g", fraction * max_move / eta, alpha);
    print(what, t, note);
  }
}

} // namespace

constexpr const char* kUsage =
    "usage: bench_contact [MESH] [RATIO=0.03] [DHAT ...]\n"
    "(default MESH models/bunny00.off if present, else builtin:sphere:6; DHAT in units of the thickness, default 0.1 0.03)\n";

int bench_main(int argc, char** argv) {
  std::string input = argc > 1 ? argv[1] : "";
  if (input.empty()) input = std::filesystem::exists("models/bunny00.off") ? "models/bunny00.off" : "builtin:sphere:6";
  const double ratio = argc > 2 ? std::stod(argv[2]) : 0.03;
  const TriMesh base = load_mesh(input);
  const int n = base.num_vertices();

  GenerateOptions g;
  g.method = ShellMethod::Rigid;
  g.thickness = thickness_from_ratio(base.V, base.F, ratio);
  g.count_intersections = false;
  const GenerateResult rigid = generate_shell(base.V, base.F, g);
  const double eta = g.thickness;
  Eigen::MatrixXd X(2 * n, 3), offset(2 * n, 3);
  X << base.V, rigid.shell.top;
  offset << base.V, offset_top(base.V, base.F, eta);

  const ShellBoundary boundary = shell_boundary(base.F, n);
  std::vector<char> movable(2 * n, 0);
  std::fill(movable.begin() + n, movable.end(), 1);
  std::vector<double> dhats;
  for (int i = 3; i < argc; ++i) dhats.push_back(std::stod(argv[i]));
  if (dhats.empty()) dhats = {0.1, 0.03};
  std::printf("%s: %d base vertices, %d shell vertices, %d boundary triangles; ratio %.3g, eta %.4g\n", input.c_str(), n,
              2 * n, boundary.size(), ratio, eta);
  std::printf("times: median of 5, wall ms (CPU ms summed over threads)\n");
  for (double dhat : dhats) {
    ContactOptions options;
    options.dhat = dhat * eta;
    options.slack = options.dhat;
    std::printf("dhat %.3g eta = %.4g, slack = dhat\n", dhat, options.dhat);
    run(boundary, movable, options, X, offset, eta);
    // A solver that repairs a region (the guard moves the top near invalid spots and a few
    // rings around them): 2 % of the top vertices, those nearest to top vertex 0.
    std::vector<std::pair<double, int>> by_distance;
    for (int i = n; i < 2 * n; ++i) by_distance.push_back({(X.row(i) - X.row(n)).squaredNorm(), i});
    std::sort(by_distance.begin(), by_distance.end());
    std::vector<char> region(2 * n, 0);
    for (int k = 0; k < n / 50; ++k) region[by_distance[k].second] = 1;
    std::printf("dhat %.3g eta, %d movable top vertices (a region)\n", dhat, n / 50);
    run(boundary, region, options, X, offset, eta);
  }
  return 0;
}

int main(int argc, char** argv) { return gshell::bench::run_benchmark(argc, argv, kUsage, bench_main); }
