#include <gshell/guard/guarded_solver.h>

#include <gshell/error.h>
#include <gshell/seconds_since.h>
#include <gshell/guard/tet_step_bound.h>

#include "guard/low_rank_inverse.h"
#include "guard/reused_ordering.h"
#include "guard/vertex_amd_ordering.h"
#include "solver/anderson_history.h"
#include "solver/hierarchy_linear.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <chrono>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

namespace gshell {

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kInf = std::numeric_limits<double>::infinity();

// Armijo constant of the line search: the accepted step decreases E_guard by at least this
// fraction of what the slope at the start promises.
constexpr double kArmijo = 1e-4;
// A whole plain step that lowered E_guard by this multiple of the model's predicted decrease is
// tried longer (max_step_multiple): 2 is the energy linear along the step, 1 the model exact.
constexpr double kLinearDecrease = 1.9;
// ... once the solve has run this many iterations with the path done: short settles (a few dozen
// iterations each on the poses of CGAL's bull, armadillo or homer) are left as they were, bit
// for bit (lengthened, homer's twist took 18 % longer on another path); a creeping solve runs
// on for hundreds or thousands.
constexpr int kLengthenAfter = 100;
constexpr int kMaxBacktracks = 30;
// A drag is stalled when the last kStallIterations iterations moved the fixed vertices by less
// than kStallProgress of their path.
constexpr int kStallIterations = 20;
constexpr double kStallProgress = 1e-3;
// A drag guarding the tets alone may creep and still finish (it is the last way a frame keeps
// every tet positive), so it is given up only when even this many times the pace of its last
// kStallIterations iterations would not finish the path in the iterations left (CGAL's
// armadillo bent until its base crossed itself crept 1e-10 to 1e-13 of its path an iteration,
// for the whole budget of each attempt).
constexpr double kHopelessPace = 100;

double dot(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) { return (a.array() * b.array()).sum(); }

} // namespace

struct GuardedSolver::Impl {
  std::shared_ptr<const ShellSolver> arap; // own, or shared with the caller's solver
  VolumeBarrier volume;
  std::unique_ptr<ContactGuard> contact;
  GuardedSolverParameters p;
  Eigen::MatrixXi T;
  int N = 0;
  std::vector<int> fixed;
  // Free (solved-for) vertices in the order of the ShellSolver's arrays, and vertex -> that order.
  std::vector<int> free;
  std::vector<int> free_index;
  std::vector<char> is_free; // per vertex
  // The exact directions where the barriers act on few vertices (p.exact_direction_vertices).
  detail::LowRankInverse low_rank;

  Impl(std::shared_ptr<const ShellSolver> solver, std::vector<int> fixed_vertices, const ShellBoundary& boundary,
       GuardedSolverParameters parameters)
      : arap(std::move(solver)), volume(arap->rest(), parameters.j_hat, parameters.skip_tets),
        p(checked(std::move(parameters))), T(arap->rest().T), N(arap->num_vertices()), fixed(std::move(fixed_vertices)),
        free(arap->free_vertices()), free_index(N, -1), low_rank(p.exact_direction_vertices) {
    for (std::size_t j = 0; j < free.size(); ++j) free_index[free[j]] = static_cast<int>(j);
    is_free.assign(N, 0);
    for (int v : free) is_free[v] = 1;
    if (p.contact_distance > 0) make_contact_guard(boundary);
  }

  // The fixed vertices of a solver with hard constraints only: every vertex it does not solve for.
  static std::vector<int> not_free(const ShellSolver& solver) {
    std::vector<char> is_free_vertex(solver.num_vertices(), 0);
    for (int v : solver.free_vertices()) is_free_vertex[v] = 1;
    std::vector<int> out;
    for (int v = 0; v < solver.num_vertices(); ++v)
      if (!is_free_vertex[v]) out.push_back(v);
    return out;
  }

  void make_contact_guard(const ShellBoundary& boundary) {
    // ContactGuard leaves out pairs among the vertices it is told are not movable.
    const std::vector<char> movable = p.guard_fixed_pairs ? std::vector<char>(N, 1) : is_free;
    contact = std::make_unique<ContactGuard>(boundary, N, movable, contact_options(p), p.excluded_triangles);
  }

  static GuardedSolverParameters checked(GuardedSolverParameters p) {
    if (!(p.keep_fraction > 0 && p.keep_fraction < 1))
      throw InputError("GuardedSolver: keep_fraction must be in (0, 1)");
    if (!(p.volume_weight > 0)) throw InputError("GuardedSolver: volume_weight must be positive");
    if (!(p.contact_distance >= 0) || !std::isfinite(p.contact_distance))
      throw InputError("GuardedSolver: contact_distance must be >= 0");
    if (p.cg_iterations < 0 || !(p.cg_tolerance > 0)) throw InputError("GuardedSolver: bad CG parameters");
    if (p.hold_rounds < 0 || !(p.hold_below > 0 && p.hold_below <= 1))
      throw InputError("GuardedSolver: hold_rounds must be >= 0 and hold_below in (0, 1]");
    check_anderson_history(p.anderson_history, "GuardedSolver: anderson_history");
    if (p.exact_direction_vertices < 0) throw InputError("GuardedSolver: exact_direction_vertices must be >= 0");
    if (p.max_step_multiple < 0) throw InputError("GuardedSolver: max_step_multiple must be >= 0");
    if (!(p.supernodal_flops >= 0)) throw InputError("GuardedSolver: supernodal_flops must be >= 0");
    if (p.contact_distance > 0 && !(p.contact_stiffness > 0))
      throw InputError("GuardedSolver: contact_stiffness must be positive");
    return p;
  }

