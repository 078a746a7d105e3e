#include <gshell/guard/valid_start.h>

#include <gshell/error.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/shell/prism_tets.h>

#include "guard/valid_start_with.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace gshell {

namespace {

constexpr int kMaxRoundsFactor = 10; // rounds in all, in units of max_rounds (a front that never settles)

// The paths of the header: per vertex, the wanted offset's unit u and length, the direction d, and
// whether the straight line serves.
struct Paths {
  Eigen::MatrixXd u, d;
  Eigen::VectorXd length;
  std::vector<char> straight;

  Eigen::RowVector3d offset(int i, double s) const {
    if (straight[i] || s >= 1) return s * length[i] * u.row(i);
    const Eigen::RowVector3d w = s * u.row(i) + (1 - s) * d.row(i);
    const double norm = w.norm();
    return s * length[i] * (norm > 1e-12 ? Eigen::RowVector3d(w / norm) : Eigen::RowVector3d(d.row(i)));
  }
};

Paths make_paths(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& P,
                 const ExtrusionDirections& directions, const std::vector<int>& rim, const ValidStartOptions& options) {
  const int n = static_cast<int>(V.rows());
  Paths p;
  p.d = directions.direction;
  p.u = P - V;
  p.length = p.u.rowwise().norm();
  p.straight.assign(n, 1);
  for (int i = 0; i < n; ++i) {
    if (p.length[i] > 0) {
      p.u.row(i) /= p.length[i];
    } else { // nowhere to go: leave along the extrusion direction
      p.u.row(i) = p.d.row(i);
      p.length[i] = options.fallback_length;
    }
  }
  // The smallest cosine between each u_i and the normals of the faces around vertex i.
  Eigen::VectorXd margin = Eigen::VectorXd::Constant(n, 2.0);
  for (int f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::Vector3d x = (b - a).cross(c - a);
    if (!(x.norm() > 0)) continue;
    const Eigen::Vector3d normal = x.normalized();
    for (int k = 0; k < 3; ++k) margin[F(f, k)] = std::min(margin[F(f, k)], p.u.row(F(f, k)).dot(normal));
  }
  for (int i = 0; i < n; ++i) p.straight[i] = margin[i] >= options.straight_margin;
  // On the rim a straight path can still be blocked: near b_i the side wall over a boundary edge
  // is the sector between the edge and u_i, and where that cuts another face at i the two meet
  // however thin the layer (double-torus-3-holes at curvature 0.3: vertex 52's wall cut its own
  // face at 2^-39 of eta). The bent path ends along d_i instead.
  std::vector<int> straight_rim;
  for (int i : rim)
    if (p.straight[i]) straight_rim.push_back(i);
  for (int i : rim_vertices_with_blocked_walls(V, F, p.u, straight_rim)) p.straight[i] = 0;
  return p;
}

// The base vertices on the rim of an open surface (those the side walls stand on), ascending.
std::vector<int> rim_vertices(const ShellBoundary& boundary, int n) {
  std::vector<char> rim(n, 0);
  for (int r = 0; r < boundary.size(); ++r)
    if (boundary.part[r] == BoundaryPart::Wall)
      for (int k = 0; k < 3; ++k)
        if (boundary.F(r, k) < n) rim[boundary.F(r, k)] = 1;
  std::vector<int> vertices;
  for (int i = 0; i < n; ++i)
    if (rim[i]) vertices.push_back(i);
  return vertices;
}

// The violations of the last round none of whose top vertices moved since (those of vertices
// thinned as often as they may be) are still there, though a check of what moved does not see
// them: they join `found`, which then asks for no part to be thinned whole (the check asks that
// only when it finds nothing else).
void keep_unmoved(const detail::StartChecker& checker, const std::vector<char>& moved, const ValidStart& last,
                  detail::StartViolations& found) {
  const int n = static_cast<int>(moved.size());
  auto unmoved = [&](int v) { return v < n || !moved[v - n]; };
  const Eigen::MatrixXi& T = checker.tets();
  const Eigen::MatrixXi& B = checker.boundary().F;
  const std::size_t tets = found.inverted_tets.size(), pairs = found.intersections.size();
  for (int t : last.inverted_tets)
    if (unmoved(T(t, 0)) && unmoved(T(t, 1)) && unmoved(T(t, 2)) && unmoved(T(t, 3))) found.inverted_tets.push_back(t);
  for (const auto& [a, b] : last.intersections)
    if (unmoved(B(a, 0)) && unmoved(B(a, 1)) && unmoved(B(a, 2)) && unmoved(B(b, 0)) && unmoved(B(b, 1)) &&
        unmoved(B(b, 2)))
      found.intersections.emplace_back(a, b);
  if (found.inverted_tets.size() == tets && found.intersections.size() == pairs) return;
  std::sort(found.inverted_tets.begin(), found.inverted_tets.end());
  std::sort(found.intersections.begin(), found.intersections.end());
  found.nested_parts.clear();
  found.nested_tops.clear();
}

} // namespace

