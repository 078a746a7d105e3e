#include <gshell/solver/aggregation_multigrid.h>

#include <gshell/error.h>
#include <gshell/seconds_since.h>

#include "solver/hierarchy_linear.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <deque>
#include <chrono>
#include <cmath>
#include <mutex>
#include <random>
#include <string>

namespace gshell {

namespace {

using SpMat = Eigen::SparseMatrix<double, Eigen::RowMajor>;
// Work vectors: one row per unknown, one column per right-hand side, three at a time (the shell
// system's x, y, z). Row-major with a fixed width, so that Eigen's sparse-times-dense product
// makes one pass over the matrix for all columns with an unrolled row update (with column-major
// operands it makes one pass per column, with a dynamic width a loop per non-zero).
constexpr int kColumns = 3;
using Block = Eigen::Matrix<double, Eigen::Dynamic, kColumns, Eigen::RowMajor>;

// Rows per parallel task of the products and vector updates.
constexpr int kRowGrain = 4096;

// body(first row, row count) over [0, n) in parallel.
template <class Body> void for_rows(Eigen::Index n, Body&& body) {
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, n, kRowGrain),
                    [&](const tbb::blocked_range<Eigen::Index>& r) { body(r.begin(), r.end() - r.begin()); });
}

// Y = M X, rows in parallel (Eigen's product itself is sequential without OpenMP).
void multiply(const SpMat& M, const Block& X, Block& Y) {
  Y.resize(M.rows(), kColumns);
  for_rows(M.rows(), [&](Eigen::Index r0, Eigen::Index len) {
    Y.middleRows(r0, len).noalias() = M.middleRows(r0, len) * X;
  });
}

// Largest eigenvalue of D^-1 A (D = diag A) by power iteration on D^-1/2 A D^-1/2 (symmetric,
// same spectrum), never above the Gershgorin bound max_i sum_j |a_ij| / a_ii.
double spectral_radius(const SpMat& A, const Eigen::VectorXd& inv_diag) {
  const Eigen::Index n = A.rows();
  const Eigen::VectorXd s = inv_diag.cwiseSqrt();
  double gershgorin = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    double row = 0;
    for (SpMat::InnerIterator it(A, i); it; ++it) row += std::abs(it.value());
    gershgorin = std::max(gershgorin, row * inv_diag[i]);
  }
  std::mt19937 random(12345); // fixed: the same matrix gives the same hierarchy
  std::uniform_real_distribution<double> uniform(0.5, 1.5);
  Eigen::VectorXd v(n), sv(n), w(n);
  for (Eigen::Index i = 0; i < n; ++i) v[i] = uniform(random);
  double lambda = 0;
  for (int it = 0; it < 20; ++it) {
    v /= v.norm();
    sv = s.cwiseProduct(v);
    for_rows(n, [&](Eigen::Index r0, Eigen::Index len) { w.segment(r0, len).noalias() = A.middleRows(r0, len) * sv; });
    w = s.cwiseProduct(w);
    lambda = v.dot(w); // Rayleigh quotient: a lower bound that converges from below
    v.swap(w);
  }
  return std::min(gershgorin, lambda);
}

// Aggregates of the strong graph of A (|a_ij| >= theta sqrt(a_ii a_jj)): first whole
// neighbourhoods of vertices none of whose neighbours is taken yet, then every remaining vertex
// joins the aggregate of its strongest aggregated neighbour, and what is left groups with its
// free neighbours. Returns aggregate per row and sets `count`.
std::vector<int> aggregate(const SpMat& A, const Eigen::VectorXd& diag, double theta, int& count) {
  const int n = static_cast<int>(A.rows());
  auto strong = [&](int i, const SpMat::InnerIterator& it) {
    const int j = static_cast<int>(it.index());
    return j != i && std::abs(it.value()) >= theta * std::sqrt(diag[i] * diag[j]);
  };
  std::vector<int> agg(n, -1);
  count = 0;
  for (int i = 0; i < n; ++i) {
    if (agg[i] >= 0) continue;
    bool free = true;
    for (SpMat::InnerIterator it(A, i); it && free; ++it)
      if (strong(i, it) && agg[it.index()] >= 0) free = false;
    if (!free) continue;
    agg[i] = count;
    for (SpMat::InnerIterator it(A, i); it; ++it)
      if (strong(i, it)) agg[it.index()] = count;
    ++count;
  }
  std::vector<int> joined = agg; // joining reads the first pass's aggregates only: no chains
  for (int i = 0; i < n; ++i) {
    if (agg[i] >= 0) continue;
    double best = -1;
    for (SpMat::InnerIterator it(A, i); it; ++it)
      if (strong(i, it) && agg[it.index()] >= 0 && std::abs(it.value()) > best) {
        best = std::abs(it.value());
        joined[i] = agg[it.index()];
      }
  }
  agg.swap(joined);
  for (int i = 0; i < n; ++i) {
    if (agg[i] >= 0) continue;
    agg[i] = count;
    for (SpMat::InnerIterator it(A, i); it; ++it)
      if (strong(i, it) && agg[it.index()] < 0) agg[it.index()] = count;
    ++count;
  }
  return agg;
}

} // namespace

