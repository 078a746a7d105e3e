#include <gshell/solver/aggregation_multigrid.h>

#include <gshell/error.h>
#include <gshell/seconds_since.h>

#include "solver/hierarchy_linear.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
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

// Chunks of rows whose partial sums are added in chunk order: the hierarchy does not depend on
// how TBB splits the work.
constexpr int kSumChunk = 8192;

// Largest eigenvalue of D^-1 A (D = diag A) by power iteration on D^-1/2 A D^-1/2 (symmetric,
// same spectrum), never above the Gershgorin bound max_i sum_j |a_ij| / a_ii. Every vector
// operation is fused into two parallel passes per iteration (on millions of rows the sequential
// vector updates cost as much as the products).
double spectral_radius(const SpMat& A, const Eigen::VectorXd& inv_diag) {
  const Eigen::Index n = A.rows();
  const int chunks = static_cast<int>((n + kSumChunk - 1) / kSumChunk);
  auto chunk_rows = [&](int c) { return std::pair<Eigen::Index, Eigen::Index>(Eigen::Index(c) * kSumChunk, std::min<Eigen::Index>(n, Eigen::Index(c + 1) * kSumChunk)); };
  const Eigen::VectorXd s = inv_diag.cwiseSqrt();
  std::vector<double> bound(chunks, 0.0);
  tbb::parallel_for(0, chunks, [&](int c) {
    const auto [r0, r1] = chunk_rows(c);
    for (Eigen::Index i = r0; i < r1; ++i) {
      double row = 0;
      for (SpMat::InnerIterator it(A, i); it; ++it) row += std::abs(it.value());
      bound[c] = std::max(bound[c], row * inv_diag[i]);
    }
  });
  const double gershgorin = *std::max_element(bound.begin(), bound.end());
  std::mt19937 random(12345); // fixed: the same matrix gives the same hierarchy
  std::uniform_real_distribution<double> uniform(0.5, 1.5);
  Eigen::VectorXd v(n), u(n), w(n); // v unit, u = D^-1/2 v, w = D^-1/2 A u
  for (Eigen::Index i = 0; i < n; ++i) v[i] = uniform(random);
  v /= v.norm();
  u = s.cwiseProduct(v);
  std::vector<std::array<double, 2>> partial(chunks);
  double lambda = 0;
  for (int it = 0; it < 20; ++it) {
    tbb::parallel_for(0, chunks, [&](int c) {
      const auto [r0, r1] = chunk_rows(c);
      w.segment(r0, r1 - r0).noalias() = A.middleRows(r0, r1 - r0) * u;
      w.segment(r0, r1 - r0) = w.segment(r0, r1 - r0).cwiseProduct(s.segment(r0, r1 - r0));
      partial[c] = {v.segment(r0, r1 - r0).dot(w.segment(r0, r1 - r0)), w.segment(r0, r1 - r0).squaredNorm()};
    });
    double vw = 0, ww = 0;
    for (const auto& p : partial) {
      vw += p[0];
      ww += p[1];
    }
    lambda = vw; // Rayleigh quotient: a lower bound that converges from below
    if (!(ww > 0)) break;
    const double scale = 1.0 / std::sqrt(ww);
    tbb::parallel_for(0, chunks, [&](int c) {
      const auto [r0, r1] = chunk_rows(c);
      v.segment(r0, r1 - r0) = scale * w.segment(r0, r1 - r0);
      u.segment(r0, r1 - r0) = v.segment(r0, r1 - r0).cwiseProduct(s.segment(r0, r1 - r0));
    });
  }
  return std::min(gershgorin, lambda);
}

// Compressed rows made in parallel: row_entries(i, out) appends row i's (column, value) pairs,
// columns ascending. Rows are made in blocks, each into its own buffer, then copied into place.
template <class RowEntries> SpMat rows_in_parallel(Eigen::Index rows, Eigen::Index cols, RowEntries&& row_entries) {
  constexpr Eigen::Index kBlock = 2048;
  const int blocks = static_cast<int>((rows + kBlock - 1) / kBlock);
  struct Block {
    std::vector<std::pair<int, double>> entries;
    std::vector<int> len;
  };
  std::vector<Block> out(blocks);
  tbb::parallel_for(0, blocks, [&](int b) {
    Block& block = out[b];
    for (Eigen::Index i = b * kBlock; i < std::min(rows, (b + 1) * kBlock); ++i) {
      const std::size_t before = block.entries.size();
      row_entries(i, block.entries);
      block.len.push_back(static_cast<int>(block.entries.size() - before));
    }
  });
  SpMat M(rows, cols);
  std::vector<Eigen::Index> block_start(blocks + 1, 0);
  for (int b = 0; b < blocks; ++b) block_start[b + 1] = block_start[b] + static_cast<Eigen::Index>(out[b].entries.size());
  M.resizeNonZeros(block_start[blocks]);
  auto* outer = M.outerIndexPtr();
  outer[0] = 0;
  tbb::parallel_for(0, blocks, [&](int b) {
    Block& block = out[b];
    auto start = block_start[b];
    for (std::size_t r = 0; r < block.len.size(); ++r) outer[b * kBlock + r + 1] = static_cast<int>(start += block.len[r]);
    for (std::size_t e = 0; e < block.entries.size(); ++e) {
      M.innerIndexPtr()[block_start[b] + e] = block.entries[e].first;
      M.valuePtr()[block_start[b] + e] = block.entries[e].second;
    }
    block = Block{};
  });
  return M;
}