ValidStart valid_start(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& P,
                       const ExtrusionDirections& directions,
                       const std::vector<char>& skip_tets, const std::vector<char>& excluded_triangles,
                       const ValidStartOptions& options) {
  const detail::StartChecker checker(F, static_cast<int>(V.rows()), skip_tets, excluded_triangles);
  return detail::valid_start_with(V, F, P, directions, checker, std::nullopt, options);
}

ValidStart detail::valid_start_with(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& P,
                                    const ExtrusionDirections& directions, const StartChecker& checker,
                                    std::optional<ShellCertificate> first, const ValidStartOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const int n = static_cast<int>(V.rows());
  if (P.rows() != n || P.cols() != 3 || directions.direction.rows() != n)
    throw InputError("valid_start: expected one wanted top vertex and one direction per base vertex");
  if (!(options.thinning > 0 && options.thinning < 1)) throw InputError("valid_start: thinning must be in (0, 1)");
  if (!(options.fallback_length > 0)) throw InputError("valid_start: fallback_length must be positive");
  const Paths paths = make_paths(V, F, P, directions, rim_vertices(checker.boundary(), n), options);

  ValidStart s;
  s.scale = Eigen::VectorXd::Ones(n);
  std::vector<char> thin(n), moved(n, 0);
  std::vector<int> thinnings(n, 0);
  bool nested = false; // a part still inside another's layer (StartViolations::nested_parts, nested_tops)
  for (s.rounds = 1;; ++s.rounds) {
    if (s.rounds == 1)
      s.top = P;
    else
      for (int i = 0; i < n; ++i)
        if (moved[i]) s.top.row(i) = V.row(i) + paths.offset(i, s.scale[i]);
    // The first round checks everything, later ones what the last thinning moved.
    detail::StartViolations found = s.rounds == 1 && first ? checker.violations(*std::move(first))
                                                           : checker.check(V, s.top, s.rounds == 1 ? nullptr : &moved);
    if (s.rounds > 1) keep_unmoved(checker, moved, s, found);
    s.inverted_tets = found.inverted_tets;
    s.intersections = found.intersections;
    std::fill(thin.begin(), thin.end(), 0);
    checker.for_each_top_vertex(found, [&](int i) { thin[i] = 1; });
    nested = !found.nested_parts.empty() || !found.nested_tops.empty();
    const bool clean = s.inverted_tets.empty() && s.intersections.empty() && !nested;
    if (s.rounds == 1) s.certificate = std::move(found.certificate); // of P itself
    if (clean) break;
    // A vertex of a violation is thinned at most max_rounds - 1 times; the start gives up when
    // every vertex of what is left has been, not after max_rounds rounds in all. A layer much
    // thicker than the base's features (blade.off at ratio 1, sheets folded close) thins as a
    // front moving out ring by ring, new violations at its edge each round, which 40 rounds did
    // not see through. A vertex behind the front can stay in a violation only because a triangle
    // it shares reaches a vertex of the front: it stops at its last thinning while the front
    // goes on. A violation from the base itself (a rim folded flat, parts touching) has its
    // vertices thinned every round, so it ends the start at round max_rounds, as before; thinning
    // those on would only shear their neighbours into new violations.
    if (s.rounds >= kMaxRoundsFactor * options.max_rounds) break;
    const Eigen::VectorXd before = s.scale;
    bool thinned = false;
    for (int i = 0; i < n; ++i)
      if (thin[i] && thinnings[i] < options.max_rounds - 1) {
        s.scale[i] *= options.thinning;
        ++thinnings[i];
        thinned = true;
      }
    if (!thinned) break;
    // Thickness steps between neighbours shear the prisms between them into new violations: keep
    // s_j <= spread * s_i along every edge, so a pulled-in spot slopes into its surroundings.
    if (options.spread > 1)
      for (bool changed = true; changed;) {
        changed = false;
        for (int f = 0; f < F.rows(); ++f)
          for (int k = 0; k < 3; ++k) {
            const int i = F(f, k), j = F(f, (k + 1) % 3);
            if (s.scale[j] > options.spread * s.scale[i]) { s.scale[j] = options.spread * s.scale[i]; changed = true; }
            if (s.scale[i] > options.spread * s.scale[j]) { s.scale[i] = options.spread * s.scale[j]; changed = true; }
          }
      }
    for (int i = 0; i < n; ++i) moved[i] = s.scale[i] != before[i];
  }
  if (s.inverted_tets.empty() && s.intersections.empty() && !nested && options.refine_passes > 0) {
    // The halving overshoots: a vertex of a violation is halved even where a little less would
    // do. Bisect each pulled-in s_i between its valid value (lo) and the last one that was not
    // (hi), all vertices at once: raise every one to the geometric middle, then put back to lo
    // the raised vertices of every violation found, until none is left (the tets and pairs whose
    // vertices are all at lo are those of the valid state, so this ends). Then back off by
    // `backoff` the same way, so that the start keeps a margin from the flat tets and touching
    // triangles the bisection ends next to.
    Eigen::VectorXd lo = s.scale, hi = s.scale;
    for (int i = 0; i < n; ++i)
      if (lo[i] < 1) hi[i] = std::min(1.0, lo[i] / options.thinning);
    auto place = [&](const std::vector<char>& which) {
      for (int i = 0; i < n; ++i)
        if (which[i]) s.top.row(i) = V.row(i) + paths.offset(i, s.scale[i]);
    };
    // Sets s to `target` where it differs from lo, reverting violators; returns the kept ones.
    auto try_move = [&](const Eigen::VectorXd& target, bool bisecting) {
      std::vector<char> changed(n, 0);
      for (int i = 0; i < n; ++i) changed[i] = target[i] != lo[i];
      s.scale = target;
      place(changed);
      std::vector<char> check = changed;
      s.rounds += checker.settle(V, s.top, changed, check, [&](int i) {
        if (bisecting) hi[i] = s.scale[i];
        s.scale[i] = lo[i];
        s.top.row(i) = V.row(i) + paths.offset(i, lo[i]);
      });
      for (int i = 0; i < n; ++i)
        if (changed[i]) lo[i] = s.scale[i];
    };
    for (int pass = 0; pass < options.refine_passes; ++pass) {
      Eigen::VectorXd target = lo;
      for (int i = 0; i < n; ++i)
        if (hi[i] > lo[i]) target[i] = lo[i] * std::sqrt(hi[i] / lo[i]);
      try_move(target, true);
    }
    if (options.backoff < 1) {
      Eigen::VectorXd target = lo;
      for (int i = 0; i < n; ++i)
        if (lo[i] < 1) target[i] = lo[i] * options.backoff;
      try_move(target, false);
    }
    s.scale = lo;
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

std::vector<int> unmended_vertices(const ValidStart& start, const Eigen::MatrixXi& F, int n) {
  std::vector<char> touched(n, 0);
  for (int t : start.inverted_tets)
    for (int k = 0; k < 3; ++k) touched[F(t / 3, k)] = 1;
  if (!start.intersections.empty()) {
    const ShellBoundary boundary = shell_boundary(F, n);
    for (const auto& [a, b] : start.intersections)
      for (int row : {a, b})
        for (int k = 0; k < 3; ++k) touched[boundary.F(row, k) % n] = 1;
  }
  std::vector<int> vertices;
  for (int i = 0; i < n; ++i)
    if (touched[i]) vertices.push_back(i);
  return vertices;
}

} // namespace gshell