struct AggregationMultigrid::Impl {
  struct Level {
    SpMat A;
    Eigen::VectorXd inv_diag;
    double lambda_max = 0; // of D^-1 A
    SpMat P, R;            // prolongation to this level from the next, and its transpose
    mutable Block b, x, r, d, t;
  };
  std::deque<Level> levels; // a deque: adding a level moves none of the others
  detail::SpdSolver coarsest;
  mutable Eigen::MatrixXd coarsest_work;
  MultigridOptions options;
  double seconds = 0;
  mutable std::mutex mutex;

  void smooth(const Level& L, bool zero_start, bool want_residual) const;
  void cycle(std::size_t l) const;
};

// Chebyshev iteration on A x = b preconditioned by D^-1 over [lambda_max / 8, 1.1 lambda_max]
// (Saad, Iterative Methods, Alg. 12.1): damps the upper part of the spectrum, which the coarse
// level cannot represent. Leaves b - A x in L.r when asked (free after the last update). The
// lower end: on generation systems of sphere:7, PCG to 1e-8 took 9 iterations with lambda / 8 and
// lambda / 4 and 14 with lambda / 30 at degree 2 (degree 1: 14-16, degree 3: 9-10 at more cost).
void AggregationMultigrid::Impl::smooth(const Level& L, bool zero_start, bool want_residual) const {
  const double upper = 1.1 * L.lambda_max, lower = L.lambda_max / 8.0;
  const double theta = 0.5 * (upper + lower), delta = 0.5 * (upper - lower), sigma = theta / delta;
  const Eigen::Index n = L.A.rows();
  if (zero_start) {
    L.x.setZero(n, kColumns);
    L.r = L.b;
  } else {
    multiply(L.A, L.x, L.t);
    L.r.resize(n, kColumns);
    for_rows(n, [&](Eigen::Index r0, Eigen::Index len) { L.r.middleRows(r0, len) = L.b.middleRows(r0, len) - L.t.middleRows(r0, len); });
  }
  L.d.resize(n, kColumns);
  for_rows(n, [&](Eigen::Index r0, Eigen::Index len) {
    L.d.middleRows(r0, len) = (L.inv_diag.segment(r0, len) / theta).asDiagonal() * L.r.middleRows(r0, len);
  });
  double rho = 1.0 / sigma;
  const int degree = options.smoothing_degree;
  for (int k = 1; k <= degree; ++k) {
    const bool last = k == degree;
    if (!last || want_residual) multiply(L.A, L.d, L.t);
    const double rho_next = 1.0 / (2.0 * sigma - rho);
    const double keep = rho_next * rho, scale = 2.0 * rho_next / delta;
    for_rows(n, [&](Eigen::Index r0, Eigen::Index len) {
      L.x.middleRows(r0, len) += L.d.middleRows(r0, len);
      if (last && !want_residual) return;
      L.r.middleRows(r0, len) -= L.t.middleRows(r0, len);
      if (last) return;
      L.d.middleRows(r0, len) = keep * L.d.middleRows(r0, len) +
                                (scale * L.inv_diag.segment(r0, len)).asDiagonal() * L.r.middleRows(r0, len);
    });
    rho = rho_next;
  }
}

// x_l <- V-cycle on b_l: smooth from zero, restrict the residual, recurse, prolong the correction,
// smooth again with the same polynomial (so the cycle is a symmetric map).
void AggregationMultigrid::Impl::cycle(std::size_t l) const {
  const Level& L = levels[l];
  if (l + 1 == levels.size()) {
    coarsest_work = L.b;
    coarsest.solve_in_place(coarsest_work);
    L.x = coarsest_work;
    return;
  }
  smooth(L, true, true);
  const Level& C = levels[l + 1];
  multiply(L.R, L.r, C.b);
  cycle(l + 1);
  multiply(L.P, C.x, L.t);
  for_rows(L.A.rows(), [&](Eigen::Index r0, Eigen::Index len) { L.x.middleRows(r0, len) += L.t.middleRows(r0, len); });
  smooth(L, false, false);
}

