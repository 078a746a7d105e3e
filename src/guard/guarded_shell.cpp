#include <gshell/guard/guarded_shell.h>

#include <gshell/error.h>
#include <gshell/guard/contact_guard.h>
#include <gshell/geometry/mesh_topology.h>
#include <gshell/seconds_since.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/quality/stretch.h>

#include "geometry/faces_touching.h"
#include "guard/lift_thin_tops.h"
#include "guard/shell_part.h"
#include "guard/small_parts.h"
#include "guard/valid_start_with.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <string>

namespace gshell {

namespace {

using Clock = std::chrono::steady_clock;

void require(bool ok, const char* name, const char* range) {
  if (!ok) throw InputError(std::string("guard option ") + name + " must be " + range);
}

// Mean length over the faces' half-edges and mean base area per vertex.
std::pair<double, double> mean_edge_and_vertex_area(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  double length = 0, area = 0;
  for (int f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    length += (b - a).norm() + (c - b).norm() + (a - c).norm();
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  return {F.rows() > 0 ? length / (3.0 * static_cast<double>(F.rows())) : 0.0,
          V.rows() > 0 ? area / static_cast<double>(V.rows()) : 0.0};
}

// What the repair, its relaxation and the lifting make of the valid start (the GuardedShell
// fields of the same names).
struct Mended {
  Eigen::MatrixXd X; // base rows, then the top
  int repaired_vertices = 0;
  GuardedSolveResult solve;
  GuardedShell::Relax relax;
  GuardedShell::Lift lift;
  double factor_seconds = 0;
};

// The barriers that keep the repair's steps clear of the validity limits also hold the top
// further from those limits than a valid top needs to be. Each round solves the repaired region
// again from the result with weaker barriers (j_hat / 3, both weights / 10, the contact support
// halved) and keeps the outcome only if it lowers the shell energy E; validity never depends on
// the barriers' strength, only on the step bounds, so every round's result is as valid as its
// start. X: the repair's result in the solver's vertex ids, replaced by each kept round's.
void relax(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta, const GuardOptions& options,
           GuardedSolver& solver, const GuardedSolveOptions& solve, Eigen::MatrixXd& X, Mended& out) {
  GuardOptions weak = options;
  double energy = out.solve.final_energy;
  out.relax.first_energy = energy;
  for (int round = 0; round < options.relax_rounds; ++round) {
    weak.j_hat /= 3;
    weak.volume_weight /= 10;
    weak.contact_weight /= 10;
    weak.contact_distance /= 2;
    GuardedSolverParameters q = absolute_guard_parameters(V, F, eta, weak);
    q.skip_tets = solver.parameters().skip_tets;
    q.excluded_triangles = solver.parameters().excluded_triangles;
    // Its weaker barriers let every step run close to the limits, so most are cut; holding what
    // cuts them cost cheese at 0.05 1.6 -> 9.5 s here for 1.035 -> 1.030 stretch ratio.
    q.hold_rounds = 0;
    // The repair's solver with the weaker barriers: its system and contact primitives serve as
    // they are (a new solver spent 0.1 s per 150K vertices making the primitives again).
    solver.set_parameters(std::move(q));
    Eigen::MatrixXd Y = X;
    const GuardedSolveResult r = solver.solve(Y, solve);
    out.relax.iterations += r.iterations;
    out.relax.seconds += r.seconds;
    if (!(r.final_energy < energy)) break;
    X = std::move(Y);
    energy = r.final_energy;
    ++out.relax.kept_rounds;
    out.solve.final_energy = r.final_energy;
    out.solve.active_tets = r.active_tets;
    out.solve.min_relative_volume = r.min_relative_volume;
    out.solve.active_contacts = r.active_contacts;
  }
}

// E, the shell energy the paper's iterations lower: rest volume times stretch, summed over tets.
double shell_energy(const RestTets& ideal, const Eigen::MatrixXd& X) { return tet_stretch(ideal, X).dot(ideal.volume); }

// The ideal rest tets, either the caller's or made on demand (and then let go of where the
// generation peaks without them).
class IdealTets {
public:
  explicit IdealTets(const RestTets& given) : given_(&given) {}
  explicit IdealTets(const std::function<RestTets()>& make) : make_(make) {}
  const RestTets& get() {
    if (given_) return *given_;
    if (!made_) {
      const auto start = Clock::now();
      made_ = make_();
      seconds_ += seconds_since(start);
    }
    return *made_;
  }
  void release() { made_.reset(); }
  double seconds() const { return seconds_; } // spent making them

private:
  const RestTets* given_ = nullptr;
  std::function<RestTets()> make_;
  std::optional<RestTets> made_;
  double seconds_ = 0;
};

// What the repair, the relaxation and the lifting read besides their region and start.
struct MendInputs {
  const Eigen::MatrixXd& V;
  const Eigen::MatrixXi& F;
  const RestTets& ideal;
  double eta;
  const GuardOptions& options;
  const GuardedSolveOptions& solve;
  const ShellBoundary& boundary;
  const GuardedShell& g; // directions, start, paper, paper_top (the lifting's goal), parameters
  // Where the lifting runs: its checker (a later check refits the tree of an earlier one to the
  // positions it is given, so attempts share it) and the top vertices it may move.
  const detail::StartChecker* lift_checker;
  const std::vector<char>& movable;
  const std::function<void(const char*)>& stage; // names the repair and relaxation for progress
};

// Top vertices the lifting may move: not those outside the guard's protection (unextrudable,
// blocked rims, next to what it cannot keep clean), whose skipped tets and unprotected rows the
// checker does not see.
std::vector<char> liftable_vertices(const GuardedShell& g, const ShellBoundary& boundary,
                                    const detail::StartChecker& checker, int n) {
  std::vector<char> movable(n, 1);
  for (int v : g.directions.unextrudable) movable[v] = 0;
  for (int v : g.blocked_rim_vertices) movable[v] = 0;
  for (int v : g.small_part_vertices) movable[v] = 0;
  const Eigen::MatrixXi& T = checker.tets();
  for (int t = 0; t < T.rows(); ++t)
    if (g.parameters.skip_tets[t])
      for (int j = 0; j < 4; ++j)
        if (T(t, j) >= n) movable[T(t, j) - n] = 0;
  for (int r = 0; r < boundary.size(); ++r)
    if (g.unprotected_triangles[r])
      for (int k = 0; k < 3; ++k)
        if (boundary.F(r, k) >= n) movable[boundary.F(r, k) - n] = 0;
  return movable;
}

// The guarded solver over the top vertices flagged in `region` (the rest held) from the valid
// start X, its relaxation rounds, then the lifting of thin tops.
Mended mend(const MendInputs& in, const std::vector<char>& region, const Eigen::MatrixXd& X) {
  const int n = static_cast<int>(in.V.rows());
  const RestTets& ideal = in.ideal;
  const GuardedSolverParameters& p = in.g.parameters;
  Mended out;
  out.X = X;
  out.repaired_vertices = static_cast<int>(std::count(region.begin(), region.end(), 1));
  if (out.repaired_vertices > 0) {
    // The solve runs over the part of the shell it can reach (detail::ShellPart), each top vertex
    // confined to a ball around its start: kRepairTravel times the larger of the thickness and the
    // longest edge of a moving boundary triangle, far beyond what a repair moves a top (it pulls
    // it back towards its prism: along its offset, and sideways by what its prism's shape asks;
    // over CGAL's models at ratios 0.01 to 0.2 with both methods no top moved more than 2.4 eta,
    // a quarter of this radius but on one base crossing itself; docs/guarded-generation.md "The
    // repair over its part").
    constexpr double kRepairTravel = 4;
    std::vector<char> moving(2 * n, 0);
    for (int i = 0; i < n; ++i) moving[n + i] = region[i];
    double longest = 0;
    for (int r = 0; r < in.boundary.size(); ++r)
      for (int k = 0; k < 3; ++k)
        if (moving[in.boundary.F(r, k)])
          for (int l = 0; l < 3; ++l)
            longest = std::max(longest, (out.X.row(in.boundary.F(r, k)) - out.X.row(in.boundary.F(r, l))).norm());
    const double travel = kRepairTravel * std::max(in.eta, longest);
    // The contact guard's candidates reach dhat + slack, its slack being dhat (ContactOptions).
    const detail::ShellPart part = detail::shell_part(ideal, in.boundary, out.X, moving, travel, 2 * p.contact_distance);
    GuardedSolverParameters q = p;
    q.skip_tets.clear();
    for (int t : part.tet) q.skip_tets.push_back(p.skip_tets.empty() ? 0 : p.skip_tets[t]);
    if (!p.excluded_triangles.empty()) {
      q.excluded_triangles.clear();
      for (int r : part.row) q.excluded_triangles.push_back(p.excluded_triangles[r]);
    }
    GuardedSolver repair(part.tets, part.size(), part.held, part.boundary, q);
    // The bound is what lets the part leave rows out; where it keeps them all it is not needed.
    if (part.row.size() < static_cast<std::size_t>(in.boundary.size())) repair.confine(part.X, travel);
    out.factor_seconds += repair.shell_solver().factor_seconds();
    // Converged as the paper's iterations are: relative to the whole shell's energy.
    GuardedSolveOptions repair_options = in.solve;
    repair_options.energy_scale = in.g.paper.energy.back();
    if (in.options.repair_iterations >= 0) {
      repair_options.max_iterations = in.options.repair_iterations;
    } else if (in.options.repair_budget > 0) {
      // The extension's ceiling: past it, the small unconverged repairs measured gain nothing.
      constexpr double kMaxRepairIterations = 300;
      const double affordable = std::min(kMaxRepairIterations, in.options.repair_budget / out.repaired_vertices);
      repair_options.max_iterations = std::max(in.solve.max_iterations, static_cast<int>(affordable));
    }
    Eigen::MatrixXd Y = part.X;
    if (in.stage) in.stage("repair");
    out.solve = repair.solve(Y, repair_options);
    if (in.stage && in.options.relax_rounds > 0) in.stage("relax");
    relax(in.V, in.F, in.eta, in.options, repair, repair_options, Y, out);
    part.scatter_moving(Y, out.X);
  }
  if (in.lift_checker) {
    const auto lift_start = Clock::now();
    Eigen::MatrixXd top = out.X.bottomRows(n);
    const detail::LiftResult lifted =
        detail::lift_thin_tops(in.V, in.F, ideal, in.g.paper_top, in.g.directions.direction, in.movable,
                               *in.lift_checker, in.options.lift_sweeps, top);
    out.X.bottomRows(n) = top;
    out.lift = {lifted.candidates, lifted.lifted, lifted.checks, lifted.energy_drop, seconds_since(lift_start)};
  }
  if (out.repaired_vertices > 0) {
    // The repair's figure covers its part before the lifting; the report's is the returned shell's:
    // every guarded tet, the lifted tops' included (they may thin a neighbour's tet).
    const Eigen::VectorXd det = tet_deformation_determinants(ideal, out.X);
    double smallest = std::numeric_limits<double>::infinity();
    for (Eigen::Index t = 0; t < det.size(); ++t)
      if (p.skip_tets.empty() || !p.skip_tets[t]) smallest = std::min(smallest, det[t]);
    out.solve.min_relative_volume = smallest;
  }
  return out;
}

} // namespace

void check_guard_options(const GuardOptions& o) {
  require(o.j_hat > 0 && o.j_hat <= 1, "j_hat", "in (0, 1]");
  require(o.volume_weight > 0 && std::isfinite(o.volume_weight), "volume_weight", "positive");
  require(o.contact_distance >= 0 && std::isfinite(o.contact_distance), "contact_distance", ">= 0");
  require(o.contact_rest_fraction >= 0 && o.contact_rest_fraction <= 1, "contact_rest_fraction", "in [0, 1]");
  require(o.contact_weight > 0 && std::isfinite(o.contact_weight), "contact_weight", "positive");
  require(o.keep_fraction > 0 && o.keep_fraction < 1, "keep_fraction", "in (0, 1)");
  require(o.cg_iterations >= 0, "cg_iterations", ">= 0");
  require(o.local_rings >= -1, "local_rings", ">= -1");
  require(o.hold_rounds >= 0, "hold_rounds", ">= 0");
  check_anderson_history(o.anderson_history, "guard option anderson_history");
  require(o.exact_direction_vertices >= 0, "exact_direction_vertices", ">= 0");
  require(o.max_step_multiple >= 0, "max_step_multiple", ">= 0");
  require(o.supernodal_rows >= 0, "supernodal_rows", ">= 0");
  require(o.supernodal_flops >= 0, "supernodal_flops", ">= 0");
  require(o.cg_tolerance > 0 && o.cg_tolerance < 1, "cg_tolerance", "in (0, 1)");
  require(o.normal_margin >= -1 && o.normal_margin <= 1, "normal_margin", "in [-1, 1]");
  require(o.start_smoothing >= 0 && std::isfinite(o.start_smoothing), "start_smoothing", ">= 0");
  require(std::isfinite(o.start_spread) && (o.start_spread <= 0 || o.start_spread > 1), "start_spread",
          "above 1, or 0 or less (no limit)");
  require(o.start_thinning > 0 && o.start_thinning < 1, "start_thinning", "in (0, 1)");
  require(o.start_refine >= 0, "start_refine", ">= 0");
  require(o.start_backoff > 0 && o.start_backoff <= 1, "start_backoff", "in (0, 1]");
  require(o.start_max_rounds >= 1, "start_max_rounds", ">= 1");
  require(o.start_margin > 0 && o.start_margin <= 1, "start_margin", "in (0, 1]");
  require(o.unextrudable_thickness > 0 && o.unextrudable_thickness <= 1, "unextrudable_thickness", "in (0, 1]");
  require(o.repair_rings >= 0, "repair_rings", ">= 0");
  require(o.small_part_ratio >= 0 && std::isfinite(o.small_part_ratio), "small_part_ratio", ">= 0");
  require(o.repair_min_scale >= 0 && o.repair_min_scale < 1, "repair_min_scale", "in [0, 1)");
  require(o.repair_iterations >= -1, "repair_iterations", ">= -1");
  require(o.repair_budget >= 0 && std::isfinite(o.repair_budget), "repair_budget", ">= 0");
  require(o.relax_rounds >= 0, "relax_rounds", ">= 0");
  require(o.lift_sweeps >= 0, "lift_sweeps", ">= 0");
  require(o.mend_rings >= -1, "mend_rings", ">= -1");
  require(o.mend_max_rise >= 0 && std::isfinite(o.mend_max_rise), "mend_max_rise", ">= 0");
}

ValidStartOptions valid_start_options(const GuardOptions& options, double fallback_length) {
  ValidStartOptions o;
  o.thinning = options.start_thinning;
  o.straight_margin = options.start_margin;
  o.spread = options.start_spread;
  o.refine_passes = options.start_refine;
  o.backoff = options.start_backoff;
  o.max_rounds = options.start_max_rounds;
  o.fallback_length = fallback_length;
  return o;
}

GuardOptions generation_guard_options() {
  GuardOptions o;
  o.contact_distance = 0.03;
  o.projected_volume_hessian = true;
  o.projected_contact_hessian = false;
  o.local_rings = 4;
  o.hold_rounds = 4;
  o.repair_budget = 1e5;
  o.relax_rounds = 1;
  o.lift_sweeps = 4;
  o.try_lift_only = true;
  o.start_smoothing = 0.3;
  return o;
}

GuardedSolverParameters absolute_guard_parameters(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta,
                                                  const GuardOptions& options) {
  check_guard_options(options);
  const auto [edge, vertex_area] = mean_edge_and_vertex_area(V, F);
  GuardedSolverParameters p;
  p.j_hat = options.j_hat;
  p.volume_weight = options.volume_weight;
  p.contact_distance = options.contact_distance * std::min(eta, edge);
  p.contact_stiffness =
      p.contact_distance > 0 ? options.contact_weight * vertex_area / std::pow(p.contact_distance, 3) : 0.0;
  p.keep_fraction = options.keep_fraction;
  p.cg_iterations = options.cg_iterations;
  p.cg_tolerance = options.cg_tolerance;
  p.projected_volume_hessian = options.projected_volume_hessian;
  p.projected_contact_hessian = options.projected_contact_hessian;
  p.local_rings = options.local_rings;
  p.supernodal_rows = options.supernodal_rows;
  p.supernodal_flops = options.supernodal_flops;
  p.hold_rounds = options.hold_rounds;
  p.anderson_history = options.anderson_history;
  p.exact_direction_vertices = options.exact_direction_vertices;
  p.max_step_multiple = options.max_step_multiple;
  return p;
}

namespace {

GuardedShell guarded_shell(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, IdealTets& ideal, double eta,
                           const GuardOptions& options, const SolveOptions& solve,
                           const LinearSolverOptions& linear, const Eigen::MatrixXd& first_top = {}) {
  const auto t0 = Clock::now();
  check_guard_options(options);
  if (!(eta > 0) || !std::isfinite(eta)) throw InputError("guarded_shell: thickness must be positive and finite");
  const int n = static_cast<int>(V.rows()), m = static_cast<int>(F.rows());
  if (ideal.get().size() != 3 * m) throw InputError("guarded_shell: expected 3 rest tets per face");
  if (first_top.size() > 0 && (first_top.rows() != n || first_top.cols() != 3))
    throw InputError("guarded_shell: the first top must be " + std::to_string(n) + " x 3");
  if (solve.stage) solve.stage("setup");
  GuardedShell g;
  g.directions = extrusion_directions(V, F, options.normal_margin);

  // Prisms around unextrudable vertices cannot all be valid: their tets are not guarded and their
  // boundary triangles see no contacts (nor do those around the base's own crossings, below).
  const std::vector<char> unguarded_face = detail::faces_touching(F, n, g.directions.unextrudable);
  GuardedSolverParameters& p = g.parameters;
  p = absolute_guard_parameters(V, F, eta, options);
  p.skip_tets.assign(3 * static_cast<std::size_t>(m), 0);
  for (int f = 0; f < m; ++f)
    if (unguarded_face[f]) p.skip_tets[3 * f] = p.skip_tets[3 * f + 1] = p.skip_tets[3 * f + 2] = 1;
  std::vector<int> fixed(n);
  std::iota(fixed.begin(), fixed.end(), 0);
  for (int v : g.directions.unextrudable) fixed.push_back(n + v);
  // The paper's iterations from the offset surface (or the caller's first top) give the top
  // wanted everywhere; the tops of unextrudable vertices are held low along their best direction.
  Eigen::MatrixXd X(2 * n, 3);
  if (first_top.size() > 0) X << V, first_top;
  else X << V, V + eta * smoothed_vertex_normals(V, F, options.start_smoothing * eta, &g.smoothing);
  for (int v : g.directions.unextrudable)
    X.row(n + v) = V.row(v) + options.unextrudable_thickness * eta * g.directions.direction.row(v);
  {
    // Shares `ideal` (which outlives it) rather than copying it: at millions of faces a copy of
    // the rest tets is the largest allocation of the generation. Scoped: its matrix and factor
    // or multigrid are freed before the start's certificate, where the generation peaks.
    if (solve.stage) solve.stage("factor");
    const ShellSolver paper_solver(std::shared_ptr<const RestTets>(std::shared_ptr<void>(), &ideal.get()), 2 * n,
                                   fixed, {}, linear);
    g.factor_seconds = paper_solver.factor_seconds();
    if (solve.stage) solve.stage("paper");
    g.paper = paper_solver.solve(X, solve); // the guarded solve reports its own iterations after these
  }
  ideal.release(); // made again below only if the start thins a top
  // Built after the paper's iterations, which do not need it, so as not to add to their peak.
  const ShellBoundary boundary = shell_boundary(F, n);

  // Valid start: that top, pulled towards the base only where it is not valid. Its first check
  // certifies the paper's top whole and finds the base's own crossings in the same pass, over the
  // certificate's tree of the base triangles (docs/scale.md, "The base's crossings from the
  // start's first check"): around them no top can be clean, so the triangles of the faces
  // touching a crossing face see no contacts.
  if (solve.stage) solve.stage("start");
  const ValidStartOptions start_options = valid_start_options(options, eta);
  {
    // Scoped: its trees over all boundary rows are freed once the start is made, as before.
    detail::StartChecker checker(F, n, p.skip_tets, {});
    ShellCertificate first = checker.certify(V, X.bottomRows(n), &g.base_self_intersections);
    const std::vector<char> crossing_face = detail::faces_around_crossings(F, n, g.base_self_intersections);
    p.excluded_triangles.assign(boundary.size(), 0);
    for (int r = 0; r < boundary.size(); ++r)
      p.excluded_triangles[r] = unguarded_face[boundary.face[r]] || crossing_face[boundary.face[r]];
    g.unprotected_triangles = unprotected_rows(boundary, p.excluded_triangles, 2 * n);
    checker.exclude_triangles(g.unprotected_triangles);
    g.start = detail::valid_start_with(V, F, X.bottomRows(n), g.directions, checker, std::move(first), start_options);
  }
  // On the rim of an open surface a vertex can have a direction that sees all its faces and still
  // not extrude: its side walls cut through its own faces however thin the layer (a rim folded
  // flat back onto its neighbours). Where the start is left with violations at such vertices
  // they are named (the start has already thinned them as far as it could, and holding them like
  // unextrudable vertices, at a tenth of eta with their stars out of the guard, was measured to
  // leave more violations: CGAL's b9_mesh 1,326 -> 2,125 at ratio 0.05).
  if (!g.start.inverted_tets.empty() || !g.start.intersections.empty()) {
    // Whatever the start could not mend (only a degenerate base leaves anything) is left
    // unguarded too, so that the solver starts valid for its barriers; the certificate reports it.
    for (int t : g.start.inverted_tets) p.skip_tets[t] = 1;
    for (const auto& [a, b] : g.start.intersections) p.excluded_triangles[a] = p.excluded_triangles[b] = 1;
    g.unprotected_triangles = unprotected_rows(boundary, p.excluded_triangles, 2 * n);
    std::vector<int> candidates;
    for (int v : unmended_vertices(g.start, F, n))
      if (!std::binary_search(g.directions.unextrudable.begin(), g.directions.unextrudable.end(), v))
        candidates.push_back(v);
    g.blocked_rim_vertices = rim_vertices_with_blocked_walls(V, F, g.directions.direction, candidates);
  }
  {
    std::vector<char> face_out(m, 0);
    for (int r = 0; r < boundary.size(); ++r)
      if (g.unprotected_triangles[r]) face_out[boundary.face[r]] = 1;
    g.unprotected_faces = static_cast<int>(std::count(face_out.begin(), face_out.end(), 1));
  }
  // Repair: the guarded solver moves only the top vertices the start pulled in and a few rings
  // around them; everywhere else the paper's result stands (its barriers are zero there and it is
  // converged), so the repair costs in proportion to the trouble, not to the shell.
  std::vector<char> in_region(n, 0);
  for (int i = 0; i < n; ++i) in_region[i] = g.start.scale[i] < 1;
  for (int v : g.directions.unextrudable) in_region[v] = 0;
  grow_by_rings(F, options.repair_rings, in_region);
  for (int v : g.directions.unextrudable) in_region[v] = 0;
  // Parts too small for the thickness keep the start (rings grow within a part only).
  if (options.small_part_ratio > 0) {
    g.small_part_radius = eta / options.small_part_ratio;
    g.small_part_vertices = detail::small_part_vertices(V, F, g.small_part_radius);
  }
  for (int v : g.small_part_vertices) in_region[v] = 0;
  // Top vertices the start had to pull nearly onto their base stay there: their pairs with the
  // base triangles around them can be closer than the contact step bound resolves in floating
  // point (it then returns 0 and the whole repair stands still), and their violations came from
  // the base itself (two input sheets nearly touching).
  // Their neighbours are held too: a top edge from such a vertex to a moving one nearly meets
  // the base edges at its base vertex.
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k)
      if (g.start.scale[F(f, k)] < options.repair_min_scale)
        for (int l = 0; l < 3; ++l)
          if (in_region[F(f, l)]) {
            in_region[F(f, l)] = 0;
            ++g.held_vertices;
          }
  // Where the start thinned no top there is nothing to mend: no region, no lifting candidates.
  const bool thinned = (g.start.scale.array() < 1).any();
  g.paper_top = X.bottomRows(n);
  X.bottomRows(n) = g.start.top;
  if (thinned) {
    const RestTets& ideal_tets = ideal.get();
    std::optional<detail::StartChecker> lift_checker;
    std::vector<char> movable;
    if (options.lift_sweeps > 0) {
      lift_checker.emplace(F, n, p.skip_tets, g.unprotected_triangles);
      movable = liftable_vertices(g, boundary, *lift_checker, n);
    }
    GuardedSolveOptions mend_solve; // the repair's and the relaxation's: the paper's caps and progress
    mend_solve.max_iterations = solve.max_iterations;
    mend_solve.tolerance = solve.tolerance;
    mend_solve.progress = solve.progress;
    const MendInputs inputs{V, F, ideal_tets, eta, options, mend_solve, boundary, g,
                            lift_checker ? &*lift_checker : nullptr, movable, solve.stage};
    Mended mended = mend(inputs, in_region, X);
    g.factor_seconds += mended.factor_seconds;
    // Around held tops the repair can move their neighbours where they block them: the lifting
    // alone, from the start, is kept where it ends at the lower energy E.
    if (g.held_vertices > 0 && options.try_lift_only && lift_checker) {
      Mended lifted = mend(inputs, std::vector<char>(n, 0), X);
      g.lift_only = shell_energy(ideal_tets, lifted.X) < shell_energy(ideal_tets, mended.X);
      if (g.lift_only) mended = std::move(lifted);
    }
    X = std::move(mended.X);
    g.repaired_vertices = mended.repaired_vertices;
    g.solve = mended.solve;
    g.relax = mended.relax;
    g.lift = mended.lift;
  }
  g.top = X.bottomRows(n);
  g.ideal_seconds = ideal.seconds();
  g.seconds = seconds_since(t0);
  return g;
}

} // namespace

GuardedShell guarded_shell(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const RestTets& ideal, double eta,
                           const GuardOptions& options, const SolveOptions& solve,
                           const LinearSolverOptions& linear, const Eigen::MatrixXd& first_top) {
  IdealTets tets(ideal);
  return guarded_shell(V, F, tets, eta, options, solve, linear, first_top);
}

GuardedShell guarded_shell(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                           const std::function<RestTets()>& make_ideal, double eta, const GuardOptions& options,
                           const SolveOptions& solve, const LinearSolverOptions& linear) {
  IdealTets tets(make_ideal);
  return guarded_shell(V, F, tets, eta, options, solve, linear);
}

} // namespace gshell
