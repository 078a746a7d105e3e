// bench_pose: direct shell deformation, hierarchical vs single-level solver (paper §5's claim of a
// > 10x speed-up). Measures wall time and iterations until E <= 1.001 E*, E* = the single-level
// (ShellSolver) minimum, for one big move from rest and for every step of a K-step drag.
//
//   bench_pose [bowl | PATH.off] [--steps K] [--runs R] [--drag-runs R] [--thickness-ratio r]
//              [--reference-iterations N] [--cap N] [--drag-cap N] [--drag-every N]
//              [--reference-cache FILE] [--only CONFIG]... [--config SPEC]...
//
// --config runs an extra hierarchical configuration given as key=value pairs (see parse_config).
//
//   bench_pose --table [--runs R] [--cap N] [--cache-dir DIR] [--case LABEL]... [--config SPEC]...
//                      [--only-extra] [--model PATH]... [--bunny PATH] [--examples DIR]
//                      [--model-cap N] [--model-reference-iterations N] [--settle-tolerance T]
//                      [--explain-stalls]
//
// --table: one table of time to 1.001 E* from rest for single, single+Anderson, single+Anderson+
// path search and hierarchical (and any --config) on the bowl at thickness ratios 0.02 and 0.05
// under the pulls examples/bowl_{pull,twist,half_pull,squeeze_soft}.json, and on bunny00 (and any
// --model) with the generic pull. E* of a case is the lowest minimum any solver reaches from rest
// (a pull can have several: the twist does): every run goes on past 1.001 E* until it settles, and
// the table says where each settled and which solver found E*. Prints shell sizes, iterations /
// median seconds, speed-ups and the coarse passes kept (ms per pass / per full iteration / per
// path search).
// --explain-stalls: for every run that misses 1.001 E* (and kept its state: all but those stopped
// near the reference), continue single-level from its state to convergence and print where that
// settles and how far it lies from the E* state.
//
// The reference is the single-level fixed point computed with Anderson acceleration (the same
// minimum as plain local/global, reached much sooner), to relative change < 1e-10 or N
// iterations; --reference-cache keeps it in a file between runs. --drag-every N times only every
// N-th drag step (all steps are still solved for the references).
//
// Shell: generate_shell, method rigid (normal prisms), eta = r * bounding radius (default r = 0.02).
// Handles (hard): bowl: hold the rim on one side (x < -0.5, z > -0.15 R, both surfaces), pull the
// rim on the other side (x > 0.7 R) by R * (0.8, 0.2, 0.5) (|move| = 0.97 R; the small sideways
// part picks one of the two mirror-image buckled shapes). Other models: hold the lowest 8% along
// y, pull the highest 8% by R * (0.5, 0.1, 0.3).
// Drag protocol: step k starts every solver from the reference states of steps k-1 and k-2 (their
// motion continued, PoseSolver::predict_start, timed; --no-extrapolate: from step k-1's state),
// so all solvers are timed on the same problems; the hierarchical solver's levels carry over.
#include "bench_common.h"

#include <gshell/deform/handles.h>
#include <gshell/deform/pose.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/io/load_mesh.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/solver/shell_solver.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

using namespace gshell;
using gshell::bench::median;

