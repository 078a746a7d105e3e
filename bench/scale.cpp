// bench_scale [--levels 6,7,8,9] [--mesh FILE]... [--subdivide K] [--linear auto,direct,auto:jacobi] [--ratio 0.02]
//             [--runs 3] [--anderson K] [--cg-relative T] [--start-smoothing S] [--method rigid|curvature]
// How shell generation and the deformer's setup grow with the mesh: builtin:sphere at the given
// subdivision levels (4x the vertices per level) plus models/bunny00.off when it is there (or
// the --mesh files), rigid method at thickness ratio 0.02, once per linear solver named (CG paths
// take the multigrid preconditioner; a ":jacobi" suffix, e.g. auto:jacobi, takes Jacobi's). Every
// case runs in a fresh process (this executable with --case), so the peak memory (VmHWM) is that
// case's own; times are medians over --runs processes. The runs go in rounds, every case once per
// round, so a drift in the machine's speed (20-30 % within minutes on a shared host) reaches all
// sizes alike, and a growth ratio is the median over rounds of that round's ratio. Prints per case:
// total, setup (assembly + factor), solve, per-iteration time, CG iterations, the deformer's setup,
// generation's CPU seconds (cpu_s), of which user time (usr_s; the rest is system time, mostly the
// kernel backing freshly touched memory) and minor page faults (faults_k, thousands), peak memory
// of generation alone (gen_MB) and of the whole case (peak_MB: the deformer is set up beside the
// generation result), the report's figures (to compare the solvers), and the growth
// ratios per 4x vertices. --subdivide K also runs every --mesh split K times (each triangle into
// four at its edge midpoints, case FILE@k: the same surface, finer against the same layer; growth
// per split printed as for the sphere levels). --anderson and --cg-relative override generation's Anderson history and
// the CG's relative stopping test (--anderson 0 --cg-relative 0: the plain iteration with an absolute CG stop);
// --start-smoothing the radius of the start's normal smoothing (0: the offset surface);
// --method curvature generates towards the curvature-sensitive prisms instead (their making,
// principal curvatures included, is the column curv_s and part of total_s).
#include "bench_main.h"
#include <gshell/deform/shell_deformer.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/io/load_mesh.h>
#include <gshell/run/process_memory.h>
#include <gshell/shell/generate_shell.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <sys/resource.h>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

using namespace gshell;
using Clock = std::chrono::steady_clock;

namespace {

// CPU seconds of all of this process's threads so far and its minor page faults (getrusage).
// System time is mostly the kernel backing freshly touched pages, which on a VM costs what the
// host makes it cost; user time is the algorithm's own.
struct ProcessTimes {
  double user = 0, system = 0, minor_faults = 0;
  double cpu() const { return user + system; }
};
ProcessTimes process_times() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
  return {seconds(usage.ru_utime), seconds(usage.ru_stime), static_cast<double>(usage.ru_minflt)};
}

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Peak resident memory of this process so far, MB (VmHWM of /proc/self/status).
double peak_megabytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return 0;
}

std::string load_average() {
  std::ifstream f("/proc/loadavg");
  std::string a, b, c;
  f >> a >> b >> c;
  return a + " " + b + " " + c;
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, sep))
    if (!item.empty()) out.push_back(item);
  return out;
}

/// "FILE@k": FILE split k times; otherwise a mesh file or builtin spec.
TriMesh load_case_mesh(const std::string& spec) {
  const auto at = spec.rfind('@');
  if (at == std::string::npos || spec.rfind("builtin:", 0) == 0) return load_mesh(spec);
  return midpoint_subdivision(load_mesh(spec.substr(0, at)), std::stoi(spec.substr(at + 1)));
}

/// The family of a case (consecutive cases of one family are 4x apart): "sphere" for the sphere
/// levels, FILE for FILE and FILE@k.
std::string family(const std::string& spec) {
  if (spec.rfind("builtin:sphere:", 0) == 0) return "sphere";
  return spec.substr(0, spec.rfind('@'));
}

/// "sphere:7", "bunny00", "bunny00@2".
std::string display_name(const std::string& spec) {
  if (spec.rfind("builtin:", 0) == 0) return spec.substr(8);
  const auto at = spec.rfind('@');
  if (at == std::string::npos) return std::filesystem::path(spec).stem().string();
  return std::filesystem::path(spec.substr(0, at)).stem().string() + spec.substr(at);
}

