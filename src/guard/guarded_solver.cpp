#include <gshell/guard/guarded_solver.h>

#include <gshell/error.h>
#include <gshell/guard/tet_step_bound.h>

#include <Eigen/SparseCore>

#include <chrono>
#include <cmath>
#include <limits>
#include <string>

namespace gshell {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
constexpr double kInf = std::numeric_limits<double>::infinity();

// Armijo constant of the line search: the accepted step decreases E_guard by at least this
// fraction of what the slope at the start promises.
constexpr double kArmijo = 1e-4;
constexpr int kMaxBacktracks = 30;

double dot(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) { return (a.array() * b.array()).sum(); }

Eigen::VectorXd flat(const Eigen::MatrixXd& P) { // index 3 * vertex + axis
  Eigen::VectorXd v(P.size());
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(v.data(), P.rows(), 3) = P;
  return v;
}

Eigen::MatrixXd unflat(const Eigen::VectorXd& v) {
  return Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(v.data(), v.size() / 3, 3);
}

} // namespace

struct GuardedSolver::Impl {
  ShellSolver arap;
  VolumeBarrier volume;
  std::unique_ptr<ContactGuard> contact;
  GuardedSolverParameters p;
  Eigen::MatrixXi T;
  int N = 0;
  std::vector<int> fixed;

  Impl(const RestTets& rest, int num_vertices, const std::vector<int>& fixed_vertices, const ShellBoundary& boundary,
       GuardedSolverParameters parameters)
      : arap(rest, num_vertices, fixed_vertices), volume(rest, parameters.j_hat, parameters.skip_tets),
        p(std::move(parameters)), T(rest.T), N(num_vertices), fixed(fixed_vertices) {
    if (!(p.keep_fraction > 0 && p.keep_fraction < 1))
      throw InputError("GuardedSolver: keep_fraction must be in (0, 1)");
    if (!(p.volume_weight > 0)) throw InputError("GuardedSolver: volume_weight must be positive");
    if (!(p.contact_distance >= 0) || !std::isfinite(p.contact_distance))
      throw InputError("GuardedSolver: contact_distance must be >= 0");
    if (p.cg_iterations < 0 || !(p.cg_tolerance > 0)) throw InputError("GuardedSolver: bad CG parameters");
    if (p.contact_distance > 0) {
      if (!(p.contact_stiffness > 0)) throw InputError("GuardedSolver: contact_stiffness must be positive");
      std::vector<char> movable(N, 0);
      for (int v = 0; v < N; ++v) movable[v] = arap.is_free(v) ? 1 : 0;
      ContactOptions options;
      options.dhat = p.contact_distance;
      options.keep_fraction = p.keep_fraction;
      contact = std::make_unique<ContactGuard>(boundary, N, std::move(movable), options, p.excluded_triangles);
    }
  }

  struct State {
    LocalStep local;
    double shell = 0, volume = 0, contact = 0, total = kInf;
  };

  // E_guard at X; false (total = inf) when X is not valid for the barriers.
  bool evaluate(const Eigen::MatrixXd& X, State& s) {
    s.volume = volume.energy(X);
    s.contact = contact ? contact->energy(X) : 0.0;
    if (!std::isfinite(s.volume) || !std::isfinite(s.contact)) {
      s.total = kInf;
      return false;
    }
    arap.local_step(X, s.local);
    s.shell = s.local.energy;
    s.total = s.shell + p.volume_weight * s.volume + p.contact_stiffness * s.contact;
    return true;
  }

  void zero_fixed(Eigen::MatrixXd& P) const {
    for (int v : fixed) P.row(v).setZero();
  }

  // Half the gradient of E_guard at X (free rows).
  Eigen::MatrixXd half_gradient(const Eigen::MatrixXd& X, const State& s) {
    Eigen::MatrixXd g = arap.half_gradient(X, s.local);
    volume.add_gradient(X, 0.5 * p.volume_weight, g);
    if (contact) contact->add_gradient(X, 0.5 * p.contact_stiffness, g);
    zero_fixed(g);
    return g;
  }

  // Half the barriers' Hessian over the free degrees of freedom (3 * vertex + axis).
  Eigen::SparseMatrix<double> half_barrier_hessian(const Eigen::MatrixXd& X) {
    std::vector<Eigen::Triplet<double>> H;
    volume.add_hessian(X, 0.5 * p.volume_weight, H);
    if (contact) contact->add_hessian(X, 0.5 * p.contact_stiffness, H);
    std::vector<Eigen::Triplet<double>> kept;
    kept.reserve(H.size());
    for (const auto& t : H)
      if (arap.is_free(t.row() / 3) && arap.is_free(t.col() / 3)) kept.push_back(t);
    Eigen::SparseMatrix<double> M(3 * N, 3 * N);
    M.setFromTriplets(kept.begin(), kept.end());
    return M;
  }

