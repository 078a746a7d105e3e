// bench_guard: guarded vs unguarded generation (dev driver; becomes the table).
#include <gshell/io/load_mesh.h>
#include <gshell/shell/generate_shell.h>

#include <cstdio>
#include <string>
#include <vector>

using namespace gshell;

int main(int argc, char** argv) {
  std::vector<std::string> files;
  std::vector<double> ratios;
  std::string method = "rigid";
  double dhat = GuardOptions{}.contact_distance, kv = GuardOptions{}.volume_weight, jhat = GuardOptions{}.j_hat;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--ratio") ratios.push_back(std::stod(argv[++i]));
    else if (a == "--method") method = argv[++i];
    else if (a == "--dhat") dhat = std::stod(argv[++i]);
    else if (a == "--kv") kv = std::stod(argv[++i]);
    else if (a == "--jhat") jhat = std::stod(argv[++i]);
    else files.push_back(a);
  }
  if (ratios.empty()) ratios = {0.01, 0.03, 0.05};
  std::printf("%-28s %6s %5s | %5s %5s %5s | %5s %5s %5s | %6s %5s %4s %3s | %6s %6s | %7s %7s\n", "model", "n", "ratio",
              "inv", "tt", "tb", "ginv", "gtt", "gtb", "thin", "unex", "it", "rnd", "str_u", "ratio", "t_u", "t_g");
  for (const std::string& file : files) {
    const TriMesh mesh = load_mesh(file);
    for (double ratio : ratios) {
      GenerateOptions o;
      o.method = parse_shell_method(method);
      o.thickness = thickness_from_ratio(mesh.V, ratio);
      o.allow_invalid = true;
      const GenerateResult u = generate_shell(mesh.V, mesh.F, o);
      o.allow_invalid = false;
      o.guard.contact_distance = dhat;
      o.guard.volume_weight = kv;
      o.guard.j_hat = jhat;
      const GenerateResult g = generate_shell(mesh.V, mesh.F, o);
      std::printf("%-28s %6d %5.2f | %5d %5d %5d | %5d %5d %5d | %6d %5d %4d %3d | %6.4f %6.3f | %7.3f %7.3f\n",
                  file.substr(file.rfind('/') + 1).c_str(), mesh.num_vertices(), ratio, u.metrics.stretch.inverted,
                  u.metrics.top_self_intersections, u.metrics.top_base_intersections, g.metrics.stretch.inverted,
                  g.metrics.top_self_intersections, g.metrics.top_base_intersections,
                  static_cast<int>(g.thinned_vertices.size()), static_cast<int>(g.unextrudable_vertices.size()),
                  g.solve.iterations, g.guard.start.rounds, u.metrics.stretch.volume_mean,
                  g.metrics.stretch.volume_mean / u.metrics.stretch.volume_mean, u.seconds.total, g.seconds.total);
      std::printf("    unguarded thinned %d, base self-intersections %d, excluded faces %d, start %.3f s, solve %.3f s (%d cg, %d backtracks, %d clamped), factor %.3f, repaired %d, min J %.3g, paper %d it\n",
                  static_cast<int>(u.thinned_vertices.size()), static_cast<int>(g.guard.base_self_intersections.size()),
                  g.guard.excluded_faces, g.guard.start.seconds, g.guard.solve.seconds, g.guard.solve.cg_iterations,
                  g.guard.solve.backtracks, g.guard.solve.clamped_steps, g.seconds.factor, g.guard.repaired_vertices,
                  g.guard.solve.min_relative_volume, g.guard.paper.iterations);
      std::fflush(stdout);
    }
  }
}
