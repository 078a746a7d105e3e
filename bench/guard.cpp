// bench_guard: guarded vs unguarded generation, one row per model and ratio.
//   bench_guard [options] MODEL.off...     (bench_guard --help lists the options)
// The table of issue 13 over CGAL's closed models, one command:
//   bench_guard --closed --ratio 0.01 --ratio 0.03 --ratio 0.05 models/*.off
// Columns: unguarded certificate counts (inverted tets, top/top, top/base, wall pairs), the guarded
// ones, `out` = guarded violations outside what the guard has to leave (prisms at unextrudable
// vertices, triangles next to the base's own crossings; must be 0), thinned / unextrudable vertices,
// base crossings, start rounds, repaired vertices, the unguarded volume-weighted stretch against the
// normal prisms and guarded / unguarded, the median seconds of N runs of each (interleaved) and
// their ratio. A summary line closes the table.
#include "bench_main.h"
#include "bench_common.h"

#include <gshell/geometry/mesh_topology.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/load_mesh.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/guard/volume_barrier.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/quality/stretch.h>
#include <gshell/run/process_memory.h>

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

using namespace gshell;
using gshell::bench::median;

namespace {

// Certificate violations of a guarded result outside what the guard had to leave (prisms around
// unextrudable vertices, triangles near the base's own crossings).
int violations_outside(const GenerateResult& g) {
  const GuardedSolverParameters& p = g.guard.parameters;
  const std::vector<char>& u = g.guard.unprotected_triangles;
  int count = 0;
  for (int t : g.metrics.certificate.inverted_tet_ids) count += p.skip_tets.empty() || !p.skip_tets[t];
  for (const BoundaryIntersection& b : g.metrics.certificate.intersections) {
    if (b.kind == IntersectionKind::BaseBase) continue;
    count += u.empty() || (!u[b.a] && !u[b.b]);
  }
  // A part inside another's layer is the guard's to mend, unless the base crosses itself (then a
  // sheet can be partly inside another layer with every guarded test passing).
  if (g.metrics.certificate.base_self_intersections <= 0) count += g.metrics.certificate.nested_parts;
  return count;
}

const char* const kHelp = R"(bench_guard: guarded vs unguarded generation (issue 13's table), one row per model and ratio.
usage: bench_guard [options] MODEL... 
  --method rigid|curvature   shell method (default rigid)
  --ratio R                  thickness ratio; repeatable (default: 0.01 0.03 0.05)
  --repeat N                 runs of each (guarded and unguarded interleaved); medians are shown
  --list FILE                read model paths from FILE (one per line, # comments), besides MODEL...
  --closed                   keep only models that load, validate and are closed (no boundary edge);
                             the others are named on stderr with the reason
  --detail                   time per phase of each guarded run
  --repair-iters N           cap on the repair's iterations (default: the solve's 50, extended by
                             --repair-budget)
  --repair-budget X          repaired vertices x iterations the repair may run past the solve's cap
                             (default 100000; 0: none)
  --relax N                  barrier relaxation rounds after the repair (default 1; 0: none)
  --lift N                   sweeps lifting thin tops after the repair (default 4; 0: none)
  --iters N                  cap on the paper's and the repair's iterations
  guard parameters (GuardOptions; defaults are generation_guard_options()):
  --dhat X --kv X --kc X --jhat X --rings N --spread X --margin X --thinning X --refine N
  --backoff X --min-scale X --local-rings N --hold-rounds N --supernodal-rows N --supernodal-flops X --start-smoothing X
  --gn-volume --projected-contact
Example (the issue's table over CGAL's closed models):
  bench_guard --closed --ratio 0.01 --ratio 0.03 --ratio 0.05 models/*.off
)";

// Empty when the mesh at `file` loads, validates and is closed, else why not.
std::string not_closed(const std::string& file) {
  try {
    const TriMesh mesh = load_mesh(file);
    require_valid_mesh(mesh, file);
    const MeshStats stats = mesh_stats(mesh);
    if (stats.boundary_edges > 0) return std::to_string(stats.boundary_edges) + " boundary edges";
    return {};
  } catch (const std::exception& e) {
    return e.what();
  }
}

} // namespace

int bench_main(int argc, char** argv) {
  gshell::reuse_freed_memory(); // as the gshell CLI does
  std::vector<std::string> files;
  std::vector<double> ratios;
  std::string method = "rigid";
  int repeat = 1;
  bool detail = false;
  int guard_iterations = -1;
  GuardOptions guard = generation_guard_options();
  bool closed_only = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a.rfind("--", 0) == 0 && a != "--detail" && a != "--closed" && a != "--gn-volume" &&
        a != "--projected-contact" && !has_value) {
      std::fprintf(stderr, "bench_guard: option %s needs a value (bench_guard --help)\n", a.c_str());
      return 1;
    }
    if (a == "--closed") closed_only = true;
    else if (a == "--list") {
      std::ifstream in(argv[++i]);
      if (!in) {
        std::fprintf(stderr, "bench_guard: cannot read the model list %s\n", argv[i]);
        return 1;
      }
      for (std::string line; std::getline(in, line);)
        if (!line.empty() && line[0] != '#') files.push_back(line);
    } else if (a == "--ratio") ratios.push_back(std::stod(argv[++i]));
    else if (a == "--method") method = argv[++i];
    else if (a == "--repeat") repeat = std::max(1, std::stoi(argv[++i]));
    else if (a == "--dhat") guard.contact_distance = std::stod(argv[++i]);
    else if (a == "--kv") guard.volume_weight = std::stod(argv[++i]);
    else if (a == "--kc") guard.contact_weight = std::stod(argv[++i]);
    else if (a == "--jhat") guard.j_hat = std::stod(argv[++i]);
    else if (a == "--rings") guard.repair_rings = std::stoi(argv[++i]);
    else if (a == "--spread") guard.start_spread = std::stod(argv[++i]);
    else if (a == "--margin") guard.start_margin = std::stod(argv[++i]);
    else if (a == "--thinning") guard.start_thinning = std::stod(argv[++i]);
    else if (a == "--start-smoothing") guard.start_smoothing = std::stod(argv[++i]);
    else if (a == "--detail") detail = true;
    else if (a == "--gn-volume") guard.projected_volume_hessian = false;
    else if (a == "--projected-contact") guard.projected_contact_hessian = true;
    else if (a == "--refine") guard.start_refine = std::stoi(argv[++i]);
    else if (a == "--backoff") guard.start_backoff = std::stod(argv[++i]);
    else if (a == "--iters") guard_iterations = std::stoi(argv[++i]);
    else if (a == "--repair-iters") guard.repair_iterations = std::stoi(argv[++i]);
    else if (a == "--repair-budget") guard.repair_budget = std::stod(argv[++i]);
    else if (a == "--relax") guard.relax_rounds = std::stoi(argv[++i]);
    else if (a == "--lift") guard.lift_sweeps = std::stoi(argv[++i]);
    else if (a == "--local-rings") guard.local_rings = std::stoi(argv[++i]);
    else if (a == "--hold-rounds") guard.hold_rounds = std::stoi(argv[++i]);
    else if (a == "--supernodal-rows") guard.supernodal_rows = std::stoi(argv[++i]);
    else if (a == "--supernodal-flops") guard.supernodal_flops = std::stod(argv[++i]);
    else if (a == "--min-scale") guard.repair_min_scale = std::stod(argv[++i]);
    else if (a.rfind("--", 0) == 0) {
      std::fprintf(stderr, "bench_guard: unknown option %s (bench_guard --help)\n", a.c_str());
      return 1;
    } else files.push_back(a);
  }
  if (closed_only) {
    std::vector<std::string> kept;
    for (const std::string& file : files) {
      const std::string why = not_closed(file);
      if (why.empty()) kept.push_back(file);
      else std::fprintf(stderr, "bench_guard: skipping %s: %s\n", file.c_str(), why.c_str());
    }
    files = kept;
  }
  if (files.empty()) {
    std::fprintf(stderr, "bench_guard: no model given (bench_guard --help)\n");
    return 1;
  }
  if (ratios.empty()) ratios = {0.01, 0.03, 0.05};
  std::printf("%-24s %6s %5s | %4s %5s %5s %4s | %4s %4s %4s %4s %5s | %5s %4s %4s %4s %5s | %6s %6s | %6s %6s %5s\n", "model",
              "n", "ratio", "inv", "tt", "tb", "wall", "ginv", "gtt", "gtb", "gwal", "out", "thin", "unex", "base", "rnd",
              "rep", "str_u", "ratio", "t_u", "t_g", "t_g/u");
  int rows = 0, valid_u = 0, clean_g = 0, valid_g = 0;
  std::vector<double> stretch_ratios, time_ratios;
  for (const std::string& file : files) {
    const TriMesh mesh = load_mesh(file);
    for (double ratio : ratios) {
      GenerateOptions o;
      o.method = parse_shell_method(method);
      o.thickness = thickness_from_ratio(mesh.V, mesh.F, ratio);
      o.guard = guard;
      if (guard_iterations >= 0) o.solve.max_iterations = guard_iterations;
      GenerateResult u, g;
      std::vector<double> tu, tg;
      for (int r = 0; r < repeat; ++r) { // interleaved, so that load changes hit both alike
        o.allow_invalid = true;
        u = generate_shell(mesh.V, mesh.F, o);
        o.allow_invalid = false;
        g = generate_shell(mesh.V, mesh.F, o);
        tu.push_back(u.seconds.total);
        tg.push_back(g.seconds.total);
      }
      const ShellCertificate &cu = u.metrics.certificate, &cg = g.metrics.certificate;
      const int out = violations_outside(g);
      const double stretch_ratio = g.metrics.stretch.volume_mean / u.metrics.stretch.volume_mean;
      const double time_ratio = median(tg) / median(tu);
      ++rows;
      valid_u += cu.valid();
      valid_g += cg.valid();
      clean_g += out == 0;
      if (std::isfinite(stretch_ratio)) stretch_ratios.push_back(stretch_ratio);
      time_ratios.push_back(time_ratio);
      std::printf("%-24s %6d %5.2f | %4d %5d %5d %4d | %4d %4d %4d %4d %5d | %5d %4d %4d %4d %5d | %6.4f %6.3f | %6.3f %6.3f %5.2f\n",
                  file.substr(file.rfind('/') + 1).c_str(), mesh.num_vertices(), ratio, cu.inverted_tets,
                  cu.top_self_intersections, cu.top_base_intersections, cu.wall_intersections, cg.inverted_tets,
                  cg.top_self_intersections, cg.top_base_intersections, cg.wall_intersections, out,
                  g.metrics.thinned_vertices, static_cast<int>(g.unextrudable_vertices.size()),
                  cg.base_self_intersections, g.guard.start.rounds, g.guard.repaired_vertices,
                  u.metrics.stretch.volume_mean, stretch_ratio, median(tu), median(tg), time_ratio);
      if (detail) {
        const GuardedShell& d = g.guard;
        std::printf("  guarded: paper %d it %.3f s | start %d rounds %.3f s | repair %d vertices, %d it (%s), "
                    "E_guard %.6g, %d cg, %d supernodal (%d reordered), %d backtracks, %d clamped (%d held), %d active tets, "
                    "%d active contacts, %.3f s | relax %d it %.3f s | lift %d of %d candidates, %d checks, %.3f s | "
                    "factor %.3f s | certificate %.3f s | total %.3f s\n",
                    d.paper.iterations, d.paper.seconds, d.start.rounds, d.start.seconds, d.repaired_vertices,
                    d.solve.iterations,
                    d.repaired_vertices == 0 ? "none to run" : d.solve.converged ? "converged" : "not converged",
                    d.solve.energy.empty() ? 0.0 : d.solve.energy.back(), d.solve.cg_iterations, d.solve.supernodal_solves,
                    d.solve.supernodal_solves - d.solve.reused_orderings,
                    d.solve.backtracks, d.solve.clamped_steps, d.solve.held_steps, d.solve.active_tets, d.solve.active_contacts,
                    d.solve.seconds, d.relax.iterations, d.relax.seconds, d.lift.moves, d.lift.candidates, d.lift.checks,
                    d.lift.seconds, d.factor_seconds, g.metrics.certificate.seconds,
                    g.seconds.total);
        if (std::getenv("GUARD_PROBE")) {
          const int nv = mesh.num_vertices();
          const RestTets rest = prism_rest_tets(mesh.F, nv, normal_prisms(mesh.V, mesh.F, o.thickness));
          const VolumeBarrier vb(rest, 0.1);
          for (const GenerateResult* r : {&u, &g}) {
            Eigen::MatrixXd X(2 * nv, 3);
            X << mesh.V, r->shell.top;
            int neg = 0, low = 0, low3 = 0;
            for (int t = 0; t < rest.size(); ++t) {
              const double J = vb.relative_volume_of(X, t);
              neg += J <= 0;
              low += J > 0 && J < 0.1;
              low3 += J > 0 && J < 0.03;
            }
            std::printf("  %s: J<=0 %d, 0<J<0.1 %d, 0<J<0.03 %d\n", r == &u ? "unguarded" : "guarded", neg, low, low3);
          }
          const ShellBoundary boundary = shell_boundary(mesh.F, nv);
          Eigen::MatrixXd Xu(2 * nv, 3), Xg(2 * nv, 3);
          Xu << mesh.V, u.shell.top;
          Xg << mesh.V, g.shell.top;
          const Eigen::VectorXd tu = tet_stretch(rest, Xu), tg = tet_stretch(rest, Xg);
          // Stretch over the faces at least `rings` rings of faces away from every marked vertex.
          auto stretch_away = [&](std::vector<char> near, int rings, const char* from) {
            for (int ring = 0; ring < rings; ++ring) {
              std::vector<char> grown = near;
              for (int f = 0; f < mesh.F.rows(); ++f)
                if (near[mesh.F(f, 0)] || near[mesh.F(f, 1)] || near[mesh.F(f, 2)])
                  for (int k = 0; k < 3; ++k) grown[mesh.F(f, k)] = 1;
              near = grown;
            }
            double su = 0, sg = 0, w = 0;
            int faces = 0;
            for (int f = 0; f < mesh.F.rows(); ++f) {
              if (near[mesh.F(f, 0)] || near[mesh.F(f, 1)] || near[mesh.F(f, 2)]) continue;
              ++faces;
              for (int k = 0; k < 3; ++k) {
                su += rest.volume[3 * f + k] * tu[3 * f + k];
                sg += rest.volume[3 * f + k] * tg[3 * f + k];
                w += rest.volume[3 * f + k];
              }
            }
            std::printf("  stretch away from %s (+%d rings, %d faces): unguarded %.4f guarded %.4f ratio %.3f\n", from,
                        rings, faces, su / w, sg / w, sg / su);
          };
          // What the guard must leave: faces with an unprotected boundary triangle (base
          // crossings, unextrudable vertices).
          std::vector<char> near(nv, 0);
          for (int row = 0; row < boundary.size(); ++row)
            if (g.guard.unprotected_triangles[row])
              for (int k = 0; k < 3; ++k) near[mesh.F(boundary.face[row], k)] = 1;
          stretch_away(near, 2, "the unavoidable");
          // What the guard must mend: the unguarded shell's inverted tets and intersecting
          // triangles. Where the excess lies within a few rings of them, it is the price of
          // mending, not a worse shell elsewhere.
          std::fill(near.begin(), near.end(), 0);
          for (int t : cu.inverted_tet_ids) near[mesh.F(t / 3, 0)] = near[mesh.F(t / 3, 1)] = near[mesh.F(t / 3, 2)] = 1;
          for (const BoundaryIntersection& x : cu.intersections)
            for (int row : {x.a, x.b})
              for (int k = 0; k < 3; ++k) near[mesh.F(boundary.face[row], k)] = 1;
          for (int rings : {0, 1, 2, 3}) stretch_away(near, rings, "the unguarded shell's violations");
          // Where the guarded stretch comes from: prisms by their least start scale (held below
          // repair_min_scale, pulled in, untouched) and by their least final relative thickness.
          const Eigen::VectorXd& sc = g.guard.start.scale;
          const Eigen::VectorXd& th = g.metrics.vertex_thickness;
          auto classes = [&](auto key, const char* name, std::initializer_list<double> edges) {
            std::vector<double> eu(edges.size() + 1, 0), eg(edges.size() + 1, 0), ew(edges.size() + 1, 0);
            std::vector<int> nf(edges.size() + 1, 0);
            for (int f = 0; f < mesh.F.rows(); ++f) {
              double k = 1e300;
              for (int j = 0; j < 3; ++j) k = std::min(k, key(mesh.F(f, j)));
              std::size_t c = 0;
              for (double e : edges) {
                if (k < e) break;
                ++c;
              }
              ++nf[c];
              for (int j = 0; j < 3; ++j) {
                eu[c] += rest.volume[3 * f + j] * tu[3 * f + j];
                eg[c] += rest.volume[3 * f + j] * tg[3 * f + j];
                ew[c] += rest.volume[3 * f + j];
              }
            }
            double W = 0, U = 0;
            for (std::size_t c = 0; c < ew.size(); ++c) W += ew[c], U += eu[c];
            std::printf("  by %s:", name);
            std::size_t c = 0;
            double lo = 0;
            for (double e : edges) {
              std::printf(" [%.0e,%.0e) %d faces u %.4f g %.4f (g/u %.3f) excess %.4f |", lo, e, nf[c], eu[c] / W,
                          eg[c] / W, eg[c] / eu[c], (eg[c] - eu[c]) / U);
              lo = e;
              ++c;
            }
            std::printf(" >= %.0e %d faces u %.4f g %.4f (g/u %.3f) excess %.4f\n", lo, nf[c], eu[c] / W, eg[c] / W,
                        eg[c] / eu[c], (eg[c] - eu[c]) / U);
          };
          classes([&](int v) { return sc[v]; }, "least start scale", {1e-4, 0.1, 0.5, 1.0});
          classes([&](int v) { return th[v]; }, "least guarded thickness", {0.1, 0.5, 0.9});
          int listed = 0;
          for (int v = 0; v < nv && listed < 12; ++v)
            if (sc[v] < 1e-3) {
              ++listed;
              std::printf("  low start: v %d scale %.2e margin %.2e thickness u %.3f g %.3f\n", v, sc[v],
                          g.guard.directions.margin[v], u.metrics.vertex_thickness[v], th[v]);
            }
        }
      }
      std::fflush(stdout);
    }
  }
  if (rows == 0) return 0;
  std::printf("%s, %d runs each: %d rows; valid unguarded %d, guarded %d; guarded clean outside the "
              "unavoidable %d; stretch guarded/unguarded median %.3f max %.3f; time guarded/unguarded median %.2f "
              "max %.2f\n",
              method.c_str(), repeat, rows, valid_u, valid_g, clean_g, median(stretch_ratios),
              stretch_ratios.empty() ? 0.0 : *std::max_element(stretch_ratios.begin(), stretch_ratios.end()),
              median(time_ratios), *std::max_element(time_ratios.begin(), time_ratios.end()));
  return 0;
}

int main(int argc, char** argv) {
  gshell::restart_with_huge_pages(argv); // as the gshell CLI does
  return gshell::bench::run_benchmark(argc, argv, kHelp, bench_main);
}