  static ContactOptions contact_options(const GuardedSolverParameters& p) {
    ContactOptions options;
    options.dhat = p.contact_distance;
    options.keep_fraction = p.keep_fraction;
    return options;
  }

  int nf() const { return static_cast<int>(free.size()); }

  Eigen::MatrixXd gather(const Eigen::MatrixXd& full) const { // free rows of an N x 3 array
    Eigen::MatrixXd out(nf(), 3);
    for (int j = 0; j < nf(); ++j) out.row(j) = full.row(free[j]);
    return out;
  }
  Eigen::MatrixXd scatter(const Eigen::MatrixXd& compact) const { // N x 3, zero on kept rows
    Eigen::MatrixXd out = Eigen::MatrixXd::Zero(N, 3);
    for (int j = 0; j < nf(); ++j) out.row(free[j]) = compact.row(j);
    return out;
  }

  struct State {
    LocalStep local;
    std::vector<int> active_tets; // inside the volume barrier
    double shell = 0, volume = 0, contact = 0, total = kInf;
  };

  // E_guard at X; false (total = inf) when X is not valid for the barriers.
  bool evaluate(const Eigen::MatrixXd& X, State& s) {
    s.volume = volume.energy(X, &s.active_tets);
    s.contact = contact ? contact->energy(X) : 0.0;
    if (!std::isfinite(s.volume) || !std::isfinite(s.contact)) {
      s.total = kInf;
      return false;
    }
    arap->local_step(X, s.local);
    s.shell = s.local.energy;
    s.total = s.shell + p.volume_weight * s.volume + p.contact_stiffness * s.contact;
    return true;
  }

  // Half the gradient of E_guard at X, free rows.
  Eigen::MatrixXd half_gradient(const Eigen::MatrixXd& X, const State& s) {
    Eigen::MatrixXd g = arap->half_gradient(X, s.local);
    volume.add_gradient(X, 0.5 * p.volume_weight, g, s.active_tets);
    if (contact) contact->add_gradient(X, 0.5 * p.contact_stiffness, g);
    return gather(g);
  }

  // Half the barriers' Hessian on the free vertices it touches: those vertices (free order
  // indices) and the matrix over their 3 coordinates each (local index 3 * k + axis).
  struct LocalHessian {
    std::vector<int> vertices; // free indices
    Eigen::SparseMatrix<double> H;
    bool empty() const { return vertices.empty(); }
    // y += H x on the touched rows (x, y: nf x 3).
    void apply_add(const Eigen::MatrixXd& x, Eigen::MatrixXd& y) const {
      Eigen::VectorXd xl(3 * vertices.size());
      for (std::size_t k = 0; k < vertices.size(); ++k)
        for (int d = 0; d < 3; ++d) xl[3 * k + d] = x(vertices[k], d);
      const Eigen::VectorXd yl = H * xl;
      for (std::size_t k = 0; k < vertices.size(); ++k)
        for (int d = 0; d < 3; ++d) y(vertices[k], d) += yl[3 * k + d];
    }
  };

  // Half the barriers' Hessian at X over all vertices (3 * vertex + axis), as triplets; with
  // `free_only`, only its free/free blocks (all a local Hessian keeps: on CGAL's man at 0.03, 39 %
  // of the triplets, most tets and many pairs having corners on the fixed base).
  std::vector<Eigen::Triplet<double>> half_barrier_triplets(const Eigen::MatrixXd& X, const State& s,
                                                            bool free_only = false) {
    // Contacts first: the volume barrier then sizes H for its (often far more numerous) tets in
    // one go instead of growing it, and reallocates only the contacts' part.
    std::vector<Eigen::Triplet<double>> H;
    const std::vector<char>* kept = free_only ? &is_free : nullptr;
    if (contact) contact->add_hessian(X, 0.5 * p.contact_stiffness, H, p.projected_contact_hessian, kept);
    volume.add_hessian(X, 0.5 * p.volume_weight, H, s.active_tets, p.projected_volume_hessian, kept);
    return H;
  }

  // The free/fixed block of half the barriers' Hessian times a motion of the fixed vertices
  // (N x 3, zero on free rows): free rows (nf x 3).
  Eigen::MatrixXd barrier_coupling(const std::vector<Eigen::Triplet<double>>& H, const Eigen::MatrixXd& motion) const {
    Eigen::MatrixXd out = Eigen::MatrixXd::Zero(nf(), 3);
    for (const auto& t : H) {
      const int a = t.row() / 3, b = t.col() / 3;
      if (free_index[a] >= 0 && free_index[b] < 0) out(free_index[a], t.row() % 3) += t.value() * motion(b, t.col() % 3);
    }
    return out;
  }