// One case in this process; prints "key=value" pairs on one line.
// `tuning`: the solver settings other than the linear solver (negative: the default).
struct Tuning {
  int anderson = -1;         ///< SolveOptions::anderson_history
  double cg_relative = -1;   ///< LinearSolverOptions::cg_relative_tolerance
  double start_smoothing = -1; ///< GuardOptions::start_smoothing
  std::string method = "rigid"; ///< GenerateOptions::method
  std::string arguments() const {
    return " --anderson " + std::to_string(anderson) + " --cg-relative " + std::to_string(cg_relative) +
           " --start-smoothing " + std::to_string(start_smoothing) + " --method " + method;
  }
};

int run_case(const std::string& spec, LinearSolver linear, CgPreconditioner preconditioner, double ratio,
             const Tuning& tuning) {
  const TriMesh mesh = load_case_mesh(spec);
  GenerateOptions options;
  options.thickness = thickness_from_ratio(mesh.V, mesh.F, ratio);
  options.linear.kind = linear;
  options.linear.preconditioner = preconditioner;
  options.method = parse_shell_method(tuning.method);
  if (tuning.anderson >= 0) options.solve.anderson_history = tuning.anderson;
  if (tuning.cg_relative >= 0) options.linear.cg_relative_tolerance = tuning.cg_relative;
  if (tuning.start_smoothing >= 0) options.guard.start_smoothing = tuning.start_smoothing;
  const ProcessTimes before = process_times();
  const GenerateResult r = generate_shell(mesh.V, mesh.F, options);
  const ProcessTimes after = process_times();
  const double generate_cpu = after.cpu() - before.cpu();
  const double generate_peak = peak_megabytes(); // before the deformer, which runs beside the result
  const auto t0 = Clock::now();
  const double deform_cpu0 = process_times().cpu();
  double deform_factor = 0;
  {
    const ShellDeformer deformer(r.shell);
    deform_factor = deformer.factor_seconds();
  }
  const double deform_setup = seconds_since(t0), deform_cpu = process_times().cpu() - deform_cpu0;
  const int iterations = std::max(1, r.solve.iterations);
  const double curvature_seconds = r.curvature ? r.curvature->prism_seconds : 0.0;
  std::printf("vertices=%d total=%.6g setup=%.6g solve=%.6g iterations=%d per_iteration=%.6g cg=%d local=%.6g "
              "global=%.6g guard=%.6g curvature=%.6g "
              "deform_setup=%.6g deform_factor=%.6g deform_cpu=%.6g cpu=%.6g user=%.6g faults=%.6g generate_peak_mb=%.6g peak_mb=%.6g energy=%.10g stretch_mean=%.10g "
              "stretch_max=%.10g inverted=%d intersections=%d thickness_min=%.10g certificate=%.6g\n",
              static_cast<int>(mesh.V.rows()), r.seconds.total, r.seconds.factor, r.seconds.solve, r.solve.iterations,
              r.seconds.solve / iterations, r.solve.linear_iterations, r.solve.local_seconds, r.solve.global_seconds,
              r.seconds.guard, curvature_seconds, deform_setup, deform_factor, deform_cpu, generate_cpu,
              after.user - before.user, after.minor_faults - before.minor_faults,
              generate_peak, peak_megabytes(), r.solve.energy.back(), r.metrics.stretch.mean, r.metrics.stretch.max,
              r.metrics.certificate.inverted_tets,
              r.metrics.certificate.top_self_intersections + r.metrics.certificate.top_base_intersections,
              r.metrics.thickness_min, r.metrics.certificate.seconds);
  return 0;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

struct Row {
  std::string name, linear;
  std::map<std::string, std::vector<double>> values; // one per round
  /// Peak memory columns give the largest run's figure, the others the median.
  static bool takes_largest(const std::string& key) { return key.find("peak_mb") != std::string::npos; }
  double get(const std::string& key) const {
    auto it = values.find(key);
    if (it == values.end() || it->second.empty()) return 0;
    return takes_largest(key) ? *std::max_element(it->second.begin(), it->second.end()) : median(it->second);
  }
};

bool run_child(const std::string& self, const std::string& spec, const std::string& linear, double ratio,
               const Tuning& tuning, Row& row) {
  const std::string command =
      "'" + self + "' --case '" + spec + "' --linear " + linear + " --ratio " + std::to_string(ratio) + tuning.arguments();
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return false;
  std::string out;
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe)) out += buffer;
  if (pclose(pipe) != 0) {
    std::fprintf(stderr, "bench_scale: %s failed\n", command.c_str());
    return false;
  }
  for (const std::string& pair : split(out, ' ')) {
    const auto eq = pair.find('=');
    if (eq != std::string::npos) row.values[pair.substr(0, eq)].push_back(std::stod(pair.substr(eq + 1)));
  }
  return true;
}

} // namespace