namespace {

Shell make_shell(const TriMesh& mesh, double ratio) {
  GenerateOptions options;
  options.method = ShellMethod::Rigid;
  options.thickness = thickness_from_ratio(mesh.V, ratio);
  options.count_intersections = false;
  return generate_shell(mesh.V, mesh.F, options).shell;
}

struct Config {
  std::string name;
  PoseSolverKind kind;
  HierarchyOptions options;
};

/// Iterations and seconds until E <= goal from X0 (or the cap; reached = false).
struct Reach {
  bool reached = false;
  int iterations = 0;
  double seconds = 0;
  double energy = 0; ///< at the end (when not reached)
  double cpu = 0;    ///< CPU seconds (--table runs only)
};

/// Thrown from the progress callback to end a solve at the first iteration that reaches the goal
/// (so a slow solver is not run past it and accelerators keep their history).
struct GoalReached {
  int iteration;
  double seconds;
};

/// Iterations and seconds (the solver's own clock) until E <= goal from X0, or the cap.
/// `final_state` (when given) receives the state the solve ended in.
Reach time_to_goal(PoseSolver& solver, const Eigen::MatrixXd& X0, double fraction, double goal, int cap,
                   Eigen::MatrixXd* final_state = nullptr) {
  Eigen::MatrixXd X = X0;
  struct Keep {
    Eigen::MatrixXd* out;
    const Eigen::MatrixXd& X;
    ~Keep() { if (out) *out = X; }
  } keep{final_state, X};
  SolveOptions so;
  so.max_iterations = cap;
  so.tolerance = 0;
  so.progress = [&](int it, double e, double sec) {
    if (e <= goal) throw GoalReached{it, sec};
  };
  try {
    const SolveResult res = solver.solve(X, fraction, so);
    return {false, res.iterations, res.seconds, res.energy.empty() ? 0.0 : res.energy.back()};
  } catch (const GoalReached& g) {
    return {true, g.iteration, g.seconds, goal};
  }
}

/// A hierarchical configuration from "levels=5,split=2,li=10,fi=1,aa=5,laa=5,fas=1,cr=1,fcs=8,top=8,lt=0,min=8,hw=100,
/// period=4,path=1,fc=10"
/// (any subset; the rest keep their defaults).
Config parse_config(const std::string& spec) {
  Config c{"hierarchical " + spec, PoseSolverKind::Hierarchical, {}};
  size_t pos = 0;
  while (pos < spec.size()) {
    const size_t comma = std::min(spec.find(',', pos), spec.size());
    const std::string item = spec.substr(pos, comma - pos);
    pos = comma + 1;
    const size_t eq = item.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = item.substr(0, eq);
    const double value = std::atof(item.substr(eq + 1).c_str());
    HierarchyOptions& o = c.options;
    if (key == "levels") o.levels = static_cast<int>(value);
    else if (key == "split") o.splits_per_level = static_cast<int>(value);
    else if (key == "li") o.level_iterations = static_cast<int>(value);
    else if (key == "fi") o.full_iterations = static_cast<int>(value);
    else if (key == "aa") o.anderson_history = static_cast<int>(value);
    else if (key == "fas") o.residual_correction = value != 0;
    else if (key == "lt") o.level_tolerance = value;
    else if (key == "min") o.min_cluster_size = static_cast<int>(value);
    else if (key == "hw") o.reduced_hard_weight = value;
    else if (key == "cr") o.cluster_rotations = value != 0;
    else if (key == "fcs") o.finest_cluster_size = static_cast<int>(value);
    else if (key == "top") o.coarsest_clusters = static_cast<int>(value);
    else if (key == "laa") o.level_anderson_history = static_cast<int>(value);
    else if (key == "period") o.coarse_period = static_cast<int>(value);
    else if (key == "path") o.path_extrapolation = value != 0;
    else if (key == "fc") o.first_coarse_iteration = static_cast<int>(value);
    else std::fprintf(stderr, "bench_pose: unknown key %s\n", key.c_str());
  }
  return c;
}


// ---- --table: time to 1.001 E* on several pulls, thicknesses and models, one table -------------

struct TableCase {
  std::string name;     ///< pull name (a handle file in --examples, or "pull" = the built-in pull)
  std::string model;    ///< "bowl" or a mesh path
  double ratio;         ///< thickness / bounding radius
};

/// Single level + Anderson(5) from X (from rest when `from_rest`) to relative change < 1e-10 or
/// `iterations`: how the references are computed.
SolveResult settle_single_level(const Shell& shell, const HandleSet& handles, Eigen::MatrixXd& X, int iterations,
                                bool from_rest) {
  HierarchyOptions o;
  o.levels = 1;
  o.anderson_history = 5;
  o.path_extrapolation = false;
  PoseSolver reference(shell, handles, PoseSolverKind::Hierarchical, o);
  if (from_rest) X = reference.rest_vertices();
  SolveOptions so;
  so.max_iterations = iterations;
  so.tolerance = 1e-10;
  return reference.solve(X, 1.0, so);
}

/// Where a hierarchical run that did not reach 1.001 E* stopped: the single-level solver goes on
/// from its state to convergence; if it stays above E*, the hierarchy found another stationary
/// state of the same energy (not a flaw of its levels). Prints that energy and how far the state
/// lies from the reference minimum (largest vertex distance, in shell thicknesses).
void explain_stall(const Shell& shell, const HandleSet& handles, const std::string& label, double Estar,
                   Eigen::MatrixXd X, int iterations) {
  const double stalled = PoseSolver(shell, handles, PoseSolverKind::Single).energy(X, 1.0);
  const SolveResult on = settle_single_level(shell, handles, X, iterations, false);
  Eigen::MatrixXd Xstar;
  settle_single_level(shell, handles, Xstar, iterations, true);
  const double distance = (X - Xstar).rowwise().norm().maxCoeff() / shell.thickness;
  std::printf("stall %s: hierarchical stopped at %.5f E*; single level + Anderson from there settles at %.5f E* after %d "
              "iterations (%s); that state is up to %.2f shell thicknesses from the E* state\n",
              label.c_str(), stalled / Estar, on.energy.back() / Estar, on.iterations,
              on.converged ? "converged" : "cap", distance);
}

/// E* of a case: single level + Anderson(5) to relative change < 1e-10 (or `iterations`), kept in
/// `cache_dir` (when given) under a name holding the case and the shell's size.
double table_reference(const Shell& shell, const HandleSet& handles, const std::string& key, const std::string& cache_dir,
                       int iterations) {
  const std::string path = cache_dir.empty() ? "" : cache_dir + "/" + key + ".ref";
  if (!path.empty()) {
    std::ifstream in(path);
    double e = 0;
    if (in >> e && e > 0) return e;
  }
  Eigen::MatrixXd X;
  const SolveResult r = settle_single_level(shell, handles, X, iterations, true);
  std::fprintf(stderr, "bench_pose: %s: E* = %.10g after %d reference iterations (%s)\n", key.c_str(), r.energy.back(),
               r.iterations, r.converged ? "converged" : "iteration cap");
  if (!path.empty()) {
    std::ofstream out(path);
    out.precision(17);
    out << r.energy.back() << "\n";
  }
  return r.energy.back();
}

/// One table run: a solve from rest with the energy and the solver's clock after every outer
/// iteration, so that time to 1.001 E* can be read off once E* is known (E* is the lowest minimum
/// any solver reaches, known only after all of them ran).
struct Trajectory {
  /// [k]: after outer iteration k (k = 0: the start, 0 s); seconds = the solver's wall clock, cpu =
  /// this process's CPU time since the solve began (all threads; steadier than wall time on a
  /// loaded machine).
  std::vector<double> energy, seconds, cpu;
  bool converged = false;              ///< stopped by settling (not by the cap)
  Eigen::MatrixXd final_state;
};

double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// Thrown from the progress callback once a run has settled.
struct Settled {};

/// Runs `solver` from rest until it settles or `cap` outer iterations: settled = relative energy
/// change of one outer iteration below `tolerance` (the solver's own test), or below 1e-6 within
/// [0.9999, 1.001] `reference` (then it is in the reference's basin and only creeps to its bottom;
/// a run heading for a lower minimum still moves faster than that when it passes 1.001 E_ref).
Trajectory run_trajectory(PoseSolver& solver, double reference, int cap, double tolerance) {
  Trajectory t;
  Eigen::MatrixXd X = solver.rest_vertices();
  // The start (rest, handles not yet at their targets) counts as not reached.
  t.energy.push_back(std::numeric_limits<double>::infinity());
  t.seconds.push_back(0);
  t.cpu.push_back(0);
  const double cpu0 = process_cpu_seconds();
  SolveOptions so;
  so.max_iterations = cap;
  so.tolerance = tolerance;
  so.progress = [&](int, double e, double sec) {
    const double previous = t.energy.back();
    t.energy.push_back(e);
    t.seconds.push_back(sec);
    t.cpu.push_back(process_cpu_seconds() - cpu0);
    if (e <= 1.001 * reference && e >= (1 - 1e-4) * reference && previous - e < 1e-6 * previous) throw Settled{};
  };
  try {
    t.converged = solver.solve(X, 1.0, so).converged;
    t.final_state = X;
  } catch (const Settled&) {
    // Only within 1.001 E_ref (the single-level solver does not hand out its state when the
    // callback throws; the final state is needed only for runs that end below the reference).
    t.converged = true;
  }
  return t;
}

/// The first iteration of `t` with E <= goal (reached = false: none).
Reach reach_in(const Trajectory& t, double goal) {
  for (size_t k = 0; k < t.energy.size(); ++k)
    if (t.energy[k] <= goal) return {true, static_cast<int>(k), t.seconds[k], t.energy[k], t.cpu[k]};
  return {false, static_cast<int>(t.energy.size()) - 1, t.seconds.back(), t.energy.back(), t.cpu.back()};
}

struct TableCell {
  Trajectory trajectory;      ///< of the first run
  Reach reach;                ///< to 1.001 E* (iterations do not vary between runs)
  double seconds = 0;         ///< median over the runs
  double setup = 0;           ///< PoseSolver construction, median
  HierarchyCounters counters; ///< hierarchical only: first run
};

int run_table(const std::vector<std::string>& args) {
  int runs = 1, cap = 3000, reference_iterations = 6000;
  int model_cap = -1, model_reference_iterations = -1; // for the mesh cases (--model, bunny); -1: as the bowl's
  double settle_tolerance = 1e-9;
  std::string examples = "examples", bunny = "models/bunny00.off", cache_dir;
  std::vector<std::string> only_cases;
  std::vector<Config> extra;
  bool only_extra = false; // development: only the --config columns, no speed-ups
  bool explain_stalls = false;
  bool bowl_cases = true;
  std::vector<std::string> models; // more meshes with the generic pull, ratio 0.01
  for (size_t i = 0; i < args.size(); ++i) {
    auto next = [&] { return i + 1 < args.size() ? args[++i] : std::string(); };
    if (args[i] == "--runs") runs = std::max(1, std::atoi(next().c_str()));
    else if (args[i] == "--cap") cap = std::atoi(next().c_str());
    else if (args[i] == "--reference-iterations") reference_iterations = std::atoi(next().c_str());
    else if (args[i] == "--model-cap") model_cap = std::atoi(next().c_str());
    else if (args[i] == "--model-reference-iterations") model_reference_iterations = std::atoi(next().c_str());
    else if (args[i] == "--settle-tolerance") settle_tolerance = std::atof(next().c_str());
    else if (args[i] == "--examples") examples = next();
    else if (args[i] == "--bunny") bunny = next();
    else if (args[i] == "--cache-dir") cache_dir = next();
    else if (args[i] == "--case") only_cases.push_back(next());
    else if (args[i] == "--config") extra.push_back(parse_config(next()));
    else if (args[i] == "--only-extra") only_extra = true;
    else if (args[i] == "--explain-stalls") explain_stalls = true;
    else if (args[i] == "--model") models.push_back(next());
    else if (args[i] == "--no-bowl") bowl_cases = false;
    else {
      std::fprintf(stderr, "bench_pose --table: unknown argument %s\n", args[i].c_str());
      return 1;
    }
  }
  std::vector<TableCase> cases;
  for (double ratio : {0.02, 0.05})
    for (const char* pull : {"bowl_pull", "bowl_twist", "bowl_half_pull", "bowl_squeeze_soft"})
      if (bowl_cases) cases.push_back({pull, "bowl", ratio});
  for (const std::string& m : models) cases.push_back({"pull", m, 0.01});
  if (std::ifstream(bunny)) cases.push_back({"pull", bunny, 0.01});
  else std::printf("(%s not found: bunny case skipped; scripts/fetch-models)\n", bunny.c_str());

  std::vector<Config> configs;
  if (!only_extra) {
    configs.push_back({"single", PoseSolverKind::Single, {}});
    HierarchyOptions o;
    o.levels = 1;
    o.path_extrapolation = false;
    configs.push_back({"single+AA", PoseSolverKind::Hierarchical, o});
    o.path_extrapolation = true;
    configs.push_back({"single+AA+path", PoseSolverKind::Hierarchical, o});
    configs.push_back({"hierarchical", PoseSolverKind::Hierarchical, HierarchyOptions{}});
  }
  for (Config c : extra) configs.push_back(c);
  const size_t first_ratio = only_extra ? configs.size() : 3; // configurations compared with the first three

  std::printf("bench_pose --table: time to E <= 1.001 E* from rest (one big move), median of %d run(s). E* of a case = "
              "the lowest minimum any solver reaches from rest: the reference (single level + Anderson(5) to relative "
              "change < 1e-10) or a lower one a solver settles in. Runs go on past 1.001 E* until they settle "
              "(relative change < %.0e, or < 1e-6 within 1.001 E_ref) or the cap: %d iterations (mesh cases: %d, "
              "reference after at most %d)\n",
              runs, settle_tolerance, cap, model_cap > 0 ? model_cap : cap,
              model_reference_iterations > 0 ? model_reference_iterations : reference_iterations);
  std::printf("threads: TBB default; load at start: ");
  if (std::ifstream load("/proc/loadavg"); load) {
    std::string l1, l5, l15;
    load >> l1 >> l5 >> l15;
    std::printf("%s %s %s (1/5/15 min)\n", l1.c_str(), l5.c_str(), l15.c_str());
  } else {
    std::printf("unknown\n");
  }

  struct Row {
    std::string label;
    int vertices = 0;
    double Estar = 0, Eref = 0;
    std::string found_by = "reference"; ///< who reached E*
    std::vector<TableCell> cells;
  };
  std::vector<Row> rows;
  for (const TableCase& tc : cases) {
    const bool bowl = tc.model == "bowl";
    char ratio_text[32];
    std::snprintf(ratio_text, sizeof ratio_text, "%.2f", tc.ratio);
    std::string stem = tc.model;
    stem = stem.substr(stem.find_last_of('/') + 1);
    stem = stem.substr(0, stem.find_last_of('.'));
    const std::string label = stem + " " + std::string(ratio_text) + " " + tc.name;
    if (!only_cases.empty() && std::find(only_cases.begin(), only_cases.end(), label) == only_cases.end()) continue;
    const TriMesh mesh = bowl ? make_bowl() : load_mesh(tc.model);
    const Shell shell = make_shell(mesh, tc.ratio);
    const HandleSet handles = bowl ? read_handles(examples + "/" + tc.name + ".json", shell) : bench::pull_handles(shell, false);
    std::string key = label;
    std::replace(key.begin(), key.end(), ' ', '_');
    key += "_" + std::to_string(2 * shell.num_base_vertices());
    const int case_cap = !bowl && model_cap > 0 ? model_cap : cap;
    const int case_reference_iterations =
        !bowl && model_reference_iterations > 0 ? model_reference_iterations : reference_iterations;
    const double Eref = table_reference(shell, handles, key, cache_dir, case_reference_iterations);
    Row row{label, 2 * shell.num_base_vertices(), Eref, Eref, "reference", {}};
    for (const Config& c : configs) {
      TableCell cell;
      PoseSolver solver(shell, handles, c.kind, c.options);
      cell.setup = solver.setup_seconds();
      cell.trajectory = run_trajectory(solver, Eref, case_cap, settle_tolerance);
      if (solver.hierarchical()) {
        cell.counters = solver.hierarchical()->counters();
        const HierarchyCounters& h = cell.counters;
        // Where the energy went (relative to E_ref) and what each part cost: the hierarchy's ledger.
        if (h.coarse_passes > 0)
          std::fprintf(stderr, "bench_pose: %s, %s: coarse %d/%d kept, drop %.4g E_ref in %.3f s; full %d it., drop %.4g E_ref "
                       "in %.3f s; path drop %.4g E_ref in %.3f s\n", label.c_str(), c.name.c_str(), h.coarse_accepted,
                       h.coarse_passes, h.coarse_decrease / Eref, h.coarse_seconds, h.full_iterations,
                       h.full_decrease / Eref, h.full_seconds, h.path_decrease / Eref, h.path_seconds);
      }
      const double end = cell.trajectory.energy.back();
      std::fprintf(stderr, "bench_pose: %s, %s: ends at %.5f E_ref after %d iterations (%s), %.3f s\n", label.c_str(),
                   c.name.c_str(), end / Eref, static_cast<int>(cell.trajectory.energy.size()) - 1,
                   cell.trajectory.converged ? "settled" : "cap", cell.trajectory.seconds.back());
      // A run ending clearly below the reference found a lower minimum: settle it there (single
      // level + Anderson from its state) for that minimum's energy.
      if (end < (1 - 1e-4) * row.Estar && cell.trajectory.final_state.size() > 0) {
        Eigen::MatrixXd X = cell.trajectory.final_state;
        const SolveResult settled = settle_single_level(shell, handles, X, case_reference_iterations, false);
        row.Estar = std::min(end, settled.energy.back());
        row.found_by = c.name;
      }
      row.cells.push_back(std::move(cell));
    }
    const double goal = 1.001 * row.Estar;
    for (size_t k = 0; k < configs.size(); ++k) {
      TableCell& cell = row.cells[k];
      cell.reach = reach_in(cell.trajectory, goal);
      std::vector<double> seconds, setups{cell.setup};
      if (cell.reach.reached) seconds.push_back(cell.reach.seconds);
      for (int r = 1; r < runs && cell.reach.reached; ++r) {
        PoseSolver solver(shell, handles, configs[k].kind, configs[k].options);
        setups.push_back(solver.setup_seconds());
        seconds.push_back(time_to_goal(solver, solver.rest_vertices(), 1.0, goal, case_cap).seconds);
      }
      cell.seconds = median(seconds);
      cell.setup = median(setups);
      if (!cell.reach.reached && cell.trajectory.final_state.size() > 0 && explain_stalls)
        explain_stall(shell, handles, label + ", " + configs[k].name, row.Estar, cell.trajectory.final_state,
                      case_reference_iterations);
      cell.trajectory.final_state.resize(0, 0);
    }
    rows.push_back(std::move(row));
  }

  // One table: per case and configuration, iterations / median seconds to 1.001 E* and where the
  // run settled (E / E*); speed-ups of the last configurations over single, single+AA and
  // single+AA+path.
  std::printf("\n| case | shell vertices | E* found by |");
  for (const Config& c : configs) std::printf(" %s: it. / s / CPU s (settles at E/E*) |", c.name.c_str());
  for (size_t k = first_ratio; k < configs.size(); ++k)
    std::printf(" %s vs single / +AA / +AA+path (CPU s) |", configs[k].name.c_str());
  std::printf(" coarse passes kept |");
  std::printf("\n|---|---|---|");
  for (size_t k = 0; k < configs.size(); ++k) std::printf("---|");
  for (size_t k = first_ratio; k < configs.size(); ++k) std::printf("---|");
  std::printf("---|\n");
  for (const Row& row : rows) {
    std::printf("| %s | %d | %s", row.label.c_str(), row.vertices, row.found_by.c_str());
    if (row.Estar < row.Eref) std::printf(" (reference %.4f E*)", row.Eref / row.Estar);
    std::printf(" |");
    for (const TableCell& cell : row.cells) {
      const double end = cell.trajectory.energy.back() / row.Estar;
      const char* how = cell.trajectory.converged ? "" : ", cap";
      if (cell.reach.reached)
        std::printf(" %d / %.3f / %.3f (%.4f%s) |", cell.reach.iterations, cell.seconds, cell.reach.cpu, end, how);
      else std::printf(" >%d (%.4f%s) |", cell.reach.iterations, end, how);
    }
    for (size_t k = first_ratio; k < row.cells.size(); ++k) {
      const TableCell& h = row.cells[k];
      // A run still moving at its cap took at least its CPU time so far: the speed-up is then a
      // bound. A run that settled in another minimum never gets there: no speed-up (nor when both
      // are still moving).
      auto ratio = [&](const TableCell& base) -> std::string {
        char text[32];
        const bool base_capped = !base.reach.reached && !base.trajectory.converged;
        const bool h_capped = !h.reach.reached && !h.trajectory.converged;
        if (base.reach.reached && h.reach.reached) std::snprintf(text, sizeof text, "%.1fx", base.reach.cpu / h.reach.cpu);
        else if (base_capped && h.reach.reached) std::snprintf(text, sizeof text, ">%.1fx", base.reach.cpu / h.reach.cpu);
        else if (h_capped && base.reach.reached) std::snprintf(text, sizeof text, "<%.1fx", base.reach.cpu / h.reach.cpu);
        else std::snprintf(text, sizeof text, "-");
        return text;
      };
      if (only_extra) std::printf(" |");
      else
        std::printf(" %s / %s / %s |", ratio(row.cells[0]).c_str(), ratio(row.cells[1]).c_str(),
                    ratio(row.cells[2]).c_str());
    }
    std::printf(" ");
    for (const TableCell& cell : row.cells)
      if (cell.counters.coarse_passes > 0)
        std::printf("%d/%d (%.0f/%.0f/%.0f ms) ", cell.counters.coarse_accepted, cell.counters.coarse_passes,
                    1e3 * cell.counters.coarse_seconds / cell.counters.coarse_passes,
                    1e3 * cell.counters.full_seconds / std::max(1, cell.counters.full_iterations),
                    1e3 * cell.counters.path_seconds / std::max(1, cell.counters.outer_iterations));
    std::printf("|\n");
  }
  std::printf("\n(E/E* in parentheses: where the run settled; above 1.001 and settled = another local minimum; "
              "'cap' = still moving at the cap. Speed-ups: '>x' / '<x' = a bound, one of the two runs still moving at its cap; "
              "'-' = no bound (one of them settled in another minimum, or both still moving). Coarse passes kept: accepted/run (ms per pass / per full iteration / "
              "per path search), over the whole run.)\n");
  std::printf("setup (s) of the last configuration (tree, assembly, factorisations):");
  for (const Row& row : rows) std::printf(" %s %.3f;", row.label.c_str(), row.cells.back().setup);
  std::printf("\n");
  return 0;
}

} // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  if (argc > 1 && std::string(argv[1]) == "--table") return run_table(std::vector<std::string>(argv + 2, argv + argc));
  std::string model = "bowl";
  int steps = 30, runs = 3, drag_runs = 1, reference_iterations = 3000, cap = 2000, drag_cap = 600, drag_every = 3;
  double ratio = 0.02;
  bool extrapolate = true; // drag steps start from the previous steps' motion continued
  std::vector<std::string> only;
  std::vector<Config> extra; // --config SPEC
  std::string cache_path; // references are slow: keep them between runs of the benchmark
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&] { return std::string(i + 1 < argc ? argv[++i] : ""); };
    if (a == "--steps") steps = std::atoi(next().c_str());
    else if (a == "--runs") runs = std::atoi(next().c_str());
    else if (a == "--thickness-ratio") ratio = std::atof(next().c_str());
    else if (a == "--reference-iterations") reference_iterations = std::atoi(next().c_str());
    else if (a == "--reference-cache") cache_path = next();
    else if (a == "--drag-runs") drag_runs = std::atoi(next().c_str());
    else if (a == "--drag-cap") drag_cap = std::atoi(next().c_str());
    else if (a == "--drag-every") drag_every = std::max(1, std::atoi(next().c_str()));
    else if (a == "--no-extrapolate") extrapolate = false;
    else if (a == "--no-drag") drag_runs = 0;
    else if (a == "--no-big") runs = 0;
    else if (a == "--cap") cap = std::atoi(next().c_str());
    else if (a == "--only") only.push_back(next());
    else if (a == "--config") extra.push_back(parse_config(next()));
    else model = a;
  }
  const bool bowl = model == "bowl";
  std::printf("drag steps start %s\n", extrapolate ? "from the previous motion continued" : "from the previous state");
  std::printf("bench_pose: big move median of %d runs, drag %d run(s); reference = single level + Anderson(5) to relative change < 1e-10 or %d iterations\n",
              runs, drag_runs, reference_iterations);
  const TriMesh mesh = bowl ? make_bowl() : load_mesh(model);
  const Shell shell = make_shell(mesh, ratio);
  const HandleSet handles = bench::pull_handles(shell, bowl);
  const int n = shell.num_base_vertices();
  std::printf("model %s: %d shell vertices, %d tets, thickness %.4g (ratio %.3g), handle vertices %zu + %zu\n",
              model.c_str(), 2 * n, 3 * static_cast<int>(shell.F.rows()), shell.thickness, ratio,
              handles.handles[0].vertices.size(), handles.handles[1].vertices.size());

  std::vector<Config> configs;
  configs.push_back({"single (ShellSolver)", PoseSolverKind::Single, {}});
  {
    HierarchyOptions o; // the same fixed-point iteration as ShellSolver, Anderson-accelerated
    o.levels = 1;
    o.full_iterations = 1;
    o.anderson_history = 5;
    o.path_extrapolation = false;
    configs.push_back({"single + Anderson(5)", PoseSolverKind::Hierarchical, o});
    o.path_extrapolation = true; // the hierarchical default's accelerations without the reduced levels
    configs.push_back({"single + Anderson(5) + path search", PoseSolverKind::Hierarchical, o});
  }
  {
    HierarchyOptions o; // the paper's recipe: own parameters, rigid propagation, ~5 iterations per level
    o.residual_correction = false;
    o.cluster_rotations = false; // border tets get their own rotations
    o.level_iterations = 5;
    o.full_iterations = 1;
    o.coarse_period = 1;
    o.anderson_history = 0;
    o.level_anderson_history = 0;
    o.path_extrapolation = false;
    configs.push_back({"hierarchical, paper coupling", PoseSolverKind::Hierarchical, o});
  }
  {
    HierarchyOptions o;
    o.anderson_history = 0;
    o.level_anderson_history = 0;
    configs.push_back({"hierarchical, no Anderson", PoseSolverKind::Hierarchical, o});
  }
  configs.push_back({"hierarchical (default)", PoseSolverKind::Hierarchical, HierarchyOptions{}});
  for (const Config& c : extra) {
    configs.push_back(c);
    only.push_back(c.name); // --config runs only what is asked (plus any --only)
  }

  // ---- references: single-level runs to convergence ----
  HierarchyOptions reference_options;
  reference_options.levels = 1;
  reference_options.anderson_history = 5;
  reference_options.path_extrapolation = false;
  PoseSolver reference(shell, handles, PoseSolverKind::Hierarchical, reference_options);
  SolveOptions ref_options;
  ref_options.max_iterations = reference_iterations;
  ref_options.tolerance = 1e-10;
  std::vector<Eigen::MatrixXd> Xref(steps + 1);
  std::vector<double> Eref(steps + 1);
  double Ebig = 0;
  Xref[0] = reference.rest_vertices();
  std::ifstream cached(cache_path, std::ios::binary);
  if (!cache_path.empty() && cached) {
    int cached_steps = 0;
    cached.read(reinterpret_cast<char*>(&cached_steps), sizeof cached_steps);
    cached.read(reinterpret_cast<char*>(&Ebig), sizeof Ebig);
    if (cached_steps != steps) {
      std::fprintf(stderr, "bench_pose: %s holds %d steps, not %d\n", cache_path.c_str(), cached_steps, steps);
      return 1;
    }
    for (int k = 1; k <= steps; ++k) {
      Xref[k].resize(Xref[0].rows(), 3);
      cached.read(reinterpret_cast<char*>(&Eref[k]), sizeof(double));
      cached.read(reinterpret_cast<char*>(Xref[k].data()), static_cast<std::streamsize>(sizeof(double) * Xref[k].size()));
    }
    std::printf("references read from %s: E*(big move) = %.8g, E*_K = %.8g\n", cache_path.c_str(), Ebig, Eref[steps]);
  } else {
    Eigen::MatrixXd Xbig = reference.rest_vertices();
    SolveResult rb = reference.solve(Xbig, 1.0, ref_options);
    Ebig = rb.energy.back();
    std::printf("reference big move: E* = %.8g after %d reference iterations (%s, %.1f s)\n", Ebig, rb.iterations,
                rb.converged ? "converged" : "iteration cap", rb.seconds);
    int ref_total = 0;
    for (int k = 1; k <= steps; ++k) {
      Xref[k] = Xref[k - 1];
      SolveResult r = reference.solve(Xref[k], static_cast<double>(k) / steps, ref_options);
      Eref[k] = r.energy.back();
      ref_total += r.iterations;
      std::printf("  reference step %d: E* = %.8g, %d iterations%s\n", k, Eref[k], r.iterations, r.converged ? "" : " (cap)");
    }
    std::printf("reference drag: %d steps, %d reference iterations in all, E*_K = %.8g\n", steps, ref_total, Eref[steps]);
    if (!cache_path.empty()) {
      std::ofstream out(cache_path, std::ios::binary);
      out.write(reinterpret_cast<const char*>(&steps), sizeof steps);
      out.write(reinterpret_cast<const char*>(&Ebig), sizeof Ebig);
      for (int k = 1; k <= steps; ++k) {
        out.write(reinterpret_cast<const char*>(&Eref[k]), sizeof(double));
        out.write(reinterpret_cast<const char*>(Xref[k].data()), static_cast<std::streamsize>(sizeof(double) * Xref[k].size()));
      }
    }
  }

  for (const Config& c : configs) {
    if (!only.empty() && std::find(only.begin(), only.end(), c.name) == only.end()) continue;
    // Big move from rest, `runs` times with a fresh solver.
    std::vector<double> big_seconds;
    Reach big;
    double setup = 0;
    for (int r = 0; r < runs; ++r) {
      PoseSolver s(shell, handles, c.kind, c.options);
      setup = s.setup_seconds();
      big = time_to_goal(s, s.rest_vertices(), 1.0, 1.001 * Ebig, cap);
      if (!big.reached) break;
      big_seconds.push_back(big.seconds);
    }
    std::printf("\n[%s] setup %.3f s\n", c.name.c_str(), setup);
    if (big.reached)
      std::printf("  big move: %d iterations, %.3f s (median of %d) to E <= 1.001 E*\n", big.iterations,
                  median(big_seconds), runs);
    else
      std::printf("  big move: not within 1.001 E* after %d iterations (%.1f s; E = %.6f E*)\n", big.iterations,
                big.seconds, big.energy / Ebig);

    // Drag: per step, from the reference state of the previous step; the solver (and the
    // hierarchical solver's level state) carries over from step to step.
    std::vector<double> step_seconds, step_iterations;
    int missed = 0;
    for (int r = 0; r < drag_runs; ++r) {
      PoseSolver s(shell, handles, c.kind, c.options);
      for (int k = 1; k <= steps; ++k) {
        if (k % drag_every != 0 && k != steps) continue;
        const double f = static_cast<double>(k) / steps;
        const auto t0 = std::chrono::steady_clock::now();
        const Eigen::MatrixXd X0 = extrapolate && k >= 2
                                       ? s.predict_start(Xref[k - 2], (k - 2.0) / steps, Xref[k - 1], (k - 1.0) / steps, f)
                                       : Xref[k - 1];
        const double predict = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        Reach hit = time_to_goal(s, X0, f, 1.001 * Eref[k], drag_cap);
        hit.seconds += predict;
        if (!hit.reached) {
          if (r == 0) ++missed;
          continue;
        }
        step_seconds.push_back(hit.seconds);
        if (r == 0) step_iterations.push_back(hit.iterations);
      }
    }
    std::sort(step_iterations.begin(), step_iterations.end());
    std::printf("  drag (%d steps, every %d-th timed): per step median %.2f ms, max %.2f ms; iterations median %.0f, max %.0f; "
                "%d steps not reached in %d iterations\n",
                steps, drag_every, 1e3 * median(step_seconds),
                step_seconds.empty() ? 0.0 : 1e3 * *std::max_element(step_seconds.begin(), step_seconds.end()),
                median(step_iterations), step_iterations.empty() ? 0.0 : step_iterations.back(), missed, drag_cap);
    std::fflush(stdout);
  }
  return 0;
}