  LocalHessian half_barrier_hessian(const Eigen::MatrixXd& X, const State& s) {
    return local_hessian(half_barrier_triplets(X, s, true));
  }

  LocalHessian local_hessian(const std::vector<Eigen::Triplet<double>>& H) const {
    LocalHessian out;
    std::vector<int> local(N, -1);
    std::vector<Eigen::Triplet<double>> kept;
    kept.reserve(H.size());
    auto index = [&](int vertex) {
      if (local[vertex] < 0) {
        local[vertex] = static_cast<int>(out.vertices.size());
        out.vertices.push_back(free_index[vertex]);
      }
      return local[vertex];
    };
    for (const auto& t : H) {
      const int a = t.row() / 3, b = t.col() / 3;
      if (free_index[a] < 0 || free_index[b] < 0) continue;
      kept.emplace_back(3 * index(a) + t.row() % 3, 3 * index(b) + t.col() % 3, t.value());
    }
    const int size = 3 * static_cast<int>(out.vertices.size());
    out.H.resize(size, size);
    out.H.setFromTriplets(kept.begin(), kept.end());
    return out;
  }

  // x <- A^-1 b for the local system. Small systems (every repair of CGAL's models) take Eigen's
  // simplicial LDLT, unless its analysis predicts much work (supernodal_flops). Its fill outgrows
  // it on large repairs: where the whole top of a 164K-vertex
  // shell needed repair (491,520 rows), one factorisation took 217 s, against 15 s for CHOLMOD's
  // supernodal Cholesky with the ordering CHOLMOD picks (METIS there: 78M entries instead of
  // AMD's 115M). About half of that was CHOLMOD's choice of ordering (4.5 of 9.2 s, idle machine),
  // which `ordering` makes once per solve: the repair factors a system over nearly the same
  // vertices each iteration. The system is indefinite only where the unprojected contact Hessian outweighs the
  // rest; Cholesky then fails and the LDLT takes over. Returns false when neither factors.
  bool solve_local_system(const Eigen::SparseMatrix<double>& A, const std::vector<int>& vertices,
                          const Eigen::VectorXd& b, Eigen::VectorXd& x) const {
    const bool large = A.rows() >= p.supernodal_rows;
    if (!large) analyse(A);
    if (large || ldlt.factor_flops() >= p.supernodal_flops) {
      try {
        detail::SpdSolver cholesky;
        const bool reused = ordering.factor(cholesky, A, vertices, N);
        Eigen::MatrixXd B = b;
        cholesky.solve_in_place(B);
        x = B.col(0);
        ++supernodal_solves;
        reused_orderings += reused;
        return true;
      } catch (const std::runtime_error&) {
      }
    }
    analyse(A);
    ldlt.factorize(A);
    if (ldlt.info() != Eigen::Success) return false;
    x = ldlt.solve(b);
    return true;
  }
  // Consecutive iterations often build the same pattern (the same region and active pairs):
  // the analysis (AMD ordering, elimination tree; on a pose step of CGAL's bull about as long
  // as the numeric factorisation) is then kept, and the factor is the one a fresh LDLT gives.
  void analyse(const Eigen::SparseMatrix<double>& A) const {
    if (analysed_for(A)) return;
    ldlt.analyzePattern(A);
    ldlt_outer.clear();
    ldlt_inner.clear();
    if (A.isCompressed()) {
      ldlt_outer.assign(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1);
      ldlt_inner.assign(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros());
    }
  }
  // Whether ldlt was analysed for A's pattern (A square, as every local system).
  bool analysed_for(const Eigen::SparseMatrix<double>& A) const {
    return !ldlt_outer.empty() && A.isCompressed() &&
           std::equal(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1, ldlt_outer.begin(), ldlt_outer.end()) &&
           std::equal(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros(), ldlt_inner.begin(), ldlt_inner.end());
  }
  // Of the small local systems, ordered on their vertex graph (a ninth of the scalar pattern to
  // order, and less fill on the barriers' coupled 3 x 3 blocks; docs/guarded-generation.md).
  // The work its analysis predicts for the numeric factorisation: the sum over the factor's
  // columns of their squared entry counts (multiply-adds, up to a constant).
  struct SmallSystemLdlt
      : Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, detail::VertexAmdOrdering<int>> {
    double factor_flops() const {
      double sum = 0;
      for (Eigen::Index j = 0; j < m_nonZerosPerCol.size(); ++j)
        sum += static_cast<double>(m_nonZerosPerCol[j]) * static_cast<double>(m_nonZerosPerCol[j]);
      return sum;
    }
  };
  mutable SmallSystemLdlt ldlt;
  mutable std::vector<int> ldlt_outer, ldlt_inner; // the pattern it was analysed for (empty: none)
  mutable detail::ReusedOrdering ordering; // of the large local systems, from the current solve()
  mutable int supernodal_solves = 0;       // since the last solve() began
  mutable int reused_orderings = 0;        // of those, with `ordering`