constexpr const char* kUsage =
    "usage: bench_scale [--levels 6,7,8,9] [--mesh FILE]... [--subdivide K] [--no-mesh] [--linear auto,direct,cg,auto:jacobi] "
    "[--ratio 0.02] [--runs N] [--anderson K] [--cg-relative T] [--start-smoothing S] [--method rigid|curvature]\n";

int bench_main(int argc, char** argv) {
  std::vector<int> levels{6, 7, 8, 9};
  std::vector<std::string> meshes, linears{"auto"};
  double ratio = 0.02;
  int runs = 1;
  std::string case_spec;
  bool meshes_given = false;
  int subdivisions = 0;
  Tuning tuning;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench_scale: %s needs a value\n", a.c_str());
        std::exit(1);
      }
      return argv[++i];
    };
    if (a == "--levels") {
      levels.clear();
      for (const auto& s : split(next(), ',')) levels.push_back(std::stoi(s));
    } else if (a == "--mesh") {
      meshes.push_back(next());
      meshes_given = true;
    } else if (a == "--no-mesh") {
      meshes_given = true;
    } else if (a == "--linear") {
      linears = split(next(), ',');
    } else if (a == "--ratio") {
      ratio = std::stod(next());
    } else if (a == "--runs") {
      runs = std::max(1, std::stoi(next()));
    } else if (a == "--case") {
      case_spec = next();
    } else if (a == "--subdivide") {
      subdivisions = std::max(0, std::stoi(next()));
    } else if (a == "--anderson") {
      tuning.anderson = std::stoi(next());
    } else if (a == "--cg-relative") {
      tuning.cg_relative = std::stod(next());
    } else if (a == "--start-smoothing") {
      tuning.start_smoothing = std::stod(next());
    } else if (a == "--method") {
      tuning.method = next();
      parse_shell_method(tuning.method); // rejects an unknown name here, not in every child
    } else {
      std::fprintf(stderr, "bench_scale: unknown argument %s\n%s", a.c_str(), kUsage);
      return 1;
    }
  }
  if (!case_spec.empty()) {
    gshell::reuse_freed_memory(); // as the gshell CLI does
    // "auto", "cg", ... with the multigrid preconditioner; "auto:jacobi", "cg:jacobi" with Jacobi's.
    const std::vector<std::string> parts = split(linears.at(0), ':');
    const bool jacobi = parts.size() > 1 && parts[1] == "jacobi";
    if (parts.empty() || (parts.size() > 1 && !jacobi)) {
      std::fprintf(stderr, "bench_scale: unknown linear solver '%s'\n", linears.at(0).c_str());
      return 1;
    }
    return run_case(case_spec, parse_linear_solver(parts[0]), jacobi ? CgPreconditioner::Jacobi : CgPreconditioner::Multigrid,
                    ratio, tuning);
  }
  if (!meshes_given && std::filesystem::exists("models/bunny00.off")) meshes.push_back("models/bunny00.off");

  const std::string self = std::filesystem::canonical("/proc/self/exe").string();
  std::printf("bench_scale: %s generation at thickness ratio %g, medians of %d rounds of fresh processes; "
              "Anderson history %s, relative CG tolerance %s, start smoothing %s; load average at start %s; GLIBC_TUNABLES %s\n",
              tuning.method.c_str(), ratio, runs, tuning.anderson >= 0 ? std::to_string(tuning.anderson).c_str() : "default",
              tuning.cg_relative >= 0 ? std::to_string(tuning.cg_relative).c_str() : "default",
              tuning.start_smoothing >= 0 ? std::to_string(tuning.start_smoothing).c_str() : "default",
              load_average().c_str(), std::getenv("GLIBC_TUNABLES") ? std::getenv("GLIBC_TUNABLES") : "unset");
  std::vector<std::string> specs;
  for (int level : levels) specs.push_back("builtin:sphere:" + std::to_string(level));
  for (const std::string& mesh : meshes) {
    specs.push_back(mesh);
    for (int k = 1; k <= subdivisions; ++k) specs.push_back(mesh + "@" + std::to_string(k));
  }
  std::vector<Row> rows;
  for (const std::string& linear : linears)
    for (const std::string& spec : specs) rows.push_back(Row{spec, linear, {}});
  std::vector<char> failed(rows.size(), 0);
  for (int run = 0; run < runs; ++run)
    for (std::size_t r = 0; r < rows.size(); ++r) {
      if (failed[r]) continue;
      if (runs > 1) std::fprintf(stderr, "bench_scale: round %d/%d %s\n", run + 1, runs, display_name(rows[r].name).c_str());
      failed[r] = !run_child(self, rows[r].name, rows[r].linear, ratio, tuning, rows[r]);
    }
  for (std::size_t r = rows.size(); r-- > 0;)
    if (failed[r]) rows.erase(rows.begin() + static_cast<std::ptrdiff_t>(r));
  std::printf("%-22s %-11s %9s %8s %8s %8s %4s %9s %5s %8s %8s %8s %8s %8s %8s %8s %8s %8s %8s %8s %8s %8s %11s %11s %11s %4s "
              "%4s\n",
              "mesh", "linear", "vertices", "total_s", "setup_s", "solve_s", "its", "per_it_s", "cg", "local_s", "global_s",
              "guard_s", "curv_s", "cert_s", "deform_s",
              "dfm_cpu", "cpu_s", "usr_s", "faults_k", "gen_MB", "peak_MB", "KB/vert", "energy", "stretch", "stretch_max", "inv", "isct");
  for (const Row& row : rows) {
    const std::string name = display_name(row.name);
    std::printf("%-22s %-11s %9.0f %8.3f %8.3f %8.3f %4.0f %9.4f %5.0f %8.3f %8.3f %8.3f %8.3f %8.3f %8.3f %8.2f %8.2f %8.2f %8.0f %8.0f %8.0f %8.2f %11.6g %11.6g %11.6g "
                "%4.0f "
                "%4.0f\n",
                name.c_str(), row.linear.c_str(), row.get("vertices"), row.get("total"), row.get("setup"), row.get("solve"),
                row.get("iterations"), row.get("per_iteration"), row.get("cg"), row.get("local"),
                row.get("global"), row.get("guard"), row.get("curvature"), row.get("certificate"), row.get("deform_setup"), row.get("deform_cpu"), row.get("cpu"),
                row.get("user"), row.get("faults") / 1000, row.get("generate_peak_mb"), row.get("peak_mb"), 1024.0 * row.get("peak_mb") / row.get("vertices"), row.get("energy"),
                row.get("stretch_mean"), row.get("stretch_max"), row.get("inverted"), row.get("intersections"));
  }

  std::printf("\ngrowth per 4x vertices (consecutive sphere levels and midpoint splits; target <= 4.6):\n");
  std::printf("%-22s %-11s %8s %8s %8s %8s %8s %8s %8s %8s %8s\n", "step", "linear", "total", "setup", "per_it", "deform",
              "dfm_cpu", "cpu", "usr", "gen_MB", "peak_MB");
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const Row &a = rows[i - 1], &b = rows[i];
    if (a.linear != b.linear || family(a.name) != family(b.name)) continue;
    // Peak memory compares the largest runs (as printed); the other columns pair the two cases'
    // runs round by round.
    auto ratio_of = [&](const char* key) {
      if (Row::takes_largest(key)) return a.get(key) > 0 ? b.get(key) / a.get(key) : 0.0;
      const auto x = a.values.find(key), y = b.values.find(key);
      std::vector<double> ratios;
      for (std::size_t k = 0; x != a.values.end() && y != b.values.end() && k < std::min(x->second.size(), y->second.size()); ++k)
        if (x->second[k] > 0) ratios.push_back(y->second[k] / x->second[k]);
      return median(std::move(ratios));
    };
    const std::string step = display_name(a.name) + " -> " + display_name(b.name);
    std::printf("%-22s %-11s %8.2f %8.2f %8.2f %8.2f %8.2f %8.2f %8.2f %8.2f %8.2f\n", step.c_str(), b.linear.c_str(),
                ratio_of("total"), ratio_of("setup"), ratio_of("per_iteration"), ratio_of("deform_setup"),
                ratio_of("deform_cpu"), ratio_of("cpu"), ratio_of("user"), ratio_of("generate_peak_mb"), ratio_of("peak_mb"));
  }
  std::printf("load average at end %s\n", load_average().c_str());
  return 0;
}

int main(int argc, char** argv) {
  gshell::restart_with_huge_pages(argv); // as the gshell CLI does; the cases inherit it
  return gshell::bench::run_benchmark(argc, argv, kUsage, bench_main);
}
