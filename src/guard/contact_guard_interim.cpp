// INTERIM implementation of ContactGuard (include/gshell/guard/contact_guard.h) so that the guarded
// solver can be built and tested before the `contact` branch lands; deleted when it does. Simple
// and slow on purpose: candidate pairs by sort-and-sweep on every call (no Verlet list), distance
// by closest points, Gauss-Newton Hessian, additive CCD for the step bound.
#include <gshell/guard/contact_guard.h>

#include <gshell/error.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <set>

namespace gshell {

namespace {

using Vec = Eigen::Vector3d;
constexpr double kInf = std::numeric_limits<double>::infinity();

// Closest point of triangle abc to p (Ericson), barycentric weights w.
Vec closest_on_triangle(const Vec& p, const Vec& a, const Vec& b, const Vec& c, std::array<double, 3>& w) {
  const Vec ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) { w = {1, 0, 0}; return a; }
  const Vec bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) { w = {0, 1, 0}; return b; }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) { const double v = d1 / (d1 - d3); w = {1 - v, v, 0}; return a + v * ab; }
  const Vec cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) { w = {0, 0, 1}; return c; }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) { const double v = d2 / (d2 - d6); w = {1 - v, 0, v}; return a + v * ac; }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double v = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    w = {0, 1 - v, v};
    return b + v * (c - b);
  }
  const double den = 1 / (va + vb + vc);
  const double v = vb * den, u = vc * den;
  w = {1 - v - u, v, u};
  return a + ab * v + ac * u;
}

// Closest points of segments p0p1 and q0q1 (Ericson): parameters s, t.
double closest_segments(const Vec& p0, const Vec& p1, const Vec& q0, const Vec& q1, double& s, double& t) {
  const Vec d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  if (a <= 1e-300 && e <= 1e-300) { s = t = 0; return r.squaredNorm(); }
  if (a <= 1e-300) { s = 0; t = std::clamp(f / e, 0.0, 1.0); }
  else {
    const double c = d1.dot(r);
    if (e <= 1e-300) { t = 0; s = std::clamp(-c / a, 0.0, 1.0); }
    else {
      const double b = d1.dot(d2), den = a * e - b * b;
      s = den > 0 ? std::clamp((b * f - c * e) / den, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) { t = 0; s = std::clamp(-c / a, 0.0, 1.0); }
      else if (t > 1) { t = 1; s = std::clamp((b - c) / a, 0.0, 1.0); }
    }
  }
  return ((p0 + s * d1) - (q0 + t * d2)).squaredNorm();
}

struct Pair {
  std::array<int, 4> v; // point-triangle: p, a, b, c; edge-edge: p0, p1, q0, q1
  bool edge_edge;
};

} // namespace

struct ContactGuard::Impl {
  ShellBoundary boundary;
  int N = 0;
  std::vector<char> movable;
  ContactOptions options;
  std::vector<char> excluded;
  Eigen::MatrixXi edges;             // boundary edges (E x 2)
  std::vector<char> edge_excluded;   // edge of an excluded triangle
  std::vector<char> vertex_excluded; // corner of an excluded triangle
  std::vector<char> on_boundary;     // vertex used by a boundary triangle
  int active = 0;

  double dhat2() const { return options.dhat * options.dhat; }

  // Squared distance of a pair at X and its gradient weights: d2 = |sum_k c_k x_k|^2.
  double distance2(const Eigen::MatrixXd& X, const Pair& q, std::array<double, 4>& c) const {
    return distance2(X.row(q.v[0]).transpose(), X.row(q.v[1]).transpose(), X.row(q.v[2]).transpose(),
                     X.row(q.v[3]).transpose(), q.edge_edge, c);
  }
  static double distance2(const Vec& x0, const Vec& x1, const Vec& x2, const Vec& x3, bool edge_edge,
                          std::array<double, 4>& c) {
    if (!edge_edge) {
      std::array<double, 3> w;
      const Vec cp = closest_on_triangle(x0, x1, x2, x3, w);
      c = {1, -w[0], -w[1], -w[2]};
      return (x0 - cp).squaredNorm();
    }
    double s, t;
    const double d2 = closest_segments(x0, x1, x2, x3, s, t);
    c = {1 - s, s, -(1 - t), -t};
    return d2;
  }

