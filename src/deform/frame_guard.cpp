#include "frame_guard.h"

#include <gshell/error.h>
#include <gshell/geometry/mesh_topology.h>
#include <gshell/guard/contact_guard.h>
#include <gshell/guard/extrusion_directions.h>
#include <gshell/guard/guarded_shell.h>
#include <gshell/guard/pair_ccd.h>
#include <gshell/guard/tet_step_bound.h>
#include <gshell/guard/valid_start.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/quality/triangle_intersections.h>

#include "geometry/faces_touching.h"
#include "guard/shell_part.h"

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

namespace gshell {

namespace {

/// Largest relative change of a base edge vector from `from` to `to`: max over edges (i, j) of
/// |(to_j - to_i) - (from_j - from_i)| / |from_j - from_i|.
double max_edge_change(const Eigen::MatrixXd& from, const Eigen::MatrixXd& to, const Eigen::MatrixXi& F) {
  double worst = 0;
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int i = F(f, k), j = F(f, (k + 1) % 3);
      const Eigen::RowVector3d e0 = from.row(j) - from.row(i), e1 = to.row(j) - to.row(i);
      const double length = e0.norm();
      if (length > 0) worst = std::max(worst, (e1 - e0).norm() / length);
    }
  return worst;
}

// accepted_fraction's tries: each 0.7 of the one before (about 8 tries from 0.7 down to 0.05).
constexpr double kFractionShrink = 0.7;

// Tets at or below this relative volume are left out of the guard: no step bound computed in
// floating point keeps their sign.
constexpr double kFlat = 1e-8;

// A mend's steps cut below this fraction are taken with what cuts them held (generation's repair
// holds below GuardedSolverParameters' 0.05): from tops pulled in, one pair pressed to a
// hundred-thousandth of dhat and sliding can hold every step to 3e-4 (CGAL's refined_elephant bent
// by 30 degrees a frame: 2,000 iterations, still 6 % above the paper's energy), while holding below
// 0.05 held dozens of dino's steps each mend and cost its bends and twists half again their time
// (docs/valid-deformation.md, "Mends held still by one pair").
constexpr double kMendHoldBelow = 0.005;

/// Flags in `skip` the three tets of the prism over every face flagged in `face`.
void skip_prisms_of(const std::vector<char>& face, std::vector<char>& skip) {
  for (std::size_t f = 0; f < face.size(); ++f)
    if (face[f]) skip[3 * f] = skip[3 * f + 1] = skip[3 * f + 2] = 1;
}

/// Flags in `excluded` (one per row of `boundary`) the boundary triangles of every face flagged in
/// `face`.
void exclude_triangles_of(const std::vector<char>& face, const ShellBoundary& boundary, std::vector<char>& excluded) {
  for (int r = 0; r < boundary.size(); ++r)
    if (face[boundary.face[r]]) excluded[r] = 1;
}

/// Flags in `skip` the three tets of every prism touching a vertex of (V, F) that no direction
/// extrudes (one of them must be inverted, and which one may change as the base moves).
void skip_prisms_at_unextrudable_vertices(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, std::vector<char>& skip) {
  skip_prisms_of(detail::faces_touching(F, static_cast<int>(V.rows()), extrusion_directions(V, F).unextrudable), skip);
}

/// Flags in `excluded` the boundary triangles around the crossings of the base (V, F) with itself:
/// over every face sharing a vertex with a face that crosses another (no top there is clean).
void exclude_around_base_crossings(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const ShellBoundary& boundary,
                                   std::vector<char>& excluded) {
  const std::vector<std::pair<int, int>> crossings = surface_self_intersections(V, F);
  if (crossings.empty()) return;
  exclude_triangles_of(detail::faces_around_crossings(F, static_cast<int>(V.rows()), crossings), boundary, excluded);
}

/// Flags in `touched` (one per base vertex) the base vertex of every vertex of a boundary pair
/// that touches to rounding at X (pair_touches_to_rounding), among the pairs a guard with these
/// fixed vertices sees. The candidate search reaches 1e-4 eta: ten rounding allowances of pairs
/// up to about 200 eta across.
void touch_pairs_touching_to_rounding(const ShellBoundary& boundary, const Eigen::MatrixXd& X, int n,
                                      const std::vector<int>& fixed, double eta, std::vector<char>& touched) {
  std::vector<char> movable(X.rows(), 1);
  for (int v : fixed) movable[v] = 0;
  ContactOptions near;
  near.dhat = 1e-4 * eta;
  ContactGuard pairs(boundary, static_cast<int>(X.rows()), std::move(movable), near);
  pairs.min_distance(X); // builds the candidate list at X
  for (const ContactPair& pair : pairs.candidate_pairs()) {
    PairPoints x;
    for (int k = 0; k < 4; ++k) x[k] = X.row(pair.vertices[k]).transpose();
    if (pair_touches_to_rounding(pair.kind, x))
      for (int v : pair.vertices) touched[v % n] = 1;
  }
}

} // namespace

