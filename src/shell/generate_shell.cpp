#include <gshell/shell/generate_shell.h>

#include <gshell/error.h>
#include <gshell/format_number.h>
#include <gshell/geometry/curvature.h>
#include <gshell/geometry/mesh_topology.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/seconds_since.h>
#include <gshell/shell/curvature_prisms.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>

#include "quality/uncertified_metrics.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <utility>

namespace gshell {

namespace {

using Clock = std::chrono::steady_clock;

void check_shapes(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  if (V.cols() != 3 || F.cols() != 3 || F.rows() == 0) throw InputError("generate: need an n x 3 V and a non-empty m x 3 F");
  // Else a NaN or infinity surfaced as a "non-positive volume" or a thickness "0 times" the size.
  require_usable_coordinates(V, "generate");
}

Shell make_shell(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top, double eta) {
  Shell s;
  s.base = V;
  s.top = top;
  s.F = F;
  s.thickness = eta;
  return s;
}

// The certificate, for every method (the metrics leave it to this step): unguarded, the tets, and
// the pairs if asked; a guarded result is tested in full, the base's crossings taken from the
// guard (the same exact test, not run twice). The guard's first check certified the paper's top
// whole: the result's certificate decides again only what the guard moved since (recertify_shell,
// certify_shell's answer without a second search of the whole boundary; where the guard moved
// nothing, that check's answer itself).
void certify(GenerateResult& r, const GenerateOptions& options) {
  if (options.solve.stage) options.solve.stage("certificate");
  const Shell& s = r.shell;
  CertifyOptions o;
  if (!r.guarded) {
    r.unextrudable_vertices = extrusion_directions(s.base, s.F).unextrudable;
    o.test_intersections = options.count_intersections;
    r.metrics.certificate = certify_shell(s.base, s.top, s.F, o);
    return;
  }
  o.base_self_intersections = false;
  r.metrics.certificate = r.guard.start.certificate
                              ? recertify_shell(*r.guard.start.certificate, s.base, r.guard.paper_top, s.base, s.top, s.F, o)
                              : certify_shell(s.base, s.top, s.F, o);
  r.metrics.certificate.base_self_intersections = static_cast<int>(r.guard.base_self_intersections.size());
}

// The quality measures of the result, timed (seconds.metrics); certify() adds the certificate.
// `normal_rest`: the normal prisms' rest tets when the caller has them.
void measure(GenerateResult& r, const SolveOptions& solve, const RestTets* normal_rest = nullptr) {
  if (solve.stage) solve.stage("metrics");
  const auto t0 = Clock::now();
  const Shell& s = r.shell;
  r.metrics = normal_rest ? detail::uncertified_shell_metrics(s.base, s.F, s.top, s.thickness, *normal_rest)
                          : detail::uncertified_shell_metrics(s.base, s.F, s.top, s.thickness);
  r.seconds.metrics = seconds_since(t0);
}

// Generation towards the ideal prisms' rest tets, made by `make_ideal` where they are needed (the
// guard lets go of them through its certificate, where a big generation peaks); `ideal_is_normal`
// lets the unguarded result's metrics reuse them.
GenerateResult generate_towards(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                const std::function<RestTets()>& make_ideal, const GenerateOptions& options,
                                bool ideal_is_normal) {
  const auto t0 = Clock::now();
  options.check();
  check_shapes(V, F);
  const int n = static_cast<int>(V.rows());
  GenerateResult r;
  r.method = options.method;
  if (options.allow_invalid) {
    if (options.solve.stage) options.solve.stage("setup");
    const RestTets rest = make_ideal();
    {
      std::vector<int> base_vertices(n);
      std::iota(base_vertices.begin(), base_vertices.end(), 0);
      // The paper's iteration as it was before the guard, bit for bit: plain local/global, each
      // global step solved to the absolute tolerance (no Anderson, no early CG stop).
      LinearSolverOptions linear = options.linear;
      linear.cg_relative_tolerance = 0;
      SolveOptions paper = options.solve;
      paper.anderson_history = 0;
      if (paper.stage) paper.stage("factor");
      const ShellSolver solver(std::shared_ptr<const RestTets>(std::shared_ptr<void>(), &rest), 2 * n, base_vertices,
                               {}, linear); // shares `rest` (kept for the metrics) instead of copying it
      r.seconds.factor = solver.factor_seconds();
      Eigen::MatrixXd X(2 * n, 3);
      X << V, offset_top(V, F, options.thickness);
      if (paper.stage) paper.stage("paper");
      r.solve = solver.solve(X, paper);
      r.seconds.solve = r.solve.seconds;
      r.shell = make_shell(V, F, X.bottomRows(n), options.thickness);
    }
    measure(r, options.solve, ideal_is_normal ? &rest : nullptr);
  } else {
    r.guard = guarded_shell(V, F, make_ideal, options.thickness, options.guard, options.solve, options.linear);
    r.guarded = true;
    r.unextrudable_vertices = r.guard.directions.unextrudable;
    r.unextrudable_vertices.insert(r.unextrudable_vertices.end(), r.guard.blocked_rim_vertices.begin(),
                                   r.guard.blocked_rim_vertices.end());
    std::sort(r.unextrudable_vertices.begin(), r.unextrudable_vertices.end());
    // The paper's iterations (the energy the guard starts from); the repair's own iterations, on
    // E_guard of the region it moves, are in guard.solve.
    r.solve = r.guard.paper;
    r.solve.converged = r.guard.paper.converged && r.guard.repair_converged();
    r.seconds.factor = r.guard.factor_seconds;
    r.seconds.solve = r.guard.paper.seconds + r.guard.solve.seconds + r.guard.relax.seconds;
    r.seconds.guard = r.guard.seconds - r.guard.factor_seconds - r.seconds.solve - r.guard.ideal_seconds;
    r.shell = make_shell(V, F, r.guard.top, options.thickness);
    measure(r, options.solve);
  }
  certify(r, options);
  r.seconds.total = seconds_since(t0);
  return r;
}

// The curvature method: curvature prisms (timed apart, they are its own cost), then generation
// towards them.
GenerateResult generate_curvature(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const GenerateOptions& options) {
  const auto t0 = Clock::now();
  if (options.solve.stage) options.solve.stage("curvature prisms");
  CurvaturePrismStats prisms;
  const PrismCorners ideal =
      curvature_prisms(V, F, face_curvature(V, F), options.thickness, options.s_min, options.s_max, &prisms);
  const double prism_seconds = seconds_since(t0);
  const int n = static_cast<int>(V.rows());
  GenerateResult r = generate_towards(V, F, [&] { return prism_rest_tets(F, n, ideal); }, options, false);
  r.seconds.total += prism_seconds;
  CurvatureGeneration& c = r.curvature.emplace();
  c.s_min = options.s_min;
  c.s_max = options.s_max;
  c.prisms = prisms;
  c.prism_seconds = prism_seconds;
  // Against the prisms it was optimised towards.
  c.own_stretch = stretch_stats(prism_rest_tets(F, n, ideal), r.shell.vertices());
  return r;
}

// Radius of the bounding sphere about the bounding-box centre (see thickness_from_ratio) and the
// largest coordinate magnitude, over the rows `used` flags (all rows when null). No copy of V:
// at sphere:9 it is 63 MB.
struct Extent {
  double radius = 0, max_abs = 0;
};
Extent extent_of(const Eigen::MatrixXd& V, const std::vector<char>* used = nullptr) {
  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  Extent e;
  for (Eigen::Index v = 0; v < V.rows(); ++v)
    if (!used || (*used)[v]) {
      lo = lo.cwiseMin(V.row(v));
      hi = hi.cwiseMax(V.row(v));
      e.max_abs = std::max(e.max_abs, V.row(v).cwiseAbs().maxCoeff());
    }
  const Eigen::RowVector3d centre = 0.5 * (lo + hi);
  for (Eigen::Index v = 0; v < V.rows(); ++v)
    if (!used || (*used)[v]) e.radius = std::max(e.radius, (V.row(v) - centre).norm());
  return e;
}

double thickness_for(double ratio, const Extent& e) {
  if (!(ratio > 0) || !std::isfinite(ratio))
    throw InputError("thickness ratio must be positive and finite (got " + format_number(ratio) + ")");
  if (!(e.radius > 0)) throw InputError("thickness ratio of a mesh of zero size");
  return ratio * e.radius;
}

} // namespace

std::string to_string(ShellMethod method) {
  switch (method) {
  case ShellMethod::Offset: return "offset";
  case ShellMethod::Rigid: return "rigid";
  case ShellMethod::Curvature: return "curvature";
  }
  return "unknown";
}

ShellMethod parse_shell_method(const std::string& name) {
  for (ShellMethod m : {ShellMethod::Rigid, ShellMethod::Offset, ShellMethod::Curvature})
    if (name == to_string(m)) return m;
  throw InputError("unknown method '" + name + "' (expected rigid, offset or curvature)");
}

void GenerateOptions::check() const {
  if (!(thickness > 0) || !std::isfinite(thickness))
    throw InputError("thickness must be positive and finite (got " + format_number(thickness) + ")");
  if (solve.max_iterations < 0)
    throw InputError("iterations must be >= 0 (got " + std::to_string(solve.max_iterations) + "; 0 keeps the start)");
  if (!(solve.tolerance >= 0) || !std::isfinite(solve.tolerance)) throw InputError("tolerance must be a non-negative number");
  check_anderson_history(solve.anderson_history, "anderson (the Anderson history)");
  check_curvature_clamp(s_min, s_max);
  if (!allow_invalid && method != ShellMethod::Offset) check_guard_options(guard);
}

double thickness_from_ratio(const Eigen::MatrixXd& V, double ratio) {
  if (V.rows() == 0) throw InputError("thickness ratio of an empty mesh");
  require_usable_coordinates(V, "thickness ratio"); // a NaN vertex was left out of the size
  return thickness_for(ratio, extent_of(V));
}

double thickness_from_ratio(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double ratio) {
  if (V.rows() == 0) throw InputError("thickness ratio of an empty mesh");
  require_usable_coordinates(V, "thickness ratio");
  const std::vector<char> used = used_vertices(F, V.rows());
  return thickness_for(ratio, extent_of(V, &used));
}

void check_thickness_scale(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double thickness) {
  const std::vector<char> used = used_vertices(F, V.rows());
  if (std::find(used.begin(), used.end(), char{1}) == used.end()) return;
  const Extent e = extent_of(V, &used);
  const double extent = std::max(e.radius, e.max_abs);
  const std::string what = "thickness " + format_number(thickness) + " is " + format_number(thickness / e.radius) +
                           " times the mesh's bounding radius (" + format_number(e.radius) + ")";
  if (thickness > kMaxThicknessRatio * e.radius)
    throw InputError(what + "; gshell builds layers up to " + format_number(kMaxThicknessRatio) +
                     " times it (thickness ratio " + format_number(kMaxThicknessRatio) + ")");
  if (thickness < kMinThicknessScale * extent) {
    // Far from the origin (georeferenced scans) the extent is the distance, not the size: there
    // moving the mesh is the remedy, and the thickness itself is fine.
    const bool far = e.max_abs > e.radius;
    throw InputError(what + ", below " + format_number(kMinThicknessScale) + " of the mesh's extent (" +
                     format_number(extent) + (far ? ", its largest coordinate" : "") +
                     "): double precision cannot tell a top that close from the base" +
                     (far ? "; move the mesh near the origin (subtract its centre) and add the centre back to the output" : ""));
  }
}

GenerateResult generate_shell_from_prisms(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                          const PrismCorners& ideal, const GenerateOptions& options) {
  options.check();
  check_shapes(V, F);
  check_thickness_scale(V, F, options.thickness);
  return generate_towards(V, F, [&] { return prism_rest_tets(F, static_cast<int>(V.rows()), ideal); }, options, false);
}

GenerateResult generate_shell(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const GenerateOptions& options) {
  options.check();
  check_shapes(V, F);
  check_thickness_scale(V, F, options.thickness);
  if (options.method == ShellMethod::Curvature) return generate_curvature(V, F, options);
  if (options.method == ShellMethod::Rigid) {
    const auto t0 = Clock::now();
    GenerateResult r = generate_towards(
        V, F, [&] { return normal_prism_rest_tets(V, F, options.thickness); },
        options, true);
    r.seconds.total = seconds_since(t0);
    return r;
  }
  const auto t0 = Clock::now();
  GenerateResult r;
  r.method = ShellMethod::Offset;
  r.shell = make_shell(V, F, offset_top(V, F, options.thickness), options.thickness);
  // Its energy against the normal prisms is sum_t vol_t stretch_t, the rigid method's energy[0].
  const RestTets rest = normal_prism_rest_tets(V, F, options.thickness);
  measure(r, options.solve, &rest);
  r.solve.energy = {r.metrics.tet_stretch.dot(rest.volume)};
  certify(r, options);
  r.solve.converged = true;
  r.seconds.total = seconds_since(t0);
  return r;
}

} // namespace gshell