  // The minimiser of the quadratic model over the free vertices within local_rings rings of those
  // the barrier Hessian touches, all others held: solves (A + H/2)_loc delta = r_loc.
  Eigen::MatrixXd local_correction(const LocalHessian& Hl, const Eigen::MatrixXd& r) const {
    Eigen::MatrixXd delta = Eigen::MatrixXd::Zero(nf(), 3);
    std::vector<int> local_index(N, -1), vertices; // vertex ids
    for (int j : Hl.vertices) {
      local_index[free[j]] = static_cast<int>(vertices.size());
      vertices.push_back(free[j]);
    }
    std::size_t frontier = 0;
    for (int ring = 0; ring < p.local_rings; ++ring) {
      const std::vector<int> last(vertices.begin() + static_cast<long>(frontier), vertices.end());
      frontier = vertices.size();
      const auto rows = arap->system_rows(last);
      for (int i = 0; i < rows.outerSize(); ++i)
        for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(rows, i); it; ++it)
          if (local_index[it.col()] < 0) {
            local_index[it.col()] = static_cast<int>(vertices.size());
            vertices.push_back(static_cast<int>(it.col()));
          }
    }
    const int nl = static_cast<int>(vertices.size());
    std::vector<Eigen::Triplet<double>> entries;
    const auto rows = arap->system_rows(vertices);
    for (int i = 0; i < nl; ++i)
      for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(rows, i); it; ++it) {
        const int j = local_index[it.col()];
        if (j >= 0)
          for (int d = 0; d < 3; ++d) entries.emplace_back(3 * i + d, 3 * j + d, it.value());
      }
    // Hl's local order is the first |Hl.vertices| entries of `vertices`.
    for (int k = 0; k < Hl.H.outerSize(); ++k)
      for (Eigen::SparseMatrix<double>::InnerIterator it(Hl.H, k); it; ++it)
        entries.emplace_back(static_cast<int>(it.row()), static_cast<int>(it.col()), it.value());
    Eigen::SparseMatrix<double> A(3 * nl, 3 * nl);
    A.setFromTriplets(entries.begin(), entries.end());
    Eigen::VectorXd b(3 * nl);
    for (int i = 0; i < nl; ++i)
      for (int d = 0; d < 3; ++d) b[3 * i + d] = r(free_index[vertices[i]], d);
    Eigen::VectorXd x;
    if (!solve_local_system(A, vertices, b, x)) return delta;
    for (int i = 0; i < nl; ++i)
      for (int d = 0; d < 3; ++d) delta(free_index[vertices[i]], d) = x[3 * i + d];
    return delta;
  }

  // The Newton direction of the quadratic model A + H/2 (see the header): the plain step
  // -A^-1 g, corrected on the neighbourhood of the barriers, then CG preconditioned with A^-1.
  // With `exact`, the model's exact Newton step where the barriers touch few enough vertices
  // (p.exact_direction_vertices).
  Eigen::MatrixXd direction(const Eigen::MatrixXd& X, const State& state, const Eigen::MatrixXd& g, bool exact,
                            int& cg_iterations) {
    if (p.cg_iterations == 0 && p.local_rings < 0) {
      Eigen::MatrixXd d = -g;
      arap->apply_inverse(d);
      return d;
    }
    return direction(half_barrier_hessian(X, state), g, exact, cg_iterations);
  }

  Eigen::MatrixXd direction(const LocalHessian& Hl, const Eigen::MatrixXd& g, bool exact, int& cg_iterations) {
    Eigen::MatrixXd d = -g;
    arap->apply_inverse(d);
    if (Hl.empty() || (exact && low_rank.solve(*arap, Hl.vertices, Hl.H, d, d))) return d;
    auto apply = [&](const Eigen::MatrixXd& v) {
      Eigen::MatrixXd y = arap->multiply_free(v);
      Hl.apply_add(v, y);
      return y;
    };
    const double gMg = -dot(g, d);
    if (!(gMg > 0)) return d;
    Eigen::MatrixXd r = -g - apply(d);
    if (p.local_rings >= 0) {
      const Eigen::MatrixXd delta = local_correction(Hl, r);
      d += delta;
      r = -g - apply(d);
    }
    Eigen::MatrixXd z = r;
    arap->apply_inverse(z);
    double rz = dot(r, z);
    const double stop = p.cg_tolerance * p.cg_tolerance * gMg;
    Eigen::MatrixXd s = z;
    for (int k = 0; k < p.cg_iterations && rz > stop; ++k) {
      const Eigen::MatrixXd q = apply(s);
      const double sq = dot(s, q);
      if (!(sq > 0)) break;
      const double a = rz / sq;
      d += a * s;
      r -= a * q;
      z = r;
      arap->apply_inverse(z);
      const double rz_new = dot(r, z);
      ++cg_iterations;
      s = z + (rz_new / rz) * s;
      rz = rz_new;
    }
    return d;
  }

  // confine(): the free vertices stay within confine_radius of their rows in anchor.
  Eigen::MatrixXd anchor;
  double confine_radius = kInf;
  bool confined() const { return std::isfinite(confine_radius); }

  // Largest step in [0, limit] along D (N x 3) keeping free vertex v inside its ball: the positive
  // root of |p + s d| = radius with p = X_v - anchor_v (written so that it does not cancel).
  double confined_step(int v, const Eigen::MatrixXd& X, const Eigen::MatrixXd& D, double limit) const {
    const Eigen::Vector3d p = (X.row(v) - anchor.row(v)).transpose(), d = D.row(v).transpose();
    const double dd = d.squaredNorm();
    if (dd == 0) return limit;
    const double pd = p.dot(d), room = confine_radius * confine_radius - p.squaredNorm();
    if (!(room > 0)) return pd < 0 ? std::min(limit, -pd / dd) : 0.0; // on the sphere by rounding
    const double root = std::sqrt(pd * pd + dd * room);
    return std::min(limit, pd > 0 ? room / (pd + root) : (root - pd) / dd);
  }

  // Largest step in [0, 1] keeping tets and boundary pairs safe along D (N x 3), and the free
  // vertices in their balls where confined.
  double step_bound(const Eigen::MatrixXd& X, const Eigen::MatrixXd& D) {
    double a = 1;
    if (confined())
      for (int v : free) a = confined_step(v, X, D, a);
    const TetStepBound tb = tet_step_bound(T, X, D, p.keep_fraction, a, &volume.skip());
    a = std::min(a, tb.step);
    if (contact && a > 0) a = std::min(a, contact->step_bound(X, D, a));
    return a;
  }

  // The free vertices moving along D of every tet and boundary pair that would cut a step of tau;
  // of the pairs, only those with a vertex flagged in `touching` where that is given.
  std::vector<int> vertices_cutting(const Eigen::MatrixXd& X, const Eigen::MatrixXd& D, double tau,
                                    const std::vector<char>* touching = nullptr) {
    std::vector<char> held(N, 0);
    for (int t : tets_cutting_step(T, X, D, p.keep_fraction, tau, &volume.skip()))
      for (int k = 0; k < 4; ++k) held[T(t, k)] = 1;
    if (confined())
      for (int v : free)
        if (confined_step(v, X, D, tau) < tau) held[v] = 1;
    // The pairs last: those whose vertices the tets hold already need no CCD.
    if (contact) contact->flag_cutting_vertices(X, D, tau, held, touching);
    std::vector<int> out;
    for (int v : free)
      if (held[v] && !D.row(v).isZero(0)) out.push_back(v);
    std::sort(out.begin(), out.end());
    return out;
  }

  bool lengthening() const { return p.max_step_multiple > 1; }

  // The plain step D from X, taken whole to Xt (E_guard's parts in `at`), lowered E_guard by
  // `ratio` times the model's predicted decrease. Where the model holds a soft mode of the shell
  // for stiff (its rotations are held), E_guard falls nearly linearly along the step (ratio near
  // 2) and the iterations creep along that mode at a fraction of what a step could gain: a pose
  // of CGAL's turbine twisted by 45 degrees spent 3,365 guarded iterations in its last step, all
  // but 25 of them whole steps, nearly all with ratios of 1.8-2 (docs/valid-deformation.md). The
  // step is tried at the power of two nearest below the minimum of the quadratic through
  // E_guard(0), its slope and E_guard(1), 1 / (2 - ratio), halved until one is taken, and doubled
  // on from there while that lowers E_guard further, up to max_step_multiple. Every longer step
  // is bounded from X like any step, so the whole segment is valid. Xt and `at` become the
  // longest step taken; false when none was.
  bool lengthen_step(const Eigen::MatrixXd& X, const Eigen::MatrixXd& D, double ratio, Eigen::MatrixXd& Xt, State& at) {
    const double fit = std::min<double>(ratio < 2 ? 1 / (2 - ratio) : kInf, p.max_step_multiple);
    int first = 2;
    while (2 * first <= fit) first *= 2;
    State trial;
    auto take = [&](int multiple) {
      const Eigen::MatrixXd Dm = multiple * D;
      if (step_bound(X, Dm) < 1) return false;
      Eigen::MatrixXd Xm = X + Dm;
      if (!evaluate(Xm, trial) || !(trial.total < at.total)) return false;
      Xt.swap(Xm);
      std::swap(at, trial);
      return true;
    };
    int multiple = first;
    while (multiple >= 2 && !take(multiple)) multiple /= 2;
    if (multiple < 2) return false;
    if (multiple == first)
      for (multiple *= 2; multiple <= p.max_step_multiple && take(multiple); multiple *= 2) {
      }
    return true;
  }

  struct HeldStep {
    Eigen::MatrixXd d; // free rows, zero on the held vertices
    double bound = 0;
    double slope = 0;  // dE_guard/dalpha at 0 along d
  };

  // The direction d (free rows) with the vertices of every tet and pair that would cut a step of
  // tau = min(0.5, 64 x its bound) held still, and again for those the holding makes cut it (up
  // to hold_rounds rounds), if its first-order decrease (bound x slope) beats d's. On CGAL's man
  // the plain bound was 5e-4..5e-3 on every repair iteration; held, 0.1-0.3 (a few hundred of its
  // 10,000 vertices held), and 64 gained more than 8 on every step probed.
  std::optional<HeldStep> held_step(const Eigen::MatrixXd& X, const Eigen::MatrixXd& g, const Eigen::MatrixXd& d,
                                    double bound, double slope) {
    if (p.hold_rounds <= 0 || !(bound < p.hold_below) || !(bound > 0)) return std::nullopt;
    const double tau = std::min(0.5, 64 * bound);
    Eigen::MatrixXd held = d;
    // After the first round only the pairs of the vertices held last can cut anew: every other
    // pair moves as it did in the round that checked it, and either did not cut or is held still.
    std::vector<char> held_last;
    for (int round = 0; round < p.hold_rounds; ++round) {
      const std::vector<int> cut = vertices_cutting(X, scatter(held), tau, round > 0 ? &held_last : nullptr);
      if (cut.empty()) break;
      held_last.assign(N, 0);
      for (int v : cut) {
        held.row(free_index[v]).setZero();
        held_last[v] = 1;
      }
    }
    const double a = step_bound(X, scatter(held));
    const double s = 2 * dot(g, held);
    if (!(s < 0 && a * s < bound * slope)) return std::nullopt;
    return HeldStep{std::move(held), a, s};
  }
};

