// bench_guard: guarded vs unguarded generation (dev driver; becomes the table).
#include <gshell/io/load_mesh.h>
#include <gshell/shell/generate_shell.h>

#include <cstdio>
#include <string>
#include <vector>

using namespace gshell;

namespace {

// Certificate violations of a guarded result outside what the guard had to leave (prisms around
// unextrudable vertices, triangles near the base's own crossings).
int violations_outside(const GenerateResult& g) {
  const GuardedSolverParameters& p = g.guard.parameters;
  const std::vector<char>& u = g.guard.unprotected_triangles;
  int count = 0;
  for (int t : g.certificate.inverted_tet_ids) count += p.skip_tets.empty() || !p.skip_tets[t];
  for (const BoundaryIntersection& b : g.certificate.intersections) {
    if (b.kind == IntersectionKind::BaseBase) continue;
    count += u.empty() || (!u[b.a] && !u[b.b]);
  }
  return count;
}

} // namespace

int main(int argc, char** argv) {
  std::vector<std::string> files;
  std::vector<double> ratios;
  std::string method = "rigid";
  GuardOptions guard;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--ratio") ratios.push_back(std::stod(argv[++i]));
    else if (a == "--method") method = argv[++i];
    else if (a == "--dhat") guard.contact_distance = std::stod(argv[++i]);
    else if (a == "--kv") guard.volume_weight = std::stod(argv[++i]);
    else if (a == "--kc") guard.contact_weight = std::stod(argv[++i]);
    else if (a == "--jhat") guard.j_hat = std::stod(argv[++i]);
    else if (a == "--rings") guard.repair_rings = std::stoi(argv[++i]);
    else if (a == "--spread") guard.start_spread = std::stod(argv[++i]);
    else if (a == "--margin") guard.start_margin = std::stod(argv[++i]);
    else if (a == "--thinning") guard.start_thinning = std::stod(argv[++i]);
    else files.push_back(a);
  }
  if (ratios.empty()) ratios = {0.01, 0.03, 0.05};
  std::printf("%-24s %6s %5s | %4s %5s %5s %4s | %4s %4s %4s %4s %5s | %5s %4s %4s %4s %5s | %6s %6s | %6s %6s\n", "model",
              "n", "ratio", "inv", "tt", "tb", "wall", "ginv", "gtt", "gtb", "gwal", "out", "thin", "unex", "base", "rnd",
              "rep", "str_u", "ratio", "t_u", "t_g");
  for (const std::string& file : files) {
    const TriMesh mesh = load_mesh(file);
    for (double ratio : ratios) {
      GenerateOptions o;
      o.method = parse_shell_method(method);
      o.thickness = thickness_from_ratio(mesh.V, ratio);
      o.allow_invalid = true;
      const GenerateResult u = generate_shell(mesh.V, mesh.F, o);
      o.allow_invalid = false;
      o.guard = guard;
      const GenerateResult g = generate_shell(mesh.V, mesh.F, o);
      const ShellCertificate &cu = u.certificate, &cg = g.certificate;
      std::printf("%-24s %6d %5.2f | %4d %5d %5d %4d | %4d %4d %4d %4d %5d | %5d %4d %4d %4d %5d | %6.4f %6.3f | %6.3f %6.3f\n",
                  file.substr(file.rfind('/') + 1).c_str(), mesh.num_vertices(), ratio, cu.inverted_tets,
                  cu.top_self_intersections, cu.top_base_intersections, cu.wall_intersections, cg.inverted_tets,
                  cg.top_self_intersections, cg.top_base_intersections, cg.wall_intersections, violations_outside(g),
                  static_cast<int>(g.thinned_vertices.size()), static_cast<int>(g.unextrudable_vertices.size()),
                  cg.base_self_intersections, g.guard.start.rounds, g.guard.repaired_vertices,
                  u.metrics.stretch.volume_mean, g.metrics.stretch.volume_mean / u.metrics.stretch.volume_mean,
                  u.seconds.total, g.seconds.total);
      std::fflush(stdout);
    }
  }
}