FrameGuard::FrameGuard(const Shell& rest, std::shared_ptr<const RestTets> shared_tets, const GuardOptions& options,
                       std::vector<int> fixed, bool moving_base, std::shared_ptr<const ShellSolver> arap)
    : options_(options), rest_tets_(std::move(shared_tets)), arap_(std::move(arap)), rest_vertices_(rest.vertices()),
      probe_(*rest_tets_, options.j_hat),
      n_(rest.num_base_vertices()),
      F_(rest.F), fixed_(std::move(fixed)), moving_base_(moving_base),
      boundary_(shell_boundary(rest.F, rest.num_base_vertices())), certifier_(rest.F, rest.num_base_vertices()) {
  const int n = n_;
  double eta = rest.thickness;
  if (!(eta > 0) && n > 0) eta = (rest.top - rest.base).rowwise().norm().mean();
  parameters_ = absolute_guard_parameters(rest.base, rest.F, eta, options);

  // What the rest shell breaks already stays out of the guard: its inverted tets, and the faces
  // of its intersecting triangle pairs with every face sharing a vertex with them, triangles and
  // prisms (a base that crosses itself leaves no clean top near the crossing).
  const ShellCertificate rest_certificate = certifier_.certify(rest.base, rest.top);
  for (const auto& [v, t] : rest_certificate.nested) rest_nested_.push_back(v);
  const Eigen::MatrixXd& X = rest_vertices_;
  parameters_.skip_tets.assign(static_cast<std::size_t>(rest_tets_->size()), 0);
  for (int t : rest_certificate.inverted_tet_ids) parameters_.skip_tets[t] = 1;
  // So do tets flat to rounding error (J below kFlat): a drag guarding them crawls at steps of
  // 1e-10 (CGAL's man: minutes per frame, then a step that rounded one of them inverted). The
  // certificate still counts them.
  for (int t = 0; t < rest_tets_->size(); ++t)
    if (!(probe_.relative_volume_of(X, t) > kFlat)) parameters_.skip_tets[t] = 1;
  // And every tet of a prism at an unextrudable vertex of the base (no direction sees all its faces
  // from their positive side): one of them must be inverted, and which one may change as the base
  // moves, so guarding the others would hold the frame still.
  skip_prisms_at_unextrudable_vertices(rest.base, rest.F, parameters_.skip_tets);
  std::vector<char> touched(n, 0);
  for (const BoundaryIntersection& pair : rest_certificate.intersections)
    for (int row : {pair.a, pair.b})
      for (int k = 0; k < 3; ++k) touched[boundary_.F(row, k) % n] = 1;
  // The faces of pairs that touch to rounding at rest are left out of the contacts too (a top left
  // a hair's breadth from its base where the generation's guard could not lift it, next to a base
  // crossing or a vertex extruded almost sideways): no step moving them is certified, so guarding
  // them would hold every drag still (CGAL's mannequin-devil posed: every step ended where it
  // began).
  // A posed shell's handles move relative to each other, so their own pairs are guarded too;
  // a deformation's base is the caller's.
  parameters_.guard_fixed_pairs = moving_base_;
  if (parameters_.contact_distance > 0 && n > 0)
    touch_pairs_touching_to_rounding(boundary_, X, n, parameters_.guard_fixed_pairs ? std::vector<int>{} : fixed_, eta,
                                     touched);
  const std::vector<char> around = detail::faces_touching(rest.F, touched);
  parameters_.excluded_triangles.assign(boundary_.size(), 0);
  exclude_triangles_of(around, boundary_, parameters_.excluded_triangles);
  rest_excluded_ = parameters_.excluded_triangles;
  // And the tets of those faces' prisms: their tops cross another sheet already or lie a hair
  // from one, and guarding them held drags back (CGAL's mannequin-devil posed: not done in 600 s,
  // 2-3 minutes without them; docs/valid-deformation.md). A rest shell with no intersecting
  // pair and no pair touching to rounding has no such place: nothing changes for it.
  skip_prisms_of(around, parameters_.skip_tets);
  rest_skip_ = parameters_.skip_tets;
}