  // Every admissible pair whose inflated (and swept, X to X + D) boxes meet: sort-and-sweep along
  // the longest axis, vertices against triangles and edges against edges.
  std::vector<Pair> candidates(const Eigen::MatrixXd& X, const Eigen::MatrixXd* D, double inflate) const {
    struct Box {
      Eigen::Array3d lo, hi;
      int id;
      bool moves;
    };
    auto box_of = [&](std::initializer_list<int> vs, int id) {
      Box b{Eigen::Array3d::Constant(kInf), Eigen::Array3d::Constant(-kInf), id, false};
      for (int v : vs) {
        b.moves = b.moves || movable[v];
        b.lo = b.lo.min(X.row(v).transpose().array());
        b.hi = b.hi.max(X.row(v).transpose().array());
        if (D) {
          const Eigen::Array3d y = (X.row(v) + D->row(v)).transpose().array();
          b.lo = b.lo.min(y);
          b.hi = b.hi.max(y);
        }
      }
      b.lo -= inflate;
      b.hi += inflate;
      return b;
    };
    std::vector<Box> verts, tris, eds;
    for (int v = 0; v < N; ++v)
      if (on_boundary[v] && !vertex_excluded[v]) verts.push_back(box_of({v}, v));
    for (int f = 0; f < boundary.size(); ++f)
      if (!excluded[f]) tris.push_back(box_of({boundary.F(f, 0), boundary.F(f, 1), boundary.F(f, 2)}, f));
    for (int e = 0; e < edges.rows(); ++e)
      if (!edge_excluded[e]) eds.push_back(box_of({edges(e, 0), edges(e, 1)}, e));
    const Eigen::Array3d extent = X.colwise().maxCoeff().transpose().array() - X.colwise().minCoeff().transpose().array();
    int axis = 0;
    extent.maxCoeff(&axis);
    auto by_lo = [axis](const Box& a, const Box& b) { return a.lo[axis] < b.lo[axis]; };
    std::vector<Pair> out;
    auto meet = [](const Box& a, const Box& b) { return !(a.lo > b.hi).any() && !(b.lo > a.hi).any() && (a.moves || b.moves); };
    // Bipartite sweep: every pair (a in A, b in B) whose boxes meet, once.
    auto sweep = [&](std::vector<Box>& A, std::vector<Box>& B, bool same, auto&& emit) {
      std::sort(A.begin(), A.end(), by_lo);
      if (!same) std::sort(B.begin(), B.end(), by_lo);
      if (same) {
        for (std::size_t i = 0; i < A.size(); ++i)
          for (std::size_t j = i + 1; j < A.size() && A[j].lo[axis] <= A[i].hi[axis]; ++j)
            if (meet(A[i], A[j])) emit(A[i], A[j]);
        return;
      }
      std::size_t i = 0, j = 0;
      while (i < A.size() && j < B.size()) {
        if (A[i].lo[axis] <= B[j].lo[axis]) {
          for (std::size_t k = j; k < B.size() && B[k].lo[axis] <= A[i].hi[axis]; ++k)
            if (meet(A[i], B[k])) emit(A[i], B[k]);
          ++i;
        } else {
          for (std::size_t k = i; k < A.size() && A[k].lo[axis] <= B[j].hi[axis]; ++k)
            if (meet(A[k], B[j])) emit(A[k], B[j]);
          ++j;
        }
      }
    };
    sweep(verts, tris, false, [&](const Box& a, const Box& b) {
      const int p = a.id;
      const auto t = boundary.F.row(b.id);
      if (p == t[0] || p == t[1] || p == t[2]) return;
      out.push_back({{p, t[0], t[1], t[2]}, false});
    });
    sweep(eds, eds, true, [&](const Box& a, const Box& b) {
      const int p0 = edges(a.id, 0), p1 = edges(a.id, 1), q0 = edges(b.id, 0), q1 = edges(b.id, 1);
      if (p0 == q0 || p0 == q1 || p1 == q0 || p1 == q1) return;
      out.push_back({{p0, p1, q0, q1}, true});
    });
    return out;
  }

  static double barrier(double s, double sh) { return s >= sh ? 0 : -(s - sh) * (s - sh) * std::log(s / sh); }
  static double barrier1(double s, double sh) {
    return s >= sh ? 0 : -2 * (s - sh) * std::log(s / sh) - (s - sh) * (s - sh) / s;
  }
  static double barrier2(double s, double sh) {
    return s >= sh ? 0 : -2 * std::log(s / sh) - 4 * (s - sh) / s + (s - sh) * (s - sh) / (s * s);
  }
};

ContactGuard::ContactGuard(const ShellBoundary& boundary, int num_vertices, std::vector<char> movable,
                           const ContactOptions& options, std::vector<char> excluded_triangles)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  if (!(options.dhat > 0)) throw InputError("ContactGuard: dhat must be positive");
  if (static_cast<int>(movable.size()) != num_vertices) throw InputError("ContactGuard: one movable flag per vertex");
  m.boundary = boundary;
  m.N = num_vertices;
  m.movable = std::move(movable);
  m.options = options;
  m.excluded = excluded_triangles.empty() ? std::vector<char>(boundary.size(), 0) : std::move(excluded_triangles);
  m.vertex_excluded.assign(num_vertices, 0);
  m.on_boundary.assign(num_vertices, 0);
  std::set<std::pair<int, int>> all, bad;
  for (int f = 0; f < boundary.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = boundary.F(f, k), b = boundary.F(f, (k + 1) % 3);
      m.on_boundary[a] = 1;
      all.insert({std::min(a, b), std::max(a, b)});
      if (m.excluded[f]) {
        bad.insert({std::min(a, b), std::max(a, b)});
        m.vertex_excluded[a] = 1;
      }
    }
  m.edges.resize(static_cast<int>(all.size()), 2);
  int e = 0;
  for (const auto& [a, b] : all) {
    m.edges.row(e) << a, b;
    m.edge_excluded.push_back(bad.count({a, b}) ? 1 : 0);
    ++e;
  }
}