  // The Newton direction of the quadratic model A + H/2 (see the header), by preconditioned CG.
  Eigen::MatrixXd direction(const Eigen::MatrixXd& X, const Eigen::MatrixXd& g, int& cg_iterations) {
    Eigen::MatrixXd d = -arap.apply_inverse(g);
    if (p.cg_iterations == 0) return d;
    const Eigen::SparseMatrix<double> H = half_barrier_hessian(X);
    if (H.nonZeros() == 0) return d;
    auto apply = [&](const Eigen::MatrixXd& v) {
      Eigen::MatrixXd y = arap.multiply(v) + unflat(H * flat(v));
      zero_fixed(y);
      return y;
    };
    const double gMg = -dot(g, d);
    if (!(gMg > 0)) return d;
    Eigen::MatrixXd r = -g - apply(d);
    Eigen::MatrixXd z = arap.apply_inverse(r);
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
      z = arap.apply_inverse(r);
      const double rz_new = dot(r, z);
      ++cg_iterations;
      s = z + (rz_new / rz) * s;
      rz = rz_new;
    }
    return d;
  }

  // Largest step in [0, 1] keeping tets and boundary pairs safe along D.
  double step_bound(const Eigen::MatrixXd& X, const Eigen::MatrixXd& D) {
    const std::vector<char>* skip = &volume.skip();
    double a = tet_step_bound(T, X, D, p.keep_fraction, 1.0, skip).step;
    if (contact && a > 0) a = std::min(a, contact->step_bound(X, D, a));
    return a;
  }
};

GuardedSolver::GuardedSolver(const RestTets& rest, int num_vertices, const std::vector<int>& fixed,
                             const ShellBoundary& boundary, GuardedSolverParameters parameters)
    : impl_(std::make_unique<Impl>(rest, num_vertices, fixed, boundary, std::move(parameters))) {}

GuardedSolver::~GuardedSolver() = default;
GuardedSolver::GuardedSolver(GuardedSolver&&) noexcept = default;
GuardedSolver& GuardedSolver::operator=(GuardedSolver&&) noexcept = default;

const ShellSolver& GuardedSolver::shell_solver() const { return impl_->arap; }
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
  if (X.rows() != m.N || X.cols() != 3) throw InputError("GuardedSolver::solve: expected " + std::to_string(m.N) + " x 3 positions");
  if (options.max_iterations < 0 || !(options.tolerance >= 0)) throw InputError("GuardedSolver::solve: bad options");
  const bool drag = fixed_targets.size() > 0;
  if (drag && (fixed_targets.rows() != m.N || fixed_targets.cols() != 3))
    throw InputError("GuardedSolver::solve: fixed_targets must be " + std::to_string(m.N) + " x 3");
  GuardedSolveResult result;
  Impl::State state;
  if (!m.evaluate(X, state))
    throw InputError("GuardedSolver::solve: the start state is not valid (a guarded tet is flat or inverted, or "
                     "two boundary primitives touch)");
  result.energy.push_back(state.total);

  // The prescribed path of the fixed vertices: X_c(tau) = start + tau * (targets - start).
  Eigen::MatrixXd path = Eigen::MatrixXd::Zero(m.N, 3), path_start;
  double tau = 1;
  if (drag) {
    path_start = X;
    for (int v : m.fixed) path.row(v) = fixed_targets.row(v) - X.row(v);
    tau = path.isZero(0) ? 1 : 0;
  }

  for (int it = 1; it <= options.max_iterations; ++it) {
    if (tau < 1) {
      // Drag: the rest of the path, the free vertices following linearly; as far as is safe.
      const Eigen::MatrixXd Dc = (1 - tau) * path;
      const Eigen::MatrixXd D = Dc - m.arap.apply_inverse(m.arap.multiply(Dc));
      const double a = m.step_bound(X, D);
      if (a > 0) {
        X += a * D;
        tau = a >= 1 ? 1 : tau + a * (1 - tau);
        if (tau >= 1)
          for (int v : m.fixed) X.row(v) = fixed_targets.row(v);
        if (!m.evaluate(X, state)) // cannot happen: the bounds keep every pair and tet apart
          throw std::runtime_error("GuardedSolver: the drag step left the valid set");
      }
    }
    const double E = state.total;
    const Eigen::MatrixXd g = m.half_gradient(X, state);
    Eigen::MatrixXd D = m.direction(X, g, result.cg_iterations);
    double slope = 2 * dot(g, D); // dE_guard/dalpha at 0
    if (!(slope < 0)) { // not a descent direction (CG round-off): fall back to the preconditioned gradient
      D = -m.arap.apply_inverse(g);
      slope = 2 * dot(g, D);
    }
    bool moved = false;
    double E_new = E;
    if (slope < 0) {
      double a = m.step_bound(X, D);
      if (a < 1) ++result.clamped_steps;
      Impl::State trial;
      for (int b = 0; b <= kMaxBacktracks && a > 0; ++b, a *= 0.5) {
        const Eigen::MatrixXd Xt = X + a * D;
        if (m.evaluate(Xt, trial) && trial.total <= E + kArmijo * a * slope) {
          X = Xt;
          state = std::move(trial);
          E_new = state.total;
          moved = true;
          break;
        }
        ++result.backtracks;
      }
    }
    result.iterations = it;
    result.energy.push_back(E_new);
    if (options.progress) options.progress(it, E_new, seconds_since(t0));
    const bool small = E <= 0 || (E - E_new) < options.tolerance * E;
    if (tau >= 1 && (small || !moved)) {
      result.converged = small;
      break;
    }
  }
  result.path_done = tau;
  result.final_energy = state.shell;
  result.active_tets = m.volume.active_tets(X);
  result.active_contacts = m.contact ? m.contact->active_pairs() : 0;
  result.seconds = seconds_since(t0);
  return result;
}

} // namespace gshell