GuardedSolver::GuardedSolver(const RestTets& rest, int num_vertices, const std::vector<int>& fixed,
                             const ShellBoundary& boundary, GuardedSolverParameters parameters)
    : impl_(std::make_unique<Impl>(std::make_shared<const ShellSolver>(rest, num_vertices, fixed), fixed, boundary,
                                   std::move(parameters))) {}

GuardedSolver::GuardedSolver(std::shared_ptr<const ShellSolver> arap, const ShellBoundary& boundary,
                             GuardedSolverParameters parameters) {
  if (!arap) throw InputError("GuardedSolver: the shared ARAP solver is null");
  std::vector<int> fixed = Impl::not_free(*arap);
  impl_ = std::make_unique<Impl>(std::move(arap), std::move(fixed), boundary, std::move(parameters));
}

GuardedSolver::~GuardedSolver() = default;
GuardedSolver::GuardedSolver(GuardedSolver&&) noexcept = default;
GuardedSolver& GuardedSolver::operator=(GuardedSolver&&) noexcept = default;

void GuardedSolver::set_parameters(GuardedSolverParameters parameters) {
  Impl& m = *impl_;
  parameters = Impl::checked(std::move(parameters));
  if (parameters.skip_tets != m.p.skip_tets || parameters.excluded_triangles != m.p.excluded_triangles ||
      parameters.guard_fixed_pairs != m.p.guard_fixed_pairs)
    throw InputError("GuardedSolver::set_parameters: skip_tets, excluded_triangles and guard_fixed_pairs must stay as "
                     "they are");
  if ((parameters.contact_distance > 0) != (m.contact != nullptr))
    throw InputError("GuardedSolver::set_parameters: contact_distance must stay positive, or zero, as at construction");
  if (parameters.exact_direction_vertices != m.p.exact_direction_vertices)
    m.low_rank = detail::LowRankInverse(parameters.exact_direction_vertices);
  m.volume.set_j_hat(parameters.j_hat);
  if (m.contact) m.contact->set_options(Impl::contact_options(parameters));
  m.p = std::move(parameters);
}

