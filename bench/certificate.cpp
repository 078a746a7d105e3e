// bench_certificate [--ratio R] [--methods rigid,curvature,offset] [--runs K] [--closed] [MESH ...]
// The exact shell certificate against today's two intersection counts on generated shells:
// for every mesh (default models/bunny00.off; a builtin spec, a mesh file or a folder of .off
// files) and method, the shell is generated at thickness ratio R (default 0.03) without metrics,
// then certify_shell (with and without the base/base pairs) and the old counts (top
// self-intersections of pairs sharing no vertex, plus top/base pairs) are timed, interleaved, K
// times each (default 5; medians, wall and CPU seconds).
// One row per shell: vertices, the certificate's counts, the old counts, times. Meshes that
// cannot carry a shell, and with --closed those with a boundary, are listed as skipped.
// The baseline table of docs/validity.md: bench_certificate --closed --runs 3 models
//
// bench_certificate --frames K [--bend DEG=60] [--ratio R] [--runs K] [MESH]: the certificate of a
// deformation's frames alone (issue 14): the rigid shell at ratio R (default 0.01 here) bent in K
// frames to DEG degrees by the deformer (--allow-invalid, untimed), then one ShellCertifier
// certifies every frame in order (trees refit), as the deform guard does (no base/base pairs) and
// as the pose guard does (with them); median ms per frame over the frames, then over the runs.
#include "bench_main.h"
#include "bench_common.h"

#include <gshell/deform/shell_deformer.h>
#include <gshell/deform/synthetic_motion.h>
#include <gshell/geometry/mesh_topology.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/load_mesh.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/quality/triangle_intersections.h>
#include <gshell/shell/generate_shell.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

using namespace gshell;

namespace {

double process_cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

struct Time {
  double wall = 0, cpu = 0;
};

Time timed(const std::function<void()>& f) {
  const double c0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return {std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), process_cpu_seconds() - c0};
}