// A B for row-major sparse matrices, rows in parallel (Eigen's sparse product is sequential):
// each row accumulated in a per-thread dense array over B's columns, summing in the order of
// A's row and then B's rows (the same bits however the rows are split).
SpMat sparse_product(const SpMat& A, const SpMat& B) {
  struct Workspace {
    std::vector<double> sum;
    std::vector<int> touched;
    std::vector<char> seen;
  };
  tbb::enumerable_thread_specific<Workspace> workspaces(
      [&] { return Workspace{std::vector<double>(B.cols(), 0.0), {}, std::vector<char>(B.cols(), 0)}; });
  return rows_in_parallel(A.rows(), B.cols(), [&](Eigen::Index i, std::vector<std::pair<int, double>>& out) {
    Workspace& w = workspaces.local();
    w.touched.clear();
    for (SpMat::InnerIterator a(A, i); a; ++a)
      for (SpMat::InnerIterator b(B, a.index()); b; ++b) {
        const int j = static_cast<int>(b.index());
        if (!w.seen[j]) {
          w.seen[j] = 1;
          w.touched.push_back(j);
        }
        w.sum[j] += a.value() * b.value();
      }
    std::sort(w.touched.begin(), w.touched.end());
    for (int j : w.touched) {
      out.emplace_back(j, w.sum[j]);
      w.sum[j] = 0.0;
      w.seen[j] = 0;
    }
  });
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

// out = row i of M times X (3 columns).
inline void row_times(const SpMat& M, Eigen::Index i, const Block& X, double out[kColumns]) {
  const int* index = M.innerIndexPtr();
  const double* value = M.valuePtr();
  const double* x = X.data();
  double s0 = 0, s1 = 0, s2 = 0;
  for (int k = M.outerIndexPtr()[i]; k < M.outerIndexPtr()[i + 1]; ++k) {
    const double a = value[k];
    const double* xk = x + kColumns * static_cast<std::size_t>(index[k]);
    s0 += a * xk[0];
    s1 += a * xk[1];
    s2 += a * xk[2];
  }
  out[0] = s0;
  out[1] = s1;
  out[2] = s2;
}

// Chebyshev iteration on A x = b preconditioned by D^-1 over [lambda_max / 8, 1.1 lambda_max]
// (Saad, Iterative Methods, Alg. 12.1): damps the upper part of the spectrum, which the coarse
// level cannot represent. Leaves b - A x in L.r when asked (free after the last update). The
// lower end: on generation systems of sphere:7, PCG to 1e-8 took 9 iterations with lambda / 8 and
// lambda / 4 and 14 with lambda / 30 at degree 2 (degree 1: 14-16, degree 3: 9-10 at more cost).
// Each step is one pass over the rows: the product A d of a row and every vector update of that
// row together (the next direction goes to a second buffer, as other rows still read d); the
// cycle is bound by memory traffic, and separate passes for the updates cost as much as the
// products.
void AggregationMultigrid::Impl::smooth(const Level& L, bool zero_start, bool want_residual) const {
  const double upper = 1.1 * L.lambda_max, lower = L.lambda_max / 8.0;
  const double theta = 0.5 * (upper + lower), delta = 0.5 * (upper - lower), sigma = theta / delta;
  const Eigen::Index n = L.A.rows();
  L.x.resize(n, kColumns);
  L.r.resize(n, kColumns);
  L.d.resize(n, kColumns);
  L.t.resize(n, kColumns);
  for_rows(n, [&](Eigen::Index r0, Eigen::Index len) {
    for (Eigen::Index i = r0; i < r0 + len; ++i) {
      const double scale = L.inv_diag[i] / theta;
      double ax[kColumns] = {0, 0, 0};
      if (!zero_start) row_times(L.A, i, L.x, ax);
      for (int c = 0; c < kColumns; ++c) {
        const double r = L.b(i, c) - ax[c];
        if (zero_start) L.x(i, c) = 0.0;
        L.r(i, c) = r;
        L.d(i, c) = scale * r;
      }
    }
  });
  double rho = 1.0 / sigma;
  const int degree = options.smoothing_degree;
  for (int k = 1; k <= degree; ++k) {
    const bool last = k == degree;
    const double rho_next = 1.0 / (2.0 * sigma - rho);
    const double keep = rho_next * rho, scale = 2.0 * rho_next / delta;
    if (last && !want_residual) {
      for_rows(n, [&](Eigen::Index r0, Eigen::Index len) { L.x.middleRows(r0, len) += L.d.middleRows(r0, len); });
      break;
    }
    for_rows(n, [&](Eigen::Index r0, Eigen::Index len) {
      for (Eigen::Index i = r0; i < r0 + len; ++i) {
        double ad[kColumns];
        row_times(L.A, i, L.d, ad);
        const double step = scale * L.inv_diag[i];
        for (int c = 0; c < kColumns; ++c) {
          const double d = L.d(i, c);
          L.x(i, c) += d;
          const double r = L.r(i, c) - ad[c];
          L.r(i, c) = r;
          if (!last) L.t(i, c) = keep * d + step * r; // the next direction
        }
      }
    });
    if (!last) L.d.swap(L.t);
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
  for_rows(L.A.rows(), [&](Eigen::Index r0, Eigen::Index len) {
    for (Eigen::Index i = r0; i < r0 + len; ++i) {
      double px[kColumns];
      row_times(L.P, i, C.x, px);
      for (int c = 0; c < kColumns; ++c) L.x(i, c) += px[c];
    }
  });
  smooth(L, false, false);
}

AggregationMultigrid::AggregationMultigrid(const Eigen::SparseMatrix<double, Eigen::RowMajor>& A,
                                           const MultigridOptions& options)
    : AggregationMultigrid(SpMat(A), options) {}

// Eigen 3.4's SparseMatrix has no move operations: matrices change hands by swap() here, since an
// assignment or a by-value parameter copies them, serially, into fresh memory (at 2.6M rows the
// copies of the finest level and of the prolongations were a tenth of the generation's page faults).
AggregationMultigrid::AggregationMultigrid(Eigen::SparseMatrix<double, Eigen::RowMajor>&& A,
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
  m.levels.back().A.swap(A);
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
    // P = (I - omega D^-1 A) P_tent with omega = 4 / (3 rho(D^-1 A)), the usual smoothed-
    // aggregation choice: it damps the tentative basis functions' high-frequency edges. P_tent
    // is piecewise constant on the aggregates, so row i of A P_tent sums row i of A by aggregate.
    const double omega = 4.0 / (3.0 * L.lambda_max);
    SpMat P = rows_in_parallel(L.A.rows(), coarse_rows, [&](Eigen::Index i, std::vector<std::pair<int, double>>& out) {
      const std::size_t first = out.size();
      for (SpMat::InnerIterator it(L.A, i); it; ++it) {
        const int a = agg[it.index()];
        auto e = std::find_if(out.begin() + first, out.end(), [&](const auto& x) { return x.first == a; });
        if (e == out.end()) out.emplace_back(a, 0.0), e = out.end() - 1;
        e->second -= omega * L.inv_diag[i] * it.value();
      }
      auto own = std::find_if(out.begin() + first, out.end(), [&](const auto& x) { return x.first == agg[i]; });
      if (own == out.end()) out.emplace_back(agg[i], 1.0);
      else own->second += 1.0;
      out.erase(std::remove_if(out.begin() + first, out.end(), [](const auto& x) { return x.second == 0.0; }), out.end());
      std::sort(out.begin() + first, out.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    });
    L.P.swap(P);
    L.R = L.P.transpose();
    SpMat coarse = sparse_product(L.R, sparse_product(L.A, L.P));
    coarse.makeCompressed();
    m.levels.emplace_back();
    m.levels.back().A.swap(coarse);
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
const Eigen::SparseMatrix<double, Eigen::RowMajor>& AggregationMultigrid::matrix() const { return impl_->levels[0].A; }

std::vector<MultigridLevelInfo> AggregationMultigrid::levels() const {
  std::vector<MultigridLevelInfo> out;
  for (const auto& L : impl_->levels) out.push_back({static_cast<int>(L.A.rows()), static_cast<long long>(L.A.nonZeros())});
  return out;
}

double AggregationMultigrid::setup_seconds() const { return impl_->seconds; }

} // namespace gshell