const std::shared_ptr<const ShellSolver>& FrameGuard::arap() {
  if (!arap_) arap_ = std::make_shared<const ShellSolver>(rest_tets_, 2 * n_, fixed_);
  return arap_;
}

GuardedSolver& FrameGuard::contact_solver() {
  // Built at the first drag, not with the guard: most steps and frames are accepted as the solver
  // made them and never need it (a factorisation of the whole shell's system), and with soft
  // handles (no fixed vertex: no drag) its system would be singular.
  if (!contact_) {
    contact_ = std::make_unique<GuardedSolver>(arap(), boundary_, parameters_);
    cap_contact_supports();
  }
  return *contact_;
}

void FrameGuard::cap_contact_supports() {
  if (contact_ && options_.contact_rest_fraction > 0)
    contact_->cap_contact_support(rest_vertices_, options_.contact_rest_fraction);
}

FrameGuard::~FrameGuard() = default;

bool FrameGuard::leave_out(const Eigen::MatrixXd& from, const Eigen::MatrixXd* to) {
  std::vector<char> skip = rest_skip_, excluded = rest_excluded_;
  if (to) {
    skip_prisms_at_unextrudable_vertices(to->topRows(n_), F_, skip);
    exclude_around_base_crossings(to->topRows(n_), F_, boundary_, excluded);
  }
  tbb::parallel_for(0, static_cast<int>(skip.size()), [&](int t) {
    if (!skip[t] && !(probe_.relative_volume_of(from, t) > kFlat)) skip[t] = 1;
  });
  // A state made with triangles left out around its base's crossings may have intersections
  // there: they stay left out while its base crosses itself.
  if (parameters_.excluded_triangles != rest_excluded_)
    exclude_around_base_crossings(from.topRows(n_), F_, boundary_, excluded);
  const bool new_skip = skip != parameters_.skip_tets, new_excluded = excluded != parameters_.excluded_triangles;
  if (new_skip) {
    if (contact_) contact_->set_skipped_tets(skip);
    if (tets_) tets_->set_skipped_tets(skip);
    parameters_.skip_tets = std::move(skip);
  }
  if (new_excluded) {
    if (contact_) contact_->set_excluded_triangles(boundary_, excluded);
    if (tets_) tets_->set_excluded_triangles(boundary_, excluded);
    parameters_.excluded_triangles = std::move(excluded);
    cap_contact_supports();
  }
  return new_skip || new_excluded;
}

bool FrameGuard::built_with(const GuardOptions& o) const {
  const GuardOptions& p = options_;
  return p.j_hat == o.j_hat && p.volume_weight == o.volume_weight && p.contact_distance == o.contact_distance &&
         p.contact_rest_fraction == o.contact_rest_fraction &&
         p.contact_weight == o.contact_weight && p.keep_fraction == o.keep_fraction &&
         p.cg_iterations == o.cg_iterations && p.cg_tolerance == o.cg_tolerance && p.local_rings == o.local_rings &&
         p.hold_rounds == o.hold_rounds && p.anderson_history == o.anderson_history &&
         p.exact_direction_vertices == o.exact_direction_vertices && p.max_step_multiple == o.max_step_multiple &&
         p.projected_volume_hessian == o.projected_volume_hessian &&
         p.projected_contact_hessian == o.projected_contact_hessian;
}

GuardedSolver& FrameGuard::tets_only() {
  if (!tets_) {
    GuardedSolverParameters p = parameters_;
    p.contact_distance = 0;
    p.contact_stiffness = 0;
    tets_ = std::make_unique<GuardedSolver>(arap(), boundary_, p);
  }
  return *tets_;
}

bool FrameGuard::accepts(const Eigen::MatrixXd& X0, const Eigen::MatrixXd& X1, bool contacts,
                         ShellCertificate* certificate) {
  // Without the contacts guarded, the straight path's tet bound is the test.
  if (!(contacts && guards_contacts()))
    return tet_step_bound(rest_tets_->T, X0, X1 - X0, parameters_.keep_fraction, 1.0, &parameters_.skip_tets).step >= 1;
  // Otherwise the end state is certified exactly (the base against itself left out when the caller
  // moves the base: a base crossing itself is then the caller's) and its tets' volumes checked
  // against X0's. Cheaper than continuous collision detection along the path, and what matters is
  // the frame, not the way to it: a certified frame is a valid start for the next one. When the
  // path's tet bound was asked as well, a shell turned by more than 143
  // degrees between frames (its path flattens every tet half-way; the paper's solve is exact
  // there) was dragged over 20 sub-steps, minutes on 10K vertices. The two run side by side,
  // filling each other's idle threads (serial parts of the certificate's tree passes).
  bool kept = false;
  ShellCertificate c;
  tbb::parallel_invoke(
      [&] { kept = tets_keep_volume(rest_tets_->T, X0, X1, parameters_.keep_fraction, &parameters_.skip_tets); },
      [&] {
        CertifyOptions options;
        options.base_self_intersections = moving_base_;
        c = certifier_.certify(X1.topRows(n_), X1.bottomRows(n_), options);
      });
  const bool ok = kept && only_unguarded_faults(c);
  if (certificate) *certificate = std::move(c);
  return ok;
}