ContactGuard::~ContactGuard() = default;
ContactGuard::ContactGuard(ContactGuard&&) noexcept = default;
ContactGuard& ContactGuard::operator=(ContactGuard&&) noexcept = default;

double ContactGuard::energy(const Eigen::MatrixXd& X) {
  Impl& m = *impl_;
  double E = 0;
  m.active = 0;
  for (const Pair& q : m.candidates(X, nullptr, 0.5 * m.options.dhat)) {
    std::array<double, 4> c;
    const double s = m.distance2(X, q, c);
    if (s >= m.dhat2()) continue;
    if (!(s > 0)) return kInf;
    ++m.active;
    E += Impl::barrier(s, m.dhat2());
  }
  return E;
}

void ContactGuard::add_gradient(const Eigen::MatrixXd& X, double scale, Eigen::MatrixXd& G) {
  Impl& m = *impl_;
  for (const Pair& q : m.candidates(X, nullptr, 0.5 * m.options.dhat)) {
    std::array<double, 4> c;
    const double s = m.distance2(X, q, c);
    if (s >= m.dhat2() || !(s > 0)) continue;
    Vec r = Vec::Zero();
    for (int k = 0; k < 4; ++k) r += c[k] * X.row(q.v[k]).transpose();
    const double b1 = Impl::barrier1(s, m.dhat2());
    for (int k = 0; k < 4; ++k) G.row(q.v[k]) += scale * b1 * 2 * c[k] * r.transpose();
  }
}

void ContactGuard::add_hessian(const Eigen::MatrixXd& X, double scale, std::vector<Eigen::Triplet<double>>& H) {
  Impl& m = *impl_;
  for (const Pair& q : m.candidates(X, nullptr, 0.5 * m.options.dhat)) {
    std::array<double, 4> c;
    const double s = m.distance2(X, q, c);
    if (s >= m.dhat2() || !(s > 0)) continue;
    Vec r = Vec::Zero();
    for (int k = 0; k < 4; ++k) r += c[k] * X.row(q.v[k]).transpose();
    const double b2 = Impl::barrier2(s, m.dhat2());
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            H.emplace_back(3 * q.v[a] + i, 3 * q.v[b] + j, scale * b2 * 4 * c[a] * c[b] * r[i] * r[j]);
  }
}

double ContactGuard::step_bound(const Eigen::MatrixXd& X, const Eigen::MatrixXd& D, double max_step) {
  Impl& m = *impl_;
  const Eigen::MatrixXd Ds = max_step * D;
  double best = 1; // fraction of max_step
  for (const Pair& q : m.candidates(X, &Ds, 0)) {
    // Additive CCD: relative displacement bound, advance conservatively.
    Vec dv[4];
    Vec mean = Vec::Zero();
    for (int k = 0; k < 4; ++k) mean += (dv[k] = Ds.row(q.v[k]).transpose());
    mean /= 4;
    double l1 = 0, l2 = 0;
    const int split = q.edge_edge ? 2 : 1;
    for (int k = 0; k < 4; ++k) (k < split ? l1 : l2) = std::max(k < split ? l1 : l2, (dv[k] - mean).norm());
    const double l = l1 + l2;
    if (!(l > 0)) continue;
    std::array<double, 4> c;
    const double d0 = std::sqrt(m.distance2(X, q, c));
    const double target = m.options.keep_fraction * d0;
    if (d0 - target >= l * best) continue;
    double t = 0;
    for (int it = 0; it < 200; ++it) {
      Vec x[4];
      for (int k = 0; k < 4; ++k) x[k] = X.row(q.v[k]).transpose() + t * dv[k];
      const double d = std::sqrt(Impl::distance2(x[0], x[1], x[2], x[3], q.edge_edge, c));
      const double delta = 0.9 * (d - target) / l;
      if (delta <= 0) break;
      if (t + delta >= best) { t = best; break; }
      if (delta < 1e-6 * (t + delta)) { t += delta; break; }
      t += delta;
    }
    best = std::min(best, t);
  }
  return best * max_step;
}

int ContactGuard::active_pairs() const { return impl_->active; }

double ContactGuard::min_distance(const Eigen::MatrixXd& X) {
  Impl& m = *impl_;
  const double slack = m.options.slack > 0 ? m.options.slack : m.options.dhat;
  double best = m.options.dhat + slack;
  for (const Pair& q : m.candidates(X, nullptr, 0.5 * (m.options.dhat + slack))) {
    std::array<double, 4> c;
    best = std::min(best, std::sqrt(m.distance2(X, q, c)));
  }
  return best;
}

} // namespace gshell