void GuardedSolver::set_skipped_tets(std::vector<char> skip) {
  impl_->volume.set_skip(std::move(skip));
  impl_->p.skip_tets = impl_->volume.skip();
}

void GuardedSolver::set_excluded_triangles(const ShellBoundary& boundary, std::vector<char> excluded) {
  Impl& m = *impl_;
  if (!excluded.empty() && static_cast<int>(excluded.size()) != boundary.size())
    throw InputError("GuardedSolver::set_excluded_triangles: expected one flag per boundary triangle");
  m.p.excluded_triangles = std::move(excluded);
  if (m.contact) m.make_contact_guard(boundary);
}

void GuardedSolver::confine(const Eigen::MatrixXd& anchor, double radius) {
  Impl& m = *impl_;
  if (anchor.rows() != m.N || anchor.cols() != 3)
    throw InputError("GuardedSolver::confine: expected " + std::to_string(m.N) + " x 3 anchor positions");
  if (!(radius > 0)) throw InputError("GuardedSolver::confine: radius must be positive");
  m.confine_radius = radius;
  if (m.confined()) m.anchor = anchor;
  else m.anchor.resize(0, 3);
}

void GuardedSolver::cap_contact_support(const Eigen::MatrixXd& X, double fraction) {
  if (impl_->contact) impl_->contact->cap_support(X, fraction);
}