double FrameGuard::accepted_fraction(const Eigen::MatrixXd& X0, const Eigen::MatrixXd& X1, bool contacts,
                                     double min_fraction, Eigen::MatrixXd& Y, ShellCertificate* certificate) {
  const Eigen::MatrixXd D = X1 - X0;
  double t = tet_step_bound(rest_tets_->T, X0, D, parameters_.keep_fraction, 1.0, &parameters_.skip_tets).step;
  // With the tets' bound at 1, the end's certificate refused the whole step.
  if (t >= 1) t = kFractionShrink;
  const bool certify = contacts && guards_contacts();
  CertifyOptions options;
  options.base_self_intersections = moving_base_;
  const auto certify_state = [&](const Eigen::MatrixXd& Z) {
    return certifier_.certify(Z.topRows(n_), Z.bottomRows(n_), options);
  };
  for (; t >= min_fraction && t > 0; t *= kFractionShrink) {
    Eigen::MatrixXd Z = X0 + t * D;
    ShellCertificate c;
    if (certify || certificate) c = certify_state(Z);
    if (certify && !only_unguarded_faults(c)) continue;
    if (certificate) *certificate = std::move(c);
    Y = std::move(Z);
    return t;
  }
  if (certificate) *certificate = certify_state(X0);
  return 0;
}

bool FrameGuard::only_unguarded_faults(const ShellCertificate& c, bool near_left_out) const {
  for (int t : c.inverted_tet_ids)
    if (!parameters_.skip_tets[t]) return false;
  std::vector<char> near;
  if (near_left_out) near = unprotected_rows(boundary_, parameters_.excluded_triangles, 2 * n_);
  const std::vector<char>& unguarded = near_left_out ? near : parameters_.excluded_triangles;
  for (const BoundaryIntersection& pair : c.intersections)
    if (!unguarded[pair.a] && !unguarded[pair.b]) return false;
  if (c.nested.empty()) return true;
  // A part carried whole into another's layer crosses no triangle (a step accepted as the solver
  // made it jumps; the guarded solver's continuous bounds never get there). Unguarded only where
  // the rest shell was nested already, or a part involved has triangles left out.
  if (!parts_) parts_ = detail::shell_parts(F_, n_);
  const std::vector<char> part_left_out =
      detail::parts_with_flagged_rows(*parts_, boundary_, parameters_.excluded_triangles, n_);
  for (const auto& [v, t] : c.nested)
    if (!std::binary_search(rest_nested_.begin(), rest_nested_.end(), v) &&
        !part_left_out[parts_->of_vertex[v % n_]] && !part_left_out[parts_->of_vertex[F_(t / 3, 0)]])
      return false;
  return true;
}

ShellCertificate FrameGuard::certify(const Eigen::MatrixXd& X) {
  return certifier_.certify(X.topRows(n_), X.bottomRows(n_), CertifyOptions{});
}