Time median(std::vector<Time> v) {
  auto mid = [&](auto member) {
    std::vector<double> x;
    for (const Time& t : v) x.push_back(t.*member);
    std::sort(x.begin(), x.end());
    return x[x.size() / 2];
  };
  return {mid(&Time::wall), mid(&Time::cpu)};
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start <= s.size()) {
    const std::size_t comma = std::min(s.find(',', start), s.size());
    out.push_back(s.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

std::vector<std::string> expand(const std::vector<std::string>& inputs) {
  std::vector<std::string> meshes;
  for (const std::string& in : inputs) {
    if (!std::filesystem::is_directory(in)) {
      meshes.push_back(in);
      continue;
    }
    std::vector<std::string> found;
    for (const auto& e : std::filesystem::directory_iterator(in))
      if (e.path().extension() == ".off") found.push_back(e.path().string());
    std::sort(found.begin(), found.end());
    meshes.insert(meshes.end(), found.begin(), found.end());
  }
  return meshes;
}

// --frames mode: see the head of this file.
int certify_frames(const std::string& input, double ratio, int frame_count, double degrees, int runs) {
  TriMesh mesh;
  try {
    mesh = load_mesh(input);
    require_valid_mesh(mesh, input);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_certificate: %s\n", e.what());
    return 1;
  }
  const Shell rest = gshell::bench::rigid_rest_shell(mesh, ratio).shell;
  const int n = rest.num_base_vertices();
  ShellDeformer deformer(rest);
  const MotionFrame frame = motion_frame(rest.base);
  DeformOptions deform;
  deform.allow_invalid = true;
  deform.certify = false;
  deform.measure_stretch = false;
  std::vector<Eigen::MatrixXd> X;
  for (int k = 1; k <= frame_count; ++k) {
    deformer.solve(bend(rest.base, frame, degrees * ramp(k, frame_count)), deform);
    X.push_back(deformer.current());
  }
  std::printf("mesh %s: %d base vertices, %d faces, ratio %g; %d frames bent to %.0f degrees (unguarded solve)\n",
              input.c_str(), n, static_cast<int>(rest.F.rows()), ratio, frame_count, degrees);
  CertifyOptions without_base;
  without_base.base_self_intersections = false;
  for (const bool base_pairs : {false, true}) {
    std::vector<double> run_ms, run_cpu;
    long long inverted = 0, pairs = 0;
    for (int r = 0; r < runs; ++r) {
      ShellCertifier certifier(rest.F, n);
      certifier.certify(rest.base, rest.top, base_pairs ? CertifyOptions{} : without_base); // built at rest
      std::vector<double> ms, cpu;
      inverted = pairs = 0;
      for (const Eigen::MatrixXd& x : X) {
        ShellCertificate c;
        const Time t = timed([&] { c = certifier.certify(x.topRows(n), x.bottomRows(n), base_pairs ? CertifyOptions{} : without_base); });
        ms.push_back(1e3 * t.wall);
        cpu.push_back(1e3 * t.cpu);
        inverted += c.inverted_tets;
        pairs += static_cast<long long>(c.intersections.size());
      }
      run_ms.push_back(gshell::bench::median(ms));
      run_cpu.push_back(gshell::bench::median(cpu));
    }
    std::printf("certificate per frame (%s): median %.2f ms wall, %.2f ms CPU over %d runs; inverted tets summed "
                "%lld, intersecting pairs summed %lld\n",
                base_pairs ? "with base/base, as pose" : "without base/base, as deform", gshell::bench::median(run_ms),
                gshell::bench::median(run_cpu), runs, inverted, pairs);
  }
  return 0;
}

} // namespace

constexpr const char* kUsage =
    "usage: bench_certificate [--ratio R=0.03] [--methods rigid,curvature,offset] [--runs K=5] [--closed] [MESH|DIR ...]\n"
    "       bench_certificate --frames K [--bend DEG=60] [--ratio R=0.01] [--runs K] [MESH]\n"
    "(default MESH models/bunny00.off; what each prints: the comment at the top of bench/certificate.cpp)\n";

int bench_main(int argc, char** argv) {
  double ratio = 0.03;
  int runs = 5, frames = 0;
  double degrees = 60;
  bool ratio_given = false;
  bool closed_only = false;
  std::vector<std::string> methods{"rigid", "curvature", "offset"}, inputs;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--ratio") && i + 1 < argc) ratio = std::stod(argv[++i]), ratio_given = true;
    else if (!std::strcmp(argv[i], "--frames") && i + 1 < argc) frames = std::stoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--bend") && i + 1 < argc) degrees = std::stod(argv[++i]);
    else if (!std::strcmp(argv[i], "--methods") && i + 1 < argc) methods = split(argv[++i]);
    else if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) runs = std::stoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--closed")) closed_only = true;
    else inputs.push_back(argv[i]);
  }
  if (inputs.empty()) inputs.push_back("models/bunny00.off");
  if (frames > 0) return certify_frames(inputs.front(), ratio_given ? ratio : 0.01, frames, degrees, runs);

  std::printf("ratio %.3g; times: median of %d, wall s (cpu s summed over threads); old = today's counts\n", ratio, runs);
  std::printf("%-28s %-9s %7s | %8s %7s %8s %5s %8s | %7s %8s | %15s %15s %15s\n", "mesh", "method", "verts",
              "inverted", "top/top", "top/base", "walls", "base/base", "old t/t", "old t/b", "certificate",
              "w/o base/base", "old counts");
  for (const std::string& input : expand(inputs)) {
    const std::string name = std::filesystem::path(input).filename().string();
    TriMesh mesh;
    try {
      mesh = load_mesh(input);
      require_valid_mesh(mesh, name);
    } catch (const std::exception& e) {
      std::printf("%-28s skipped: %s\n", name.c_str(), e.what());
      continue;
    }
    if (closed_only && mesh_stats(mesh).boundary_edges > 0) {
      std::printf("%-28s skipped: open\n", name.c_str());
      continue;
    }
    for (const std::string& method : methods) {
      GenerateOptions options;
      options.method = parse_shell_method(method);
      options.thickness = thickness_from_ratio(mesh.V, mesh.F, ratio);
      options.count_intersections = false;
      GenerateResult shell;
      try {
        shell = generate_shell(mesh.V, mesh.F, options);
      } catch (const std::exception& e) {
        std::printf("%-28s %-9s skipped: %s\n", name.c_str(), method.c_str(), e.what());
        continue;
      }
      const Eigen::MatrixXd &base = shell.shell.base, &top = shell.shell.top;
      const Eigen::MatrixXi& F = shell.shell.F;
      ShellCertificate cert;
      int old_self = 0, old_between = 0;
      std::vector<Time> cert_t, shell_t, old_t;
      CertifyOptions shell_only;
      shell_only.base_self_intersections = false;
      for (int r = 0; r < runs; ++r) {
        cert_t.push_back(timed([&] { cert = certify_shell(base, top, F); }));
        shell_t.push_back(timed([&] { certify_shell(base, top, F, shell_only); }));
        old_t.push_back(timed([&] {
          old_self = count_self_intersections(top, F);
          old_between = count_intersections_between(top, F, base, F);
        }));
      }
      const Time c = median(cert_t), w = median(shell_t), o = median(old_t);
      std::printf("%-28s %-9s %7d | %8d %7d %8d %5d %8d | %7d %8d | %6.3f (%6.3f) %6.3f (%6.3f) %6.3f (%6.3f)\n",
                  name.c_str(), method.c_str(), mesh.num_vertices(),
                  cert.inverted_tets, cert.top_self_intersections, cert.top_base_intersections, cert.wall_intersections,
                  cert.base_self_intersections, old_self, old_between, c.wall, c.cpu, w.wall, w.cpu, o.wall, o.cpu);
      std::fflush(stdout);
    }
  }
  return 0;
}

int main(int argc, char** argv) { return gshell::bench::run_benchmark(argc, argv, kUsage, bench_main); }