AggregationMultigrid::AggregationMultigrid(Eigen::SparseMatrix<double, Eigen::RowMajor> A,
                                           const MultigridOptions& options)
    : impl_(std::make_unique<Impl>()) {
  const auto t0 = std::chrono::steady_clock::now();
  if (A.rows() != A.cols()) throw InputError("AggregationMultigrid: the matrix is not square");
  if (options.coarsest_rows < 1) throw InputError("AggregationMultigrid: coarsest_rows must be at least 1");
  if (!(options.strength >= 0 && options.strength < 1))
    throw InputError("AggregationMultigrid: strength must be in [0, 1)");
  if (options.smoothing_degree < 1) throw InputError("AggregationMultigrid: smoothing_degree must be at least 1");
  Impl& m = *impl_;
  m.options = options;
  double theta = options.strength;
  m.levels.emplace_back();
  m.levels.back().A = std::move(A);
  m.levels.back().A.makeCompressed();
  for (;;) {
    Impl::Level& L = m.levels.back();
    const Eigen::VectorXd diag = L.A.diagonal();
    if ((diag.array() <= 0).any() || !diag.allFinite())
      throw InputError("AggregationMultigrid: the matrix has a non-positive diagonal entry");
    L.inv_diag = diag.cwiseInverse();
    L.lambda_max = spectral_radius(L.A, L.inv_diag);
    if (L.A.rows() <= options.coarsest_rows) break;
    int coarse_rows = 0;
    const std::vector<int> agg = aggregate(L.A, diag, theta, coarse_rows);
    if (coarse_rows > 0.75 * static_cast<double>(L.A.rows())) break; // stalled: factor this level
    SpMat tentative(L.A.rows(), coarse_rows);
    tentative.reserve(Eigen::VectorXi::Ones(L.A.rows()));
    for (Eigen::Index i = 0; i < L.A.rows(); ++i) tentative.insert(i, agg[i]) = 1.0;
    tentative.makeCompressed();
    // P = (I - omega D^-1 A) P_tent with omega = 4 / (3 rho(D^-1 A)), the usual smoothed-
    // aggregation choice: it damps the tentative basis functions' high-frequency edges.
    SpMat AP = L.A * tentative;
    const double omega = 4.0 / (3.0 * L.lambda_max);
    L.P = tentative - (omega * L.inv_diag).asDiagonal() * AP;
    L.P.prune(0.0);
    L.P.makeCompressed();
    L.R = L.P.transpose();
    AP = L.A * L.P;
    SpMat coarse = L.R * AP;
    coarse.makeCompressed();
    m.levels.emplace_back();
    m.levels.back().A = std::move(coarse);
    theta *= 0.5;
  }
  m.coarsest.factor(Eigen::SparseMatrix<double>(m.levels.back().A));
  m.seconds = seconds_since(t0);
}

AggregationMultigrid::~AggregationMultigrid() = default;
AggregationMultigrid::AggregationMultigrid(AggregationMultigrid&&) noexcept = default;
AggregationMultigrid& AggregationMultigrid::operator=(AggregationMultigrid&&) noexcept = default;

void AggregationMultigrid::apply(const Eigen::Ref<const Eigen::MatrixXd>& R, Eigen::Ref<Eigen::MatrixXd> Z) const {
  const Impl& m = *impl_;
  const Eigen::Index n = m.levels[0].A.rows();
  if (R.rows() != n || R.cols() < 1)
    throw InputError("AggregationMultigrid::apply: expected " + std::to_string(n) + " rows");
  if (Z.rows() != R.rows() || Z.cols() != R.cols())
    throw InputError("AggregationMultigrid::apply: the output does not have the input's shape");
  std::lock_guard<std::mutex> lock(m.mutex);
  const Impl::Level& top = m.levels[0];
  top.b.resize(n, kColumns);
  for (Eigen::Index c0 = 0; c0 < R.cols(); c0 += kColumns) { // the last group padded with zeros
    const Eigen::Index k = std::min<Eigen::Index>(kColumns, R.cols() - c0);
    for_rows(n, [&](Eigen::Index r0, Eigen::Index len) {
      top.b.middleRows(r0, len).leftCols(k) = R.block(r0, c0, len, k);
      top.b.middleRows(r0, len).rightCols(kColumns - k).setZero();
    });
    m.cycle(0);
    for_rows(n, [&](Eigen::Index r0, Eigen::Index len) { Z.block(r0, c0, len, k) = top.x.middleRows(r0, len).leftCols(k); });
  }
}

int AggregationMultigrid::rows() const { return static_cast<int>(impl_->levels[0].A.rows()); }

std::vector<MultigridLevelInfo> AggregationMultigrid::levels() const {
  std::vector<MultigridLevelInfo> out;
  for (const auto& L : impl_->levels) out.push_back({static_cast<int>(L.A.rows()), static_cast<long long>(L.A.nonZeros())});
  return out;
}

double AggregationMultigrid::setup_seconds() const { return impl_->seconds; }

} // namespace gshell