bool FrameGuard::mend(Eigen::MatrixXd& X, int rings, const GuardedSolveOptions& solve, const ShellCertificate* refused,
                      ShellCertificate* certificate, int* iterations) {
  if (iterations) *iterations = 0;
  if (!guards_contacts() || rings < 0) return false;
  CertifyOptions with_base;
  with_base.base_self_intersections = moving_base_;
  const ShellCertificate before =
      refused && refused->intersections_tested() ? *refused : certifier_.certify(X.topRows(n_), X.bottomRows(n_), with_base);
  // Pulling tops in mends nothing where the base crosses itself, and a handle's top the start
  // would pull in (it thins the tops of every violation) is where the caller put it.
  std::vector<char> is_fixed(2 * n_, 0);
  for (int v : fixed_) is_fixed[v] = 1;
  const auto fixed_top = [&](auto vertices) {
    for (int k = 0; k < vertices.size(); ++k)
      if (vertices(k) >= n_ && is_fixed[vertices(k)]) return true;
    return false;
  };
  for (int t : before.inverted_tet_ids)
    if (!parameters_.skip_tets[t] && fixed_top(rest_tets_->T.row(t))) return false;
  for (const BoundaryIntersection& pair : before.intersections) {
    if (parameters_.excluded_triangles[pair.a] || parameters_.excluded_triangles[pair.b]) continue;
    if (pair.kind == IntersectionKind::BaseBase) return false;
    if (fixed_top(boundary_.F.row(pair.a)) || fixed_top(boundary_.F.row(pair.b))) return false;
  }
  const Eigen::MatrixXd B = X.topRows(n_);
  double thickness = 0; // the mean rest thickness: what a top with no length of its own thins from
  for (int i = 0; i < n_; ++i) thickness += (rest_vertices_.row(n_ + i) - rest_vertices_.row(i)).norm();
  thickness /= n_;
  const ValidStartOptions start_options = valid_start_options(options_, std::max(thickness, 1e-300));
  const ValidStart start =
      valid_start(B, F_, X.bottomRows(n_), extrusion_directions(B, F_, options_.normal_margin), parameters_.skip_tets,
                  parameters_.excluded_triangles, start_options);
  if (!start.inverted_tets.empty() || !start.intersections.empty()) return false;
  std::vector<char> region(n_, 0);
  for (int i = 0; i < n_; ++i) {
    region[i] = start.scale[i] < 1;
    if (region[i] && is_fixed[n_ + i]) return false;
  }
  Eigen::MatrixXd Y = X;
  Y.bottomRows(n_) = start.top;
  // A state free of faults is also refused for tets squashed on the way below the keep fraction:
  // those inside the volume barrier's support are mended with the rest.
  for (int t = 0; t < rest_tets_->T.rows(); ++t)
    if (!parameters_.skip_tets[t] && probe_.relative_volume_of(Y, t) < options_.j_hat)
      for (int k = 0; k < 4; ++k) region[rest_tets_->T(t, k) % n_] = 1;
  if (std::find(region.begin(), region.end(), 1) == region.end()) return false;
  grow_by_rings(F_, rings, region);
  std::vector<char> moving(2 * n_, 0);
  for (int i = 0; i < n_; ++i) {
    moving[n_ + i] = region[i] && !is_fixed[n_ + i];
    if (moving_base_) moving[i] = region[i] && !is_fixed[i];
  }
  // As generation's repair does, the solve runs over the part of the shell it can touch; a vertex
  // travelling farther than a few thicknesses is not a mend.
  const double travel = 4 * thickness;
  const detail::ShellPart part =
      detail::shell_part(*rest_tets_, boundary_, Y, moving, travel, 2 * parameters_.contact_distance);
  GuardedSolverParameters q = parameters_;
  q.skip_tets.clear();
  for (int t : part.tet) q.skip_tets.push_back(parameters_.skip_tets[t]);
  q.excluded_triangles.clear();
  for (int r : part.row) q.excluded_triangles.push_back(parameters_.excluded_triangles[r]);
  // Steps cut to slivers are taken with what cuts them held, as generation's repair takes them.
  q.hold_rounds = generation_guard_options().hold_rounds;
  q.hold_below = kMendHoldBelow;
  GuardedSolver solver(part.tets, part.size(), part.held, part.boundary, q);
  if (part.row.size() < static_cast<std::size_t>(boundary_.size())) solver.confine(part.X, travel);
  if (options_.contact_rest_fraction > 0) {
    Eigen::MatrixXd rest(part.size(), 3);
    for (int k = 0; k < part.size(); ++k) rest.row(k) = rest_vertices_.row(part.vertex[k]);
    solver.cap_contact_support(rest, options_.contact_rest_fraction);
  }
  Eigen::MatrixXd Z = part.X;
  if (!std::isfinite(solver.energy(Z))) return false;
  const GuardedSolveResult r = solver.solve(Z, solve);
  if (iterations) *iterations = r.iterations;
  part.scatter_moving(Z, Y);
  // Valid by construction, as a drag's end is (a valid start, every step bounded); the certificate
  // confirms it. No path from the refused state is asked for: its tops pulled in have thinned
  // their tets on purpose.
  ShellCertificate c = certifier_.certify(Y.topRows(n_), Y.bottomRows(n_), with_base);
  if (!only_unguarded_faults(c)) return false;
  if (certificate) *certificate = std::move(c);
  X = std::move(Y);
  return true;
}