const ShellSolver& GuardedSolver::shell_solver() const { return *impl_->arap; }
const VolumeBarrier& GuardedSolver::volume_barrier() const { return impl_->volume; }
const GuardedSolverParameters& GuardedSolver::parameters() const { return impl_->p; }

double GuardedSolver::energy(const Eigen::MatrixXd& X) {
  if (X.rows() != impl_->N || X.cols() != 3) throw InputError("GuardedSolver::energy: bad state size");
  Impl::State s;
  impl_->evaluate(X, s);
  return s.total;
}

GuardedSolveResult GuardedSolver::solve(Eigen::MatrixXd& X, const GuardedSolveOptions& options,
                                        const Eigen::MatrixXd& fixed_targets) {
  Impl& m = *impl_;
  const auto t0 = Clock::now();
  if (X.rows() != m.N || X.cols() != 3)
    throw InputError("GuardedSolver::solve: expected " + std::to_string(m.N) + " x 3 positions");
  if (options.max_iterations < 0 || !(options.tolerance >= 0) || !(options.path_scale > 0 && options.path_scale <= 1))
    throw InputError("GuardedSolver::solve: bad options");
  const bool drag = fixed_targets.size() > 0;
  if (drag && (fixed_targets.rows() != m.N || fixed_targets.cols() != 3))
    throw InputError("GuardedSolver::solve: fixed_targets must be " + std::to_string(m.N) + " x 3");
  GuardedSolveResult result;
  m.supernodal_solves = 0;
  m.reused_orderings = 0;
  m.ordering.clear(); // the previous solve's regions say nothing about this one's
  Impl::State state;
  if (!m.evaluate(X, state))
    throw InputError("GuardedSolver::solve: the start state is not valid (a guarded tet is flat or inverted, or "
                     "two boundary primitives touch)");
  result.energy.push_back(state.total);

  // The prescribed path of the fixed vertices: X_c(tau) = start + tau * (targets - start).
  Eigen::MatrixXd path = Eigen::MatrixXd::Zero(m.N, 3);
  double tau = 1;
  if (drag) {
    for (int v : m.fixed) path.row(v) = fixed_targets.row(v) - X.row(v);
    tau = path.isZero(0) ? 1 : 0;
  }

  int settled = 0; // iterations with the path done
  std::vector<double> tau_history{tau}; // tau_history[k]: path done after iteration k
  // Samples (X, X + D) of the iteration's map, recorded once the path is done. Where barriers act
  // the map (the local/global step corrected near them) changes a little as they move, so a
  // combined iterate is a guess: it is bounded and tested like any step, and kept only when it
  // lowers E_guard as much as the plain step must.
  detail::AndersonHistory<double> anderson(m.p.anderson_history);
  Eigen::MatrixXd accelerated;
  for (int it = 1; it <= options.max_iterations && (m.nf() > 0 || tau < 1); ++it) {
    if (tau < 1) {
      // Drag: the rest of the path, the free vertices following by the linear response of the
      // model, -A_ff^-1 A_fc dX_c (A_fc dX_c is the change of the gradient the motion causes).
      Eigen::MatrixXd D = (1 - tau) * path;
      if (m.nf() > 0) {
        // With contacts guarded, the barriers' Hessian takes part (the response of E_guard's
        // quadratic model, not of E alone): free vertices near contact or near a flat tet are held
        // back by it instead of being carried into the bound, so a base pressing two parts of the
        // top together thins the top there and the drag goes on (a plane folded shut). Guarding
        // the tets alone (the fall-back when the base forces a contact), the model's response
        // is kept: measured on CGAL's dino, the barrier-aware one costs more there and completed
        // fewer such drags.
        Eigen::MatrixXd coupling = m.gather(m.arap->half_gradient(X + D, state.local) - m.arap->half_gradient(X, state.local));
        const auto H = m.half_barrier_triplets(X, state);
        if (!m.contact || H.empty() || (m.p.cg_iterations == 0 && m.p.local_rings < 0)) {
          m.arap->apply_inverse(coupling);
          D -= m.scatter(coupling);
        } else {
          coupling += m.barrier_coupling(H, D);
          D += m.scatter(m.direction(m.local_hessian(H), coupling, false, result.cg_iterations));
        }
      }
      // The bounds keep every guarded tet and pair apart in exact arithmetic; a tet already flat to
      // rounding error can still cross zero when the step is rounded: such a step is halved, and
      // the path held where even that fails (the caller sees a stalled drag, never a broken state).
      double a = m.step_bound(X, D);
      for (int b = 0; b <= kMaxBacktracks && a > 0; ++b, a *= 0.5) {
        Eigen::MatrixXd Xt = X + a * D;
        const double tau_t = a >= 1 ? 1 : tau + a * (1 - tau);
        if (tau_t >= 1)
          for (int v : m.fixed) Xt.row(v) = fixed_targets.row(v);
        Impl::State trial;
        if (m.evaluate(Xt, trial)) {
          X = std::move(Xt);
          state = std::move(trial);
          tau = tau_t;
          break;
        }
      }
    }
    const double E = state.total;
    settled += tau >= 1;
    bool moved = false, clamped = false, combined = false;
    double E_new = E, predicted = 0;
    if (m.nf() > 0) {
      const Eigen::MatrixXd g = m.half_gradient(X, state);
      // Exact directions only once the path is done (GuardedSolverParameters::exact_direction_vertices).
      Eigen::MatrixXd d = m.direction(X, state, g, tau >= 1, result.cg_iterations);
      double slope = 2 * dot(g, d); // dE_guard/dalpha at 0
      if (!(slope < 0)) { // CG round-off: fall back to the preconditioned gradient, always descent
        d = -g;
        m.arap->apply_inverse(d);
        slope = 2 * dot(g, d);
      }
      predicted = -0.5 * slope; // decrease of the full step in the quadratic model
      if (slope < 0) {
        Eigen::MatrixXd D = m.scatter(d);
        double a = m.step_bound(X, D);
        clamped = a < 1;
        result.clamped_steps += clamped;
        // The held direction is still bounded by its own bound and searched below like any other.
        if (auto held = m.held_step(X, g, d, a, slope)) {
          D = m.scatter(held->d);
          a = held->bound;
          slope = held->slope;
          predicted = -0.5 * slope;
          ++result.held_steps;
        }
        Impl::State trial;
        if (m.p.anderson_history > 0) { // off (generation): nothing formed on its hot path
          if (tau < 1) {
            anderson.clear();
          } else if (a >= 1 && anderson.extrapolate(X, X + D, accelerated)) {
            // The combined iterate, bounded along its own segment like any step, in place of the
            // plain one when it decreases E_guard at least as much as the plain step must.
            const Eigen::MatrixXd Da = accelerated - X;
            if (m.step_bound(X, Da) >= 1 && m.evaluate(accelerated, trial) && trial.total <= E + kArmijo * slope) {
              X.swap(accelerated);
              state = std::move(trial);
              E_new = state.total;
              moved = true;
              combined = true;
              a = 0; // the plain step is not searched
            } else {
              anderson.clear();
            }
          }
        }
        for (int b = 0; b <= kMaxBacktracks && a > 0; ++b, a *= 0.5) {
          Eigen::MatrixXd Xt = X + a * D;
          if (m.evaluate(Xt, trial) && trial.total <= E + kArmijo * a * slope) {
            // a >= 1 at b = 0: the whole step, neither clamped nor backtracked.
            if (m.lengthening() && b == 0 && a >= 1 && settled > kLengthenAfter &&
                E - trial.total >= kLinearDecrease * predicted && m.lengthen_step(X, D, (E - trial.total) / predicted, Xt, trial))
              ++result.lengthened_steps;
            X = std::move(Xt);
            state = std::move(trial);
            E_new = state.total;
            moved = true;
            break;
          }
          ++result.backtracks;
        }
      }
    }
    result.iterations = it;
    result.energy.push_back(E_new);
    if (options.progress) options.progress(it, E_new, seconds_since(t0));
    // Converged when the decrease is small and neither a bound held the step back nor a combined
    // iterate replaced it (a clamped step, or a combined iterate that lowered E_guard little, with
    // a large predicted decrease of the plain step is progress still to be made). With lengthened
    // steps the predicted decrease must always be small too: beside steps many times longer, a
    // whole step that gains little is an unlucky one, not the minimum (the turbine's pose stopped
    // 0.8 % above the plain iterations' end without this).
    const double scale = std::max(options.energy_scale, E);
    const bool small = E <= 0 || ((E - E_new) < options.tolerance * scale &&
                                  ((!clamped && !combined && !m.lengthening()) || predicted < options.tolerance * scale));
    // A contact-guarded drag the bounds hold still (the fixed vertices' motion forces a contact)
    // is given up early: its iterations would only shuffle the free vertices against the
    // barriers, and the caller falls back to the tets or stops at contact. A tets-only drag, only
    // when it cannot finish (kHopelessPace).
    tau_history.push_back(tau);
    if (tau < 1 && it > kStallIterations) {
      const double progress = tau - tau_history[it - kStallIterations];
      const double left = options.max_iterations - it;
      if (m.contact ? progress * options.path_scale < kStallProgress
                    : kHopelessPace * progress * left < kStallIterations * (1 - tau))
        break;
    }
    if (tau >= 1 && (small || !moved)) {
      result.converged = small;
      break;
    }
  }
  result.path_done = tau;
  result.final_energy = state.shell;
  result.active_tets = static_cast<int>(state.active_tets.size());
  result.min_relative_volume = m.volume.min_relative_volume(X);
  result.active_contacts = m.contact ? m.contact->active_pairs() : 0;
  result.supernodal_solves = m.supernodal_solves;
  result.reused_orderings = m.reused_orderings;
  result.seconds = seconds_since(t0);
  return result;
}

} // namespace gshell