FrameMend FrameGuard::weighed_mend(const Eigen::MatrixXd& X, int rings, double max_rise,
                                   const GuardedSolveOptions& solve, const ShellCertificate* refused,
                                   const std::function<double(const Eigen::MatrixXd&)>& energy) {
  FrameMend m;
  m.X = X;
  if (!mend(m.X, rings, solve, refused, &m.certificate, &m.iterations)) {
    m.X.resize(0, 3);
    return m;
  }
  m.energy = energy(m.X);
  m.within_rise = m.energy <= (1 + max_rise) * energy(X);
  return m;
}

int FrameGuard::substeps_between(const Eigen::MatrixXd& from, const Eigen::MatrixXd& to,
                                 const DeformOptions& schedule) const {
  const double change = max_edge_change(from.topRows(n_), to.topRows(n_), F_);
  return std::clamp(static_cast<int>(std::ceil(change / schedule.substep_edge_change)), 1, schedule.max_substeps);
}

FrameGuard::Outcome FrameGuard::drag(Eigen::MatrixXd& X, const Eigen::MatrixXd& targets, int substeps, bool contacts,
                                     bool fall_back_to_tets, const GuardedSolveOptions& solve,
                                     double substep_tolerance, const std::function<bool()>& other_way,
                                     const std::function<void(const char*)>& stage) {
  Outcome out;
  GuardedSolver* solver = nullptr;
  if (contacts && guards_contacts() && std::isfinite(contact_solver().energy(X))) solver = &contact_solver();
  else if (!guards_contacts() && std::isfinite(tets_only().energy(X))) solver = &tets_only(); // contacts off
  else if (fall_back_to_tets && std::isfinite(tets_only().energy(X))) {
    solver = &tets_only();
    out.method = FrameMethod::TetsOnly;
  } else {
    out.method = FrameMethod::Failed;
    return out;
  }
  const Eigen::MatrixXd from = X;
  Eigen::MatrixXd step_targets = X;
  // A stalled drag is retried once (the energy iterations in between may make room), then
  // continued with the tets alone, or stopped there (blocked).
  constexpr int kRetries = 2;
  // The sub-steps before the last only keep the drag near the path of minima (loosely solved);
  // the last is solved to the tolerance, with the iterations the others left of their share.
  GuardedSolveOptions on_the_way = solve, last = solve;
  on_the_way.tolerance = std::max(solve.tolerance, substep_tolerance);
  for (int k = 1; k <= substeps; ++k) {
    const double t = static_cast<double>(k) / substeps;
    for (int v : fixed_) step_targets.row(v) = from.row(v) + t * (targets.row(v) - from.row(v));
    ++out.substeps;
    on_the_way.path_scale = last.path_scale = 1;
    for (int attempt = 0;; ++attempt) {
      if (k == substeps) {
        const long long share = static_cast<long long>(substeps) * solve.max_iterations - out.iterations;
        last.max_iterations = static_cast<int>(std::clamp<long long>(share, solve.max_iterations, INT_MAX));
      }
      if (stage) {
        std::string name = substeps > 1 ? "drag " + std::to_string(k) + "/" + std::to_string(substeps) : "drag";
        if (solver != contact_.get() && guards_contacts()) name += " (tets only)";
        stage(name.c_str());
      }
      const GuardedSolveResult r = solver->solve(X, k < substeps ? on_the_way : last, step_targets);
      out.iterations += r.iterations;
      if (r.path_done >= 1) break;
      on_the_way.path_scale = last.path_scale *= 1 - r.path_done; // what is left of the sub-step
      if (other_way && other_way()) {
        out.superseded = true;
        return out;
      }
      // The drag moves the free vertices with the fixed ones by the model's linear response,
      // which knows nothing of the barriers: two tops pressed against each other over a wide
      // area can stop it for good (docs/valid-deformation.md), hence only one retry.
      if (attempt + 1 < kRetries) continue;
      if (solver == contact_.get() && fall_back_to_tets) {
        solver = &tets_only();
        out.method = FrameMethod::TetsOnly;
        attempt = -1;
        continue;
      }
      if (solver == contact_.get()) {
        out.blocked = true; // X: as far as the bounds let it go, valid
        return out;
      }
      out.method = FrameMethod::Failed;
      return out;
    }
  }
  for (int v : fixed_) X.row(v) = targets.row(v); // exactly (the solver ends its path on them)
  return out;
}

} // namespace gshell
