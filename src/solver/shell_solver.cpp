#include <gshell/solver/shell_solver.h>

#include <gshell/error.h>
#include <gshell/format_number.h>
#include <gshell/seconds_since.h>

#include "geometry/disjoint_sets.h"
#include "geometry/first_touch.h"
#include "solver/anderson_history.h"
#include "solver/blas_threads.h"
#include "solver/breadth_first_order.h"
#include "solver/polar_3x3.h"
#include "solver/simd_dispatch.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <mutex>
#include <numeric>
#include <string>
#include <utility>

#ifdef GSHELL_HAVE_CHOLMOD
#include <cholmod.h>
#else
#include <Eigen/SparseCholesky>
#endif

namespace gshell {

namespace {

using Clock = std::chrono::steady_clock;
using RowMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>; // L_ff: rows by free index

// A NaN volume or rest point gave NaN positions from solve() without a word, and a negative volume
// was called a singular system.
void check_rest_numbers(const RestTets& rest) {
  for (Eigen::Index t = 0; t < rest.volume.size(); ++t)
    if (!(rest.volume[t] > 0) || !std::isfinite(rest.volume[t]))
      throw InputError("ShellSolver: rest tet " + std::to_string(t) + " has volume " + format_number(rest.volume[t]) +
                       " (rest volumes must be positive and finite)");
  for (std::size_t k = 0; k < rest.rest_points.size(); ++k)
    if (!std::isfinite(rest.rest_points[k]))
      throw InputError("ShellSolver: rest point " + std::to_string(k / 3) + " is not finite");
}

// Tets per energy chunk: chunks are summed in a fixed order so the energy does not depend on
// how TBB happened to split the work (the monotonicity test compares energies to round-off).
constexpr int kChunk = 2048;

// Free vertices from which the x column and the y, z columns are back-substituted concurrently:
// CHOLMOD's triangular solves are single-threaded, and one column costs about 60% of three.
constexpr int kParallelSolveRows = 4096;

// Rows of the system matrix assembled per task.
constexpr int kAssembleBlock = 1024;

// Rows per chunk of CG's inner products: partial sums are added in chunk order, so a solve gives
// the same bits however TBB splits the work (the monotonicity test compares energies to round-off).
constexpr int kCgChunk = 4096;

// What the local step reads per tet, straight from RestTets (no copy: at millions of faces the
// tets are the solver's largest data): vertex j of tet t at T[t + j K] (column-major K x 4),
// Dm_inv(k, c) at Dinv[9 t + k + 3 c] (column-major 3x3 matrices, stored contiguously), volume.
// In the affine-prism form (Dinv null), Dm_inv = unit_inverse[unit_corners[t]] * prism_inverse[t / 3];
// in the positions form (points set), it is made from the tet's rest points (RestTets::dm_inv).
struct LocalStepTets {
  const int* T;
  std::size_t K;
  const double* Dinv;
  const double* vol;
  const double* prism_inverse = nullptr;
  const std::uint16_t* unit_corners = nullptr;
  const double* unit_inverse = nullptr;
  const double* points = nullptr;
  const int* override_tets = nullptr;
  std::size_t overrides = 0;
  const double* override_inv = nullptr;

  // Tet t's Dm_inv(k, c) at d[k + 3 c]: a pointer into Dinv, or `scratch` filled.
  const double* dm_inv(std::size_t t, double* scratch) const {
    if (Dinv) return Dinv + 9 * t;
    if (points) {
      detail::positions_form_dm_inv(points, T, static_cast<std::ptrdiff_t>(K), override_tets, overrides, override_inv,
                                    static_cast<std::ptrdiff_t>(t), scratch);
      return scratch;
    }
    detail::multiply_3x3(unit_inverse + 9 * static_cast<std::size_t>(unit_corners[t]), prism_inverse + 9 * (t / 3), scratch);
    return scratch;
  }
};
static_assert(sizeof(Eigen::Matrix3d) == 9 * sizeof(double), "Dm_inv matrices must be contiguous");

// Where the local step puts each tet's vol Dm_inv R^T: stored per tet (Q, 9 per tet, row-major)
// for a later gather, or added at once into the rotations' part of the right-hand side (b: nf x 3
// column-major, rows by free_index; the caller makes sure no other thread adds to the same rows).
struct RotationSink {
  double* Q = nullptr;
  double* b = nullptr;
  const int* free_index = nullptr;
  std::size_t nf = 0;
};

// The local step over tets [t_begin, t_end): their energy, and (with a sink) every tet's
// vol Dm_inv R^T for the right-hand side. X: row-major positions.
GSHELL_SIMD_KERNEL double local_step_body(const LocalStepTets& tets, const double* X, const RotationSink& sink,
                                          int t_begin, int t_end) {
  double* const Q = sink.Q;
  const bool rotations = Q || sink.b;
  constexpr int W = detail::kPolarLanes;
  double e = 0;
  // W tets at a time in struct-of-arrays layout (entry k of lane l at [k * W + l]) so that the
  // polar decomposition and everything after it run across lanes in SIMD registers.
  alignas(64) double Fs[9 * W], Rs[9 * W], Ds[9 * W], Ps[9 * W], vols[W];
  for (int t0 = t_begin; t0 < t_end; t0 += W) {
    const int lanes = std::min(W, t_end - t0);
    for (int l = 0; l < W; ++l) {
      if (l >= lanes) { // padding: identity F, zero volume, so it adds nothing
        for (int k = 0; k < 9; ++k) {
          Fs[k * W + l] = (k % 4 == 0) ? 1.0 : 0.0;
          Ds[k * W + l] = 0.0;
        }
        vols[l] = 0.0;
        continue;
      }
      // F_t = D_t Dm_inv_t with D = the current edge vectors x_{j+1} - x_0 as columns.
      const int t = t0 + l;
      const int* v = tets.T + t;
      double di_scratch[9];
      const double* di = tets.dm_inv(static_cast<std::size_t>(t), di_scratch); // Dm_inv(k, c) = di[k + 3 c]
      const double* x0 = X + 3 * static_cast<std::size_t>(v[0]);
      double D[3][3];
      for (int j = 0; j < 3; ++j) {
        const double* xj = X + 3 * static_cast<std::size_t>(v[(j + 1) * tets.K]);
        for (int r = 0; r < 3; ++r) D[r][j] = xj[r] - x0[r];
      }
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
          Fs[(3 * r + c) * W + l] = D[r][0] * di[3 * c] + D[r][1] * di[1 + 3 * c] + D[r][2] * di[2 + 3 * c];
      if (rotations) // Ds: Dm_inv row-major
        for (int k = 0; k < 3; ++k)
          for (int c = 0; c < 3; ++c) Ds[(3 * k + c) * W + l] = di[k + 3 * c];
      vols[l] = tets.vol[t];
    }
    detail::closest_rotations_lanes(Fs, Rs);
    alignas(64) double d2[W] = {};
    for (int k = 0; k < 9; ++k)
      for (int l = 0; l < W; ++l) {
        const double d = Fs[k * W + l] - Rs[k * W + l];
        d2[l] += d * d;
      }
    for (int l = 0; l < W; ++l) e += vols[l] * d2[l];
    if (!rotations) continue;
    // vol Dm_inv R^T: rows 1..3 of this tet's share vol G_t R^T of the right-hand side (row 0
    // is minus their sum, G_t = [-1 -1 -1; I] Dm_inv).
    for (int k = 0; k < 3; ++k)
      for (int r = 0; r < 3; ++r)
        for (int l = 0; l < W; ++l)
          Ps[(3 * k + r) * W + l] =
              vols[l] * (Ds[(3 * k) * W + l] * Rs[(3 * r) * W + l] + Ds[(3 * k + 1) * W + l] * Rs[(3 * r + 1) * W + l] +
                         Ds[(3 * k + 2) * W + l] * Rs[(3 * r + 2) * W + l]);
    if (Q) {
      // Stored per tet, contiguously, so the writes stream; the gather picks the rows it needs.
      double* q = Q + 9 * static_cast<std::size_t>(t0);
      for (int l = 0; l < lanes; ++l)
        for (int k = 0; k < 9; ++k) q[9 * l + k] = Ps[k * W + l];
      continue;
    }
    // Added as gather_rhs would add them (same expressions, same order per row).
    for (int l = 0; l < lanes; ++l)
      for (int c = 0; c < 4; ++c) {
        const int j = sink.free_index[tets.T[t0 + l + c * tets.K]];
        if (j < 0) continue;
        double* row = sink.b + j;
        for (int r = 0; r < 3; ++r) {
          if (c == 0)
            row[r * sink.nf] -= Ps[r * W + l] + Ps[(3 + r) * W + l] + Ps[(6 + r) * W + l];
          else
            row[r * sink.nf] += Ps[(3 * (c - 1) + r) * W + l];
        }
      }
  }
  return e;
}

GSHELL_SIMD_DISPATCH(double, local_step_chunk, local_step_body,
                     (const LocalStepTets& tets, const double* X, const RotationSink& sink, int t_begin, int t_end),
                     (tets, X, sink, t_begin, t_end))

} // namespace

struct ShellSolver::Impl {
  std::shared_ptr<const RestTets> rest;
  int N = 0;      // rows of the state
  int K = 0;      // tets
  int nf = 0;     // free (solved-for) vertices
  SoftConstraints soft;

  // The gradient operator is G_t = E Dm_inv with E = [-1 -1 -1; I] (4x3): F_t = X_t^T G_t for
  // the 4x3 stacked corner positions X_t. The tets are read from *rest in place (LocalStepTets).
  int tet(int t, int j) const { return rest->T(t, j); }
  double vol(int t) const { return rest->volume[t]; }
  LocalStepTets local_step_tets() const {
    LocalStepTets tets{rest->T.data(), static_cast<std::size_t>(K), nullptr, rest->volume.data()};
    if (!rest->Dm_inv.empty())
      tets.Dinv = rest->Dm_inv[0].data();
    else if (!rest->rest_points.empty()) {
      tets.points = rest->rest_points.data();
      tets.override_tets = rest->override_tets.data();
      tets.overrides = rest->override_tets.size();
      tets.override_inv = rest->override_Dm_inv.empty() ? nullptr : rest->override_Dm_inv[0].data();
    } else if (K > 0) {
      tets.prism_inverse = rest->prism_inverse[0].data();
      tets.unit_corners = rest->unit_corners.data();
      tets.unit_inverse = unit_corner_inverses()[0].data();
    }
    return tets;
  }

  std::vector<int> free_vertices; // free index -> vertex
  std::vector<int> free_index;    // vertex -> free index, -1 for vertices kept where they start
  // The local step's chunks (kChunk tets each) grouped by colour: chunks of one colour share no
  // free vertex, so solve() lets them add their rows of the right-hand side straight into it, in
  // parallel and in a fixed order, instead of storing 72 bytes of rotations per tet for a gather
  // (1.1 GB at 15.7M tets, the largest buffer of a big generation). Chunks of colour c are
  // colour_chunk[colour_start[c] .. colour_start[c + 1]). Empty when the tets are ordered so
  // incoherently that too many colours would be needed (then solve() stores and gathers).
  std::vector<int> colour_start, colour_chunk;
  // Per free vertex: the (tet * 4 + corner) slots of the local step's RHS rows to sum (a gather,
  // so the global step's right-hand side is built in parallel without atomics). The assembly
  // reads it; with the colouring, solve() does not, so it is freed after the assembly (at 15.7M
  // tets it is 0.26 GB at the generation's peak) and made again on the first use of the
  // step-by-step API (global_step, half_gradient), which always gathers.
  mutable std::vector<int> gather_start, gather_slot;
  mutable std::once_flag gather_remade;
  void build_gather() const;
  void ensure_gather() const {
    std::call_once(gather_remade, [this] {
      if (gather_start.empty()) build_gather();
    });
  }
  // The system's free rows (L plus the soft springs' diagonal) in two parts: L_ff, their free
  // columns (by free index, CSR, ascending), and L_fc, their kept columns (by vertex id; L_fc x_c
  // is the exact Dirichlet elimination term). With the multigrid, L_ff is its finest level's
  // matrix, handed over rather than copied (0.2 GB at 2.6M rows); lff() reads it where it is.
  RowMatrix ff;
  std::vector<int> fc_start, fc_col;
  std::vector<double> fc_val;
  const RowMatrix& lff() const { return multigrid ? multigrid->matrix() : ff; }
  std::vector<int> soft_free; // free index of every soft vertex, -1 if that vertex is kept
  std::vector<double> jacobi; // 1 / diagonal of L_ff (CG's preconditioner)
  std::unique_ptr<AggregationMultigrid> multigrid; // CG's preconditioner unless Jacobi was asked for

  LinearSolverOptions linear;
  mutable LinearSolver path = LinearSolver::Direct; // Direct or ConjugateGradient (Auto resolved)
  // CG's iterate, residual, direction, product and preconditioned residual (multigrid).
  mutable std::vector<double> cg_x, cg_r, cg_p, cg_q, cg_z;

  mutable double factor_seconds = 0;
  mutable std::mutex solve_mutex; // the factor's workspace is shared: one linear solve at a time

#ifdef GSHELL_HAVE_CHOLMOD
  mutable cholmod_common cm;
  mutable cholmod_factor* factor = nullptr;
  // A CHOLMOD common with the solution and workspaces of one concurrent triangular solve. They
  // persist between solves: allocating them per call costs page faults comparable to the solve.
  struct SolveLane {
    cholmod_common cm;
    cholmod_dense *x = nullptr, *y = nullptr, *e = nullptr;
    SolveLane() {
      cholmod_start(&cm);
      cm.print = 0;
      cm.error_handler = nullptr;
    }
    ~SolveLane() {
      cholmod_free_dense(&x, &cm);
      cholmod_free_dense(&y, &cm);
      cholmod_free_dense(&e, &cm);
      cholmod_finish(&cm);
    }
    SolveLane(const SolveLane&) = delete;
    SolveLane& operator=(const SolveLane&) = delete;
  };
  mutable SolveLane lanes[2];
#else
  mutable Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Upper> ldlt;
#endif

  Impl() {
#ifdef GSHELL_HAVE_CHOLMOD
    cholmod_start(&cm);
    cm.print = 0;
    cm.error_handler = nullptr;
    cm.supernodal = CHOLMOD_SUPERNODAL;
#endif
  }
  ~Impl() {
#ifdef GSHELL_HAVE_CHOLMOD
    if (factor) cholmod_free_factor(&factor, &cm);
    cholmod_finish(&cm);
#endif
  }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  void setup(const std::vector<int>& fixed);
  void assemble(); // the rows of L (ff, fc_*), the Jacobi preconditioner, and the choice of path
  void factorize() const; // the Cholesky factor of L_ff (path becomes Direct)
  void build_multigrid(); // the V-cycle preconditioner on L_ff
  void order_rows_breadth_first(); // renumbers the free rows (CG path; see assemble)
  bool anchored() const;  // at least half the free rows couple to a kept vertex or a soft spring
  bool auto_takes_cg() const; // Auto's choice (LinearSolverOptions::cg_min_rows, cg_loose_min_rows)
  // Throws InputError when a connected part of the free vertices has neither a kept vertex in its
  // tets nor a spring: its rows of L_ff are singular. The factorisation's own test misses such a
  // part when rounding leaves its pivots positive, and the CG path has none.
  void require_every_part_held(bool has_soft) const;

  // Energy of X; with Q (9 per tet), also every tet's vol Dm_inv R^T (row-major) for the RHS;
  // with b (3 nf, needs the colouring) instead, b <- the rotations' part of the right-hand side,
  // what gather_rhs would give row by row, bit for bit.
  double local_step(const double* X, double* Q, std::vector<double>* b = nullptr) const;
  void colour_chunks();
  double soft_energy(const double* X, const Eigen::MatrixXd& targets) const;
  // rhs: nf x 3 column-major, overwritten with the solution; X (row-major, all vertices) gives
  // CG its start. Returns the CG iterations taken (0 on the direct path).
  int linear_solve(const double* X, std::vector<double>& rhs) const;
  // rhs (nf x columns, column-major) <- A_ff^-1 rhs.
  void direct_solve(double* rhs, int columns = 3) const;
  // Jacobi-preconditioned CG on the three columns at once (each with its own step sizes), from
  // X's free rows; returns the iterations and whether every column met the tolerance.
  std::pair<int, bool> cg_solve(const double* X, std::vector<double>& rhs) const;
  // The part of the right-hand side that does not depend on the rotations: -L_fc x_c (exact
  // elimination of the kept vertices) plus the soft constraints' w p; nf x 3 column-major.
  std::vector<double> rhs_constant(const double* X, const Eigen::MatrixXd& soft_targets) const;
  // Row j of the rotations' part of the right-hand side, sum_t vol G_t R_t^T at free vertex j.
  void gather_rhs(int j, const double* Q, double b[3]) const;
  // X's free rows <- the minimiser for the rotations in Q (rhs: nf x 3 scratch).
  int global_step(double* X, const double* Q, const std::vector<double>& rhs_const, std::vector<double>& rhs) const;
  // X's free rows <- the solution for the full right-hand side rhs (overwritten); CG iterations.
  int solve_free_rows(double* X, std::vector<double>& rhs) const;

  void check_positions(const Eigen::MatrixXd& X, const char* where) const {
    if (X.rows() != N || X.cols() != 3)
      throw InputError(std::string("ShellSolver::") + where + ": expected " + std::to_string(N) + " x 3 positions");
    // A NaN in a fixed row reached every row through the solve, without an error.
    if (!X.allFinite()) throw InputError(std::string("ShellSolver::") + where + ": a position is not finite");
  }
  void check_soft_targets(const Eigen::MatrixXd& targets, const char* where) const {
    if (!soft_free.empty() &&
        (targets.rows() != static_cast<Eigen::Index>(soft.vertices.size()) || targets.cols() != 3))
      throw InputError(std::string("ShellSolver::") + where + ": expected " + std::to_string(soft.vertices.size()) +
                       " x 3 soft constraint targets");
    if (!soft_free.empty() && !targets.allFinite())
      throw InputError(std::string("ShellSolver::") + where + ": a soft constraint target is not finite");
  }
  void check_step(const LocalStep& step, const char* where) const {
    if (step.Q.size() != 9 * static_cast<std::size_t>(K))
      throw InputError(std::string("ShellSolver::") + where + ": the local step is for another solver");
  }
};

void ShellSolver::Impl::setup(const std::vector<int>& fixed) {
  K = rest->size();
  for (int t = 0; t < K; ++t)
    for (int j = 0; j < 4; ++j) {
      const int v = tet(t, j);
      if (v < 0 || v >= N)
        throw InputError("tet " + std::to_string(t) + " has vertex id " + std::to_string(v) + " out of range");
    }

  // Vertices no tet (and no soft constraint) touches have no equation: keep them where they start.
  std::vector<char> used(N, 0);
  for (int t = 0; t < K; ++t)
    for (int j = 0; j < 4; ++j) used[tet(t, j)] = 1;
  const bool has_soft = soft.weight > 0 && !soft.vertices.empty();
  if (has_soft)
    for (int v : soft.vertices) {
      if (v < 0 || v >= N) throw InputError("soft constraint vertex " + std::to_string(v) + " out of range");
      used[v] = 1;
    }
  for (int v : fixed) {
    if (v < 0 || v >= N) throw InputError("fixed vertex " + std::to_string(v) + " out of range");
    used[v] = 0;
  }
  detail::assign_populated(free_index, N, -1);
  free_vertices.clear();
  for (int v = 0; v < N; ++v)
    if (used[v]) {
      free_index[v] = static_cast<int>(free_vertices.size());
      free_vertices.push_back(v);
    }
  nf = static_cast<int>(free_vertices.size());
  require_every_part_held(has_soft);

  colour_chunks();
  build_gather();
  soft_free.clear();
  if (has_soft)
    for (int v : soft.vertices) soft_free.push_back(free_index[v]);
}

void ShellSolver::Impl::build_gather() const {
  gather_start.assign(nf + 1, 0);
  for (int t = 0; t < K; ++t)
    for (int j = 0; j < 4; ++j)
      if (free_index[tet(t, j)] >= 0) ++gather_start[free_index[tet(t, j)] + 1];
  for (int j = 0; j < nf; ++j) gather_start[j + 1] += gather_start[j];
  detail::assign_populated(gather_slot, gather_start[nf]);
  std::vector<int> fill(gather_start.begin(), gather_start.end() - 1);
  // Each row's slots in the order the coloured local step adds them (colour by colour, chunks and
  // tets ascending), so that the gather and the fused step give the same bits.
  auto add_slots = [&](int t_begin, int t_end) {
    for (int t = t_begin; t < t_end; ++t)
      for (int k = 0; k < 4; ++k) {
        const int j = free_index[tet(t, k)];
        if (j >= 0) gather_slot[fill[j]++] = 4 * t + k;
      }
  };
  if (colour_chunk.empty()) add_slots(0, K);
  for (int chunk : colour_chunk) add_slots(chunk * kChunk, std::min(K, (chunk + 1) * kChunk));
}

void ShellSolver::Impl::assemble() {
  // Row j of L = sum_t vol_t G_t G_t^T, built from free vertex j's own tets (rows in parallel).
  std::vector<double> soft_diag(nf, 0.0);
  for (int j : soft_free)
    if (j >= 0) soft_diag[j] += soft.weight;
  // Rows are built in blocks (in parallel), each block into buffers of exactly its entries, then
  // copied into place: a row has about 15 distinct columns, so a short list searched linearly
  // accumulates them in cache. (A dense per-thread array indexed by vertex, with a buffer of one
  // slot per tet corner, made the assembly of 2.6M rows twice as slow per row as of 655K rows:
  // random access over tens of MB and page faults on a 1.5 GB buffer.)
  const int blocks = (nf + kAssembleBlock - 1) / kAssembleBlock;
  struct RowBlock {
    std::vector<int> col, len, nfree; // columns of the block's rows in row order, sorted per row
    std::vector<double> val;
  };
  std::vector<RowBlock> row_blocks(blocks);
  const LocalStepTets tets = local_step_tets();
  tbb::parallel_for(0, blocks, [&](int b) {
    RowBlock& out = row_blocks[b];
    std::vector<std::pair<int, double>> row; // (column, sum) in order of first touch
    for (int j = b * kAssembleBlock; j < std::min(nf, (b + 1) * kAssembleBlock); ++j) {
      row.clear();
      auto add = [&](int v, double val) {
        for (auto& e : row)
          if (e.first == v) {
            e.second += val;
            return;
          }
        row.emplace_back(v, val);
      };
      add(free_vertices[j], soft_diag[j]);
      // The next row's tets are fetched while this row sums: at millions of tets their Dm_inv
      // come from memory, and waiting for each in turn took most of the assembly.
      // (Not in the positions form: a tet's rest points are its neighbours', mostly cached.)
      if (j + 1 < nf && !tets.points)
        for (int s = gather_start[j + 1]; s < gather_start[j + 2]; ++s) {
          const std::size_t t = gather_slot[s] / 4;
          const double* d = tets.Dinv ? tets.Dinv + 9 * t : tets.prism_inverse + 9 * (t / 3);
          __builtin_prefetch(d);
          __builtin_prefetch(d + 8);
        }
      for (int s = gather_start[j]; s < gather_start[j + 1]; ++s) {
        const int t = gather_slot[s] / 4, k = gather_slot[s] % 4;
        double scratch[9];
        const double* di = tets.dm_inv(t, scratch); // Dm_inv(i, c) = di[i + 3 c]
        double g[12]; // G_t = E Dm_inv, row-major 4x3
        for (int c = 0; c < 3; ++c) {
          g[c] = -(di[3 * c] + di[1 + 3 * c] + di[2 + 3 * c]);
          for (int i = 0; i < 3; ++i) g[3 * (i + 1) + c] = di[i + 3 * c];
        }
        for (int a = 0; a < 4; ++a)
          add(tet(t, a), vol(t) * (g[3 * k] * g[3 * a] + g[3 * k + 1] * g[3 * a + 1] + g[3 * k + 2] * g[3 * a + 2]));
      }
      std::sort(row.begin(), row.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
      int nfree = 0;
      for (const auto& [v, val] : row) {
        out.col.push_back(v);
        out.val.push_back(val);
        nfree += free_index[v] >= 0;
      }
      out.len.push_back(static_cast<int>(row.size()));
      out.nfree.push_back(nfree);
    }
  });

  // The rows, split into L_ff and L_fc.
  ff.resize(nf, nf);
  fc_start.assign(nf + 1, 0);
  int* ff_start = ff.outerIndexPtr();
  for (int j = 0; j < nf; ++j) {
    const RowBlock& b = row_blocks[j / kAssembleBlock];
    const int len = b.len[j % kAssembleBlock], nfree = b.nfree[j % kAssembleBlock];
    ff_start[j + 1] = ff_start[j] + nfree;
    fc_start[j + 1] = fc_start[j] + len - nfree;
  }
  ff.resizeNonZeros(ff_start[nf]); // not written yet: its pages are first touched in parallel below
  int* ff_col = ff.innerIndexPtr();
  double* ff_val = ff.valuePtr();
  detail::assign_populated(fc_col, fc_start[nf]);
  detail::assign_populated(fc_val, fc_start[nf]);
  detail::assign_populated(jacobi, nf);
  tbb::parallel_for(0, blocks, [&](int b) {
    RowBlock& in = row_blocks[b];
    int e = 0;
    for (int j = b * kAssembleBlock; j < std::min(nf, (b + 1) * kAssembleBlock); ++j) {
      int free_out = ff_start[j], kept_out = fc_start[j];
      for (const int end = e + in.len[j - b * kAssembleBlock]; e < end; ++e) { // sorted by vertex id = by free id
        const int v = in.col[e];
        const int i = free_index[v];
        if (i < 0) {
          fc_col[kept_out] = v;
          fc_val[kept_out++] = in.val[e];
          continue;
        }
        ff_col[free_out] = i;
        ff_val[free_out++] = in.val[e];
        if (i == j) jacobi[j] = in.val[e] > 0 ? 1.0 / in.val[e] : 0.0;
      }
    }
    in = RowBlock{}; // freed as soon as copied: the peak holds the matrix about twice, not more
  });
  if (!colour_chunk.empty()) { // solve() adds the rotations without it (see gather_slot)
    gather_start = {};
    gather_slot = {};
  }
  if (nf == 0) return;
  path = linear.kind == LinearSolver::ConjugateGradient || (linear.kind == LinearSolver::Auto && auto_takes_cg())
             ? LinearSolver::ConjugateGradient
             : LinearSolver::Direct;
  // CG's products and the multigrid's sweeps read every row's neighbours, which the input's
  // vertex order may scatter over the whole array (a scanned mesh's order, kept by subdivision:
  // at 600K rows CG took twice as long per iteration as in this order). A factor picks its own
  // ordering, so the direct path keeps ascending vertex order and its bits.
  if (path == LinearSolver::ConjugateGradient) order_rows_breadth_first();
}

void ShellSolver::Impl::order_rows_breadth_first() {
  const std::vector<int> old_row = detail::breadth_first_order(ff); // new row -> old row
  ff = detail::permute_symmetric(ff, old_row);
  // Rows of a (start, items...) table moved to their new places.
  auto move_rows = [&](std::vector<int>& start, auto&... items) {
    std::vector<int> moved(nf + 1, 0);
    for (int j = 0; j < nf; ++j) moved[j + 1] = moved[j] + start[old_row[j] + 1] - start[old_row[j]];
    auto move = [&](auto& v) {
      std::remove_reference_t<decltype(v)> out(v.size());
      tbb::parallel_for(0, nf, [&](int j) {
        std::copy(v.begin() + start[old_row[j]], v.begin() + start[old_row[j] + 1], out.begin() + moved[j]);
      });
      v.swap(out);
    };
    (move(items), ...);
    start.swap(moved);
  };
  move_rows(fc_start, fc_col, fc_val);
  if (!gather_start.empty()) move_rows(gather_start, gather_slot); // kept only without the colouring
  std::vector<int> vertices(nf);
  std::vector<double> diag(nf);
  for (int j = 0; j < nf; ++j) {
    vertices[j] = free_vertices[old_row[j]];
    free_index[vertices[j]] = j;
    diag[j] = jacobi[old_row[j]];
  }
  free_vertices.swap(vertices);
  jacobi.swap(diag);
  for (std::size_t c = 0; c < soft_free.size(); ++c) soft_free[c] = free_index[soft.vertices[c]]; // as in setup
}

void ShellSolver::Impl::require_every_part_held(bool has_soft) const {
  // Generation and deformation keep the base, so every tet has a kept corner: one pass tells.
  const bool every_tet_kept = tbb::parallel_reduce(
      tbb::blocked_range<int>(0, K, 1 << 14), true,
      [&](const tbb::blocked_range<int>& r, bool all) {
        for (int t = r.begin(); all && t < r.end(); ++t)
          all = free_index[tet(t, 0)] < 0 || free_index[tet(t, 1)] < 0 || free_index[tet(t, 2)] < 0 ||
                free_index[tet(t, 3)] < 0;
        return all;
      },
      std::logical_and<bool>());
  if (every_tet_kept) return;
  // Otherwise the parts of the free vertices joined by tets, each held by a kept corner of one of
  // its tets or by a spring on one of its vertices.
  detail::DisjointSets parts(nf);
  std::vector<char> held(nf, 0);
  for (int t = 0; t < K; ++t) {
    int first = -1;
    bool kept = false;
    for (int k = 0; k < 4; ++k) {
      const int j = free_index[tet(t, k)];
      if (j < 0) {
        kept = true;
      } else if (first < 0) {
        first = j;
      } else {
        parts.unite(first, j);
      }
    }
    if (kept && first >= 0) held[first] = 1;
  }
  if (has_soft)
    for (int v : soft.vertices) held[free_index[v]] = 1;
  std::vector<char> part_held(nf, 0);
  for (int j = 0; j < nf; ++j)
    if (held[j]) part_held[parts.find(j)] = 1;
  for (int j = 0; j < nf; ++j) // by vertex id: the lowest free vertex of the first part names it
    if (!part_held[parts.find(j)])
      throw InputError("the shell system is singular: a connected part of the tets has no fixed or constrained "
                       "vertex (e.g. the part with vertex " + std::to_string(free_vertices[j]) + ")");
}

bool ShellSolver::Impl::auto_takes_cg() const {
  if (nf < linear.cg_min_rows) return false;
  if (anchored()) return true;
  // Loosely held (a pose): the Jacobi CG's iterations grow with the size and never pay; the
  // multigrid's do not, and from cg_loose_min_rows on they cost no more than back-substitution
  // per step while the factor's setup and memory grow faster (docs/scale.md).
  return linear.preconditioner == CgPreconditioner::Multigrid && nf >= linear.cg_loose_min_rows;
}

bool ShellSolver::Impl::anchored() const {
  std::vector<char> anchor(nf, 0);
  for (int j : soft_free)
    if (j >= 0) anchor[j] = 1;
  long count = 0;
  for (int j = 0; j < nf; ++j) count += anchor[j] || fc_start[j] < fc_start[j + 1];
  return 2 * count >= nf;
}

void ShellSolver::Impl::build_multigrid() {
  multigrid = std::make_unique<AggregationMultigrid>(std::move(ff), linear.multigrid); // ff is left empty
}

void ShellSolver::Impl::factorize() const {
  const auto t0 = Clock::now();
  // The upper triangle of L_ff in CSC (= the lower triangle of its rows: L_ff is symmetric).
  const RowMatrix& L = lff();
  const int* L_start = L.outerIndexPtr();
  const int* L_col = L.innerIndexPtr();
  const double* L_val = L.valuePtr();
  std::vector<int> upper_start(nf + 1, 0);
  for (int j = 0; j < nf; ++j) {
    int nff = 0;
    for (int e = L_start[j]; e < L_start[j + 1] && L_col[e] <= j; ++e) ++nff; // ascending
    upper_start[j + 1] = upper_start[j] + nff;
  }
  const std::string singular =
      "the shell system is singular: a connected part of the tets has no fixed or constrained vertex";
#ifdef GSHELL_HAVE_CHOLMOD
  cholmod_sparse* A = cholmod_allocate_sparse(nf, nf, upper_start[nf], 1, 1, 1, CHOLMOD_REAL, &cm);
  if (!A) throw std::bad_alloc();
  std::copy(upper_start.begin(), upper_start.end(), static_cast<int*>(A->p));
  tbb::parallel_for(0, nf, [&](int j) {
    int* rows = static_cast<int*>(A->i) + upper_start[j];
    double* vals = static_cast<double*>(A->x) + upper_start[j];
    for (int k = 0; k < upper_start[j + 1] - upper_start[j]; ++k) {
      rows[k] = L_col[L_start[j] + k];
      vals[k] = L_val[L_start[j] + k];
    }
  });
  factor = cholmod_analyze(A, &cm);
  if (!factor) {
    cholmod_free_sparse(&A, &cm);
    throw std::runtime_error("CHOLMOD analysis failed (status " + std::to_string(cm.status) + ")");
  }
  const int ok = detail::cholmod_factorize_small_serially(A, factor, &cm);
  cholmod_free_sparse(&A, &cm);
  if (!ok || cm.status == CHOLMOD_NOT_POSDEF || factor->minor < factor->n) throw InputError(singular);
  // The supernodal factorisation is the fast one, but the solve with three right-hand sides is
  // faster on a simplicial LL^T (one sweep over L, no BLAS call per supernode): convert once.
  if (!cholmod_change_factor(CHOLMOD_REAL, 1, 0, 1, 1, factor, &cm))
    throw std::runtime_error("CHOLMOD factor conversion failed (status " + std::to_string(cm.status) + ")");
#else
  std::vector<int> upper_row(upper_start[nf]);
  std::vector<double> upper_val(upper_start[nf]);
  for (int j = 0; j < nf; ++j)
    for (int k = 0; k < upper_start[j + 1] - upper_start[j]; ++k) {
      upper_row[upper_start[j] + k] = L_col[L_start[j] + k];
      upper_val[upper_start[j] + k] = L_val[L_start[j] + k];
    }
  Eigen::Map<const Eigen::SparseMatrix<double>> A(nf, nf, upper_start[nf], upper_start.data(), upper_row.data(),
                                                  upper_val.data());
  ldlt.compute(A);
  if (ldlt.info() != Eigen::Success || (ldlt.vectorD().array() <= 0).any()) throw InputError(singular);
#endif
  path = LinearSolver::Direct;
  factor_seconds += seconds_since(t0);
}

double ShellSolver::Impl::local_step(const double* X, double* Q, std::vector<double>* b) const {
  static_assert(kChunk % detail::kPolarLanes == 0);
  const int chunks = (K + kChunk - 1) / kChunk;
  std::vector<double> chunk_energy(chunks, 0.0);
  const LocalStepTets tets = local_step_tets();
  RotationSink sink{Q};
  if (b) {
    b->assign(3 * static_cast<std::size_t>(nf), 0.0);
    sink = {nullptr, b->data(), free_index.data(), static_cast<std::size_t>(nf)};
  }
  auto run = [&](int ci) {
    chunk_energy[ci] = local_step_chunk(tets, X, sink, ci * kChunk, std::min(K, (ci + 1) * kChunk));
  };
  if (!b)
    tbb::parallel_for(0, chunks, run);
  else // colour after colour: chunks of one colour add to disjoint rows
    for (std::size_t c = 0; c + 1 < colour_start.size(); ++c)
      tbb::parallel_for(colour_start[c], colour_start[c + 1], [&](int s) { run(colour_chunk[s]); });
  double E = 0;
  for (double e : chunk_energy) E += e;
  return E;
}

void ShellSolver::Impl::colour_chunks() {
  // Greedy colouring: a chunk takes the lowest colour no earlier chunk sharing a free vertex has
  // (one bit per colour and vertex). Tets in mesh order touch a compact region per chunk, so a
  // few colours do (8 for an icosphere's 30 chunks); a shuffled order needs about one per chunk,
  // and then the gather path is kept.
  constexpr int kMaxColours = 32;
  colour_start.clear();
  colour_chunk.clear();
  const int chunks = (K + kChunk - 1) / kChunk;
  std::vector<std::uint32_t> used(nf, 0);
  std::vector<int> colour(chunks, 0);
  int colours = 0;
  for (int ci = 0; ci < chunks; ++ci) {
    std::uint32_t taken = 0;
    const int t_end = std::min(K, (ci + 1) * kChunk);
    for (int t = ci * kChunk; t < t_end; ++t)
      for (int k = 0; k < 4; ++k)
        if (const int j = free_index[tet(t, k)]; j >= 0) taken |= used[j];
    if (taken == ~std::uint32_t{0}) return; // more than kMaxColours needed
    const int c = std::countr_one(taken);
    colour[ci] = c;
    colours = std::max(colours, c + 1);
    for (int t = ci * kChunk; t < t_end; ++t)
      for (int k = 0; k < 4; ++k)
        if (const int j = free_index[tet(t, k)]; j >= 0) used[j] |= std::uint32_t{1} << c;
  }
  static_assert(kMaxColours == 32, "one bit per colour in a 32-bit mask");
  // Colours run one after another: with fewer than 4 chunks per colour on average the fused
  // step would lose more parallelism than the stored rotations cost.
  if (chunks < 4 * colours) return;
  colour_start.assign(colours + 1, 0);
  for (int ci = 0; ci < chunks; ++ci) ++colour_start[colour[ci] + 1];
  for (int c = 0; c < colours; ++c) colour_start[c + 1] += colour_start[c];
  colour_chunk.resize(chunks);
  std::vector<int> fill(colour_start.begin(), colour_start.end() - 1);
  for (int ci = 0; ci < chunks; ++ci) colour_chunk[fill[colour[ci]]++] = ci;
}

double ShellSolver::Impl::soft_energy(const double* X, const Eigen::MatrixXd& targets) const {
  if (soft_free.empty() || targets.rows() == 0) return 0;
  double e = 0;
  for (std::size_t c = 0; c < soft.vertices.size(); ++c)
    for (int d = 0; d < 3; ++d) {
      const double diff = X[3 * static_cast<std::size_t>(soft.vertices[c]) + d] - targets(c, d);
      e += diff * diff;
    }
  return soft.weight * e;
}

std::vector<double> ShellSolver::Impl::rhs_constant(const double* X, const Eigen::MatrixXd& soft_targets) const {
  std::vector<double> b(3 * static_cast<std::size_t>(nf), 0.0);
  tbb::parallel_for(0, nf, [&](int j) {
    for (int e = fc_start[j]; e < fc_start[j + 1]; ++e)
      for (int d = 0; d < 3; ++d)
        b[j + static_cast<std::size_t>(d) * nf] -= fc_val[e] * X[3 * static_cast<std::size_t>(fc_col[e]) + d];
  });
  for (std::size_t c = 0; c < soft_free.size(); ++c)
    if (soft_free[c] >= 0)
      for (int d = 0; d < 3; ++d) b[soft_free[c] + static_cast<std::size_t>(d) * nf] += soft.weight * soft_targets(c, d);
  return b;
}

void ShellSolver::Impl::gather_rhs(int j, const double* Q, double b[3]) const {
  b[0] = b[1] = b[2] = 0;
  for (int s = gather_start[j]; s < gather_start[j + 1]; ++s) {
    const int t = gather_slot[s] >> 2, k = gather_slot[s] & 3;
    const double* q = Q + 9 * static_cast<std::size_t>(t);
    if (k == 0) // corner 0's row of G_t is minus the sum of the other three
      for (int r = 0; r < 3; ++r) b[r] -= q[r] + q[3 + r] + q[6 + r];
    else
      for (int r = 0; r < 3; ++r) b[r] += q[3 * (k - 1) + r];
  }
}

int ShellSolver::Impl::global_step(double* X, const double* Q, const std::vector<double>& rhs_const,
                                   std::vector<double>& rhs) const {
  ensure_gather();
  tbb::parallel_for(0, nf, [&](int j) {
    double b[3];
    gather_rhs(j, Q, b);
    for (int d = 0; d < 3; ++d) {
      const std::size_t i = j + static_cast<std::size_t>(d) * nf;
      rhs[i] = b[d] + rhs_const[i];
    }
  });
  return solve_free_rows(X, rhs);
}

int ShellSolver::Impl::solve_free_rows(double* X, std::vector<double>& rhs) const {
  const int cg_iterations = linear_solve(X, rhs);
  tbb::parallel_for(0, nf, [&](int j) {
    for (int d = 0; d < 3; ++d) X[3 * static_cast<std::size_t>(free_vertices[j]) + d] = rhs[j + static_cast<std::size_t>(d) * nf];
  });
  return cg_iterations;
}

int ShellSolver::Impl::linear_solve(const double* X, std::vector<double>& rhs) const {
  std::lock_guard<std::mutex> lock(solve_mutex);
  if (path == LinearSolver::Direct) {
    direct_solve(rhs.data());
    return 0;
  }
  const auto [iterations, converged] = cg_solve(X, rhs);
  if (!converged && linear.kind == LinearSolver::Auto) { // CG does not pay here: factor once
    factorize();
    rhs.swap(cg_x); // cg_solve swapped its iterate into rhs: cg_x holds the right-hand side again
    direct_solve(rhs.data());
  }
  return iterations;
}

std::pair<int, bool> ShellSolver::Impl::cg_solve(const double* X, std::vector<double>& rhs) const {
  const std::size_t n = nf;
  const int chunks = static_cast<int>((n + kCgChunk - 1) / kCgChunk);
  // Kept between solves: fresh vectors would cost a page fault per 4 KB at every global step.
  for (auto* v : {&cg_x, &cg_r, &cg_p, &cg_q})
    if (v->size() != 3 * n) detail::assign_populated(*v, 3 * n);
  if (multigrid && cg_z.size() != 3 * n) detail::assign_populated(cg_z, 3 * n);
  std::vector<double>&x = cg_x, &r = cg_r, &p = cg_p, &q = cg_q, &z = cg_z;
  std::vector<std::array<double, 9>> partial(chunks); // per chunk: up to three sums per column
  // sums <- the chunk-ordered totals of partial.
  auto totals = [&](double sums[9]) {
    for (int k = 0; k < 9; ++k) sums[k] = 0;
    for (const auto& c : partial)
      for (int k = 0; k < 9; ++k) sums[k] += c[k];
  };
  auto for_chunks = [&](auto&& body) { // body(first row, end row, chunk's partial sums)
    tbb::parallel_for(0, chunks, [&](int c) {
      auto& s = partial[c];
      s.fill(0.0);
      body(static_cast<std::size_t>(c) * kCgChunk, std::min(n, static_cast<std::size_t>(c + 1) * kCgChunk), s);
    });
  };
  const int* L_start = lff().outerIndexPtr();
  const int* L_col = lff().innerIndexPtr();
  const double* L_val = lff().valuePtr();
  auto multiply = [&](const std::vector<double>& in, std::size_t j, double out[3]) { // out = (L_ff in)_j
    out[0] = out[1] = out[2] = 0;
    for (int e = L_start[j]; e < L_start[j + 1]; ++e) {
      const std::size_t i = L_col[e];
      const double a = L_val[e];
      for (int d = 0; d < 3; ++d) out[d] += a * in[i + d * n];
    }
  };
  // z <- M^-1 r by one V-cycle on the three columns at once; sums: r.z per column.
  auto v_cycle = [&] {
    using Columns = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3>>;
    multigrid->apply(Columns(r.data(), static_cast<Eigen::Index>(n), 3), Columns(z.data(), static_cast<Eigen::Index>(n), 3));
    for_chunks([&](std::size_t j0, std::size_t j1, std::array<double, 9>& s) {
      for (std::size_t j = j0; j < j1; ++j)
        for (int d = 0; d < 3; ++d) s[d] += r[j + d * n] * z[j + d * n];
    });
  };
  // r = b - L x0 with x0 = X's free rows; p = M^-1 r. Sums: b.b, r.z, r.r.
  for_chunks([&](std::size_t j0, std::size_t j1, std::array<double, 9>&) {
    for (std::size_t j = j0; j < j1; ++j)
      for (int d = 0; d < 3; ++d) x[j + d * n] = X[3 * static_cast<std::size_t>(free_vertices[j]) + d];
  });
  for_chunks([&](std::size_t j0, std::size_t j1, std::array<double, 9>& s) {
    for (std::size_t j = j0; j < j1; ++j) {
      double lx[3];
      multiply(x, j, lx);
      for (int d = 0; d < 3; ++d) {
        const std::size_t i = j + d * n;
        const double bi = rhs[i];
        r[i] = bi - lx[d];
        p[i] = jacobi[j] * r[i];
        s[d] += bi * bi;
        s[3 + d] += r[i] * p[i];
        s[6 + d] += r[i] * r[i];
      }
    }
  });
  double sums[9];
  totals(sums);
  if (multigrid) { // p = z = V-cycle(r) instead of the diagonal scaling above
    const double rr[3] = {sums[6], sums[7], sums[8]}, bb[3] = {sums[0], sums[1], sums[2]};
    v_cycle();
    totals(sums);
    for (int d = 0; d < 3; ++d) {
      sums[3 + d] = sums[d];
      sums[d] = bb[d];
      sums[6 + d] = rr[d];
    }
    std::copy(z.begin(), z.end(), p.begin());
  }
  double limit[3], rz[3];
  bool active[3]; // a column stays active until its residual meets the tolerance
  const double tol2 = linear.cg_tolerance * linear.cg_tolerance;
  // Each column stops at the absolute limit, or once its residual has fallen by the relative
  // factor from the warm start: the local/global iteration needs only a good step, not the
  // step's exact minimiser (docs/scale.md, "Inexact global steps").
  const double relative2 = linear.cg_relative_tolerance * linear.cg_relative_tolerance;
  for (int d = 0; d < 3; ++d) {
    limit[d] = std::max(tol2 * sums[d], relative2 * sums[6 + d]);
    rz[d] = sums[3 + d];
    active[d] = sums[6 + d] > limit[d] && rz[d] > 0;
  }
  int it = 0;
  for (; it < linear.cg_max_iterations && (active[0] || active[1] || active[2]); ++it) {
    // q = L p; sums: p.q
    for_chunks([&](std::size_t j0, std::size_t j1, std::array<double, 9>& s) {
      for (std::size_t j = j0; j < j1; ++j) {
        double lp[3];
        multiply(p, j, lp);
        for (int d = 0; d < 3; ++d) {
          q[j + d * n] = lp[d];
          s[d] += p[j + d * n] * lp[d];
        }
      }
    });
    totals(sums);
    double alpha[3];
    for (int d = 0; d < 3; ++d) alpha[d] = active[d] && sums[d] > 0 ? rz[d] / sums[d] : 0.0;
    // x += alpha p, r -= alpha q; sums: r.r, r.z
    for_chunks([&](std::size_t j0, std::size_t j1, std::array<double, 9>& s) {
      for (std::size_t j = j0; j < j1; ++j)
        for (int d = 0; d < 3; ++d) {
          const std::size_t i = j + d * n;
          x[i] += alpha[d] * p[i];
          r[i] -= alpha[d] * q[i];
          s[d] += r[i] * r[i];
          s[3 + d] += jacobi[j] * r[i] * r[i];
        }
    });
    totals(sums);
    if (multigrid) { // r.z with z = V-cycle(r) instead of the diagonal's
      const double rr[3] = {sums[0], sums[1], sums[2]};
      v_cycle();
      totals(sums);
      for (int d = 0; d < 3; ++d) {
        sums[3 + d] = sums[d];
        sums[d] = rr[d];
      }
    }
    double beta[3];
    for (int d = 0; d < 3; ++d) {
      if (!active[d]) continue;
      beta[d] = sums[3 + d] / rz[d];
      rz[d] = sums[3 + d];
      active[d] = sums[d] > limit[d] && rz[d] > 0;
    }
    // p = M^-1 r + beta p
    for_chunks([&](std::size_t j0, std::size_t j1, std::array<double, 9>&) {
      for (std::size_t j = j0; j < j1; ++j)
        for (int d = 0; d < 3; ++d)
          if (active[d]) {
            const std::size_t i = j + d * n;
            p[i] = (multigrid ? z[i] : jacobi[j] * r[i]) + beta[d] * p[i];
          }
    });
  }
  rhs.swap(x); // and x holds the right-hand side, which linear_solve's fallback reads
  return {it, !active[0] && !active[1] && !active[2]};
}

void ShellSolver::Impl::direct_solve(double* rhs, int columns) const {
#ifdef GSHELL_HAVE_CHOLMOD
  // Column groups solved concurrently, each through its own CHOLMOD common and workspaces (the
  // factor is only read): the triangular solves are memory-bound and single-threaded in CHOLMOD.
  auto solve_columns = [&](SolveLane& lane, int first, int count) {
    cholmod_dense B;
    B.nrow = nf;
    B.ncol = count;
    B.nzmax = static_cast<std::size_t>(count) * nf;
    B.d = nf;
    B.x = rhs + static_cast<std::size_t>(first) * nf;
    B.z = nullptr;
    B.xtype = CHOLMOD_REAL;
    B.dtype = CHOLMOD_DOUBLE;
    const int ok = cholmod_solve2(CHOLMOD_A, factor, &B, nullptr, &lane.x, nullptr, &lane.y, &lane.e, &lane.cm);
    if (!ok || !lane.x) throw std::runtime_error("CHOLMOD solve failed (status " + std::to_string(lane.cm.status) + ")");
    const double* x = static_cast<const double*>(lane.x->x);
    std::copy(x, x + static_cast<std::size_t>(count) * nf, static_cast<double*>(B.x));
  };
  // Small systems solve faster in one sweep than with a second thread joining in.
  if (nf < kParallelSolveRows || columns < 2)
    solve_columns(lanes[0], 0, columns);
  else
    tbb::parallel_invoke([&] { solve_columns(lanes[0], 0, columns / 2); },
                         [&] { solve_columns(lanes[1], columns / 2, columns - columns / 2); });
#else
  Eigen::Map<Eigen::MatrixXd> B(rhs, nf, columns);
  B = ldlt.solve(Eigen::MatrixXd(B));
#endif
}

ShellSolver::ShellSolver(RestTets rest, int num_vertices, const std::vector<int>& fixed,
                         const SoftConstraints& soft, const LinearSolverOptions& linear)
    : ShellSolver(std::make_shared<const RestTets>(std::move(rest)), num_vertices, fixed, soft, linear) {}

ShellSolver::ShellSolver(std::shared_ptr<const RestTets> rest, int num_vertices, const std::vector<int>& fixed,
                         const SoftConstraints& soft, const LinearSolverOptions& linear)
    : impl_(std::make_unique<Impl>()) {
  const auto t0 = Clock::now();
  impl_->rest = std::move(rest);
  if (!impl_->rest) throw InputError("ShellSolver: no rest tets");
  impl_->N = num_vertices;
  impl_->soft = soft;
  impl_->linear = linear;
  if (!(linear.cg_tolerance > 0) || !std::isfinite(linear.cg_tolerance))
    throw InputError("ShellSolver: the CG tolerance must be positive and finite");
  if (!(linear.cg_relative_tolerance >= 0 && linear.cg_relative_tolerance < 1))
    throw InputError("ShellSolver: the relative CG tolerance must be in [0, 1)");
  if (linear.cg_max_iterations < 1) throw InputError("ShellSolver: the CG iteration limit must be at least 1");
  if (linear.cg_min_rows < 0) throw InputError("ShellSolver: cg_min_rows must be at least 0 (0: CG at every size)");
  if (linear.cg_loose_min_rows < 0)
    throw InputError("ShellSolver: cg_loose_min_rows must be at least 0 (0: from cg_min_rows on)");
  // Springs of weight 0 would be dropped without a word (SoftConstraints{vertices} leaves the
  // weight at its default 0), and a part held only by them would then drift.
  if (!soft.vertices.empty() && !(soft.weight > 0 && std::isfinite(soft.weight)))
    throw InputError("ShellSolver: the soft constraint weight must be positive and finite (got " +
                     format_number(soft.weight) + ")");
  if (!impl_->rest->complete())
    throw InputError("ShellSolver: rest tets are incomplete");
  check_rest_numbers(*impl_->rest);
  impl_->setup(fixed);
  impl_->assemble();
  if (impl_->nf > 0 && impl_->path == LinearSolver::Direct) impl_->factorize();
  if (impl_->nf > 0 && impl_->path == LinearSolver::ConjugateGradient &&
      linear.preconditioner == CgPreconditioner::Multigrid)
    impl_->build_multigrid();
  impl_->factor_seconds = seconds_since(t0);
}

ShellSolver::~ShellSolver() = default;
ShellSolver::ShellSolver(ShellSolver&&) noexcept = default;
ShellSolver& ShellSolver::operator=(ShellSolver&&) noexcept = default;

const std::vector<int>& ShellSolver::free_vertices() const { return impl_->free_vertices; }

void ShellSolver::apply_inverse(Eigen::MatrixXd& B) const {
  const Impl& m = *impl_;
  if (B.rows() != m.nf || B.cols() < 1)
    throw InputError("ShellSolver::apply_inverse: expected " + std::to_string(m.nf) + " free rows and a column or more");
  if (m.nf == 0) return;
  // Callers use the inverse inside their own iterations (the guard's preconditioner): it must be
  // exact, so a solver on the CG path factors here once.
  std::lock_guard<std::mutex> lock(m.solve_mutex);
  if (m.path != LinearSolver::Direct) m.factorize();
  m.direct_solve(B.data(), static_cast<int>(B.cols()));
}

Eigen::MatrixXd ShellSolver::multiply_free(const Eigen::MatrixXd& P) const {
  const Impl& m = *impl_;
  if (P.rows() != m.nf || P.cols() != 3)
    throw InputError("ShellSolver::multiply_free: expected " + std::to_string(m.nf) + " x 3 free rows");
  Eigen::MatrixXd out(m.nf, 3);
  const auto& L = m.lff();
  tbb::parallel_for(tbb::blocked_range<int>(0, m.nf, 1024), [&](const tbb::blocked_range<int>& r) {
    for (int j = r.begin(); j < r.end(); ++j) {
      double s[3] = {0, 0, 0};
      for (RowMatrix::InnerIterator e(L, j); e; ++e)
        for (int d = 0; d < 3; ++d) s[d] += e.value() * P(e.index(), d);
      for (int d = 0; d < 3; ++d) out(j, d) = s[d];
    }
  });
  return out;
}

Eigen::SparseMatrix<double, Eigen::RowMajor> ShellSolver::system_rows(const std::vector<int>& vertices) const {
  const Impl& m = *impl_;
  std::vector<Eigen::Triplet<double>> entries;
  for (std::size_t r = 0; r < vertices.size(); ++r) {
    const int v = vertices[r];
    if (v < 0 || v >= m.N || m.free_index[v] < 0) throw InputError("ShellSolver::system_rows: vertex is not free");
    for (RowMatrix::InnerIterator e(m.lff(), m.free_index[v]); e; ++e)
      entries.emplace_back(static_cast<int>(r), m.free_vertices[e.index()], e.value());
  }
  Eigen::SparseMatrix<double, Eigen::RowMajor> rows(static_cast<Eigen::Index>(vertices.size()), m.N);
  rows.setFromTriplets(entries.begin(), entries.end());
  return rows;
}

double ShellSolver::factor_seconds() const { return impl_->factor_seconds; }
LinearSolver ShellSolver::linear_solver() const { return impl_->path; }

std::string to_string(LinearSolver solver) {
  switch (solver) {
  case LinearSolver::Auto: return "auto";
  case LinearSolver::Direct: return "direct";
  case LinearSolver::ConjugateGradient: return "cg";
  }
  return "unknown";
}

LinearSolver parse_linear_solver(const std::string& name) {
  for (LinearSolver s : {LinearSolver::Auto, LinearSolver::Direct, LinearSolver::ConjugateGradient})
    if (name == to_string(s)) return s;
  throw InputError("unknown linear solver '" + name + "' (expected auto, direct or cg)");
}
const RestTets& ShellSolver::rest() const { return *impl_->rest; }
int ShellSolver::num_vertices() const { return impl_->N; }

namespace {

std::vector<double> to_row_major(const Eigen::MatrixXd& X) {
  std::vector<double> x(3 * static_cast<std::size_t>(X.rows()));
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(x.data(), X.rows(), 3) = X;
  return x;
}

void from_row_major(const std::vector<double>& x, Eigen::MatrixXd& X) {
  X = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(x.data(), X.rows(), 3);
}

} // namespace

double ShellSolver::energy(const Eigen::MatrixXd& X, const Eigen::MatrixXd& soft_targets) const {
  impl_->check_positions(X, "energy");
  const std::vector<double> x = to_row_major(X);
  return impl_->local_step(x.data(), nullptr) + impl_->soft_energy(x.data(), soft_targets);
}

void check_anderson_history(int history, const std::string& what) {
  if (history < 0 || history > kMaxAndersonHistory)
    throw InputError(what + " must be in [0, " + std::to_string(kMaxAndersonHistory) + "] (got " + std::to_string(history) +
                     ")");
}

void check_solve_limits(const SolveOptions& options, const std::string& caller) {
  if (options.max_iterations < 0) throw InputError(caller + ": negative iteration count");
  if (!(options.tolerance >= 0) || !std::isfinite(options.tolerance))
    throw InputError(caller + ": the tolerance must be a number >= 0 (got " + format_number(options.tolerance) + ")");
}

SolveResult ShellSolver::solve(Eigen::MatrixXd& Xio, const SolveOptions& options,
                               const Eigen::MatrixXd& soft_targets) const {
  const Impl& m = *impl_;
  const auto t0 = Clock::now();
  m.check_positions(Xio, "solve");
  m.check_soft_targets(soft_targets, "solve");
  check_solve_limits(options, "ShellSolver::solve");
  check_anderson_history(options.anderson_history, "ShellSolver::solve: the Anderson history");
  std::vector<double> X = to_row_major(Xio);
  const std::vector<double> rhs_const = m.rhs_constant(X.data(), soft_targets);
  // With the colouring the local step adds the rotations straight into b; otherwise they are
  // stored per tet (Q) and gathered. Q is not zeroed: the first local step writes every entry,
  // from all threads.
  const bool fused = !m.colour_chunk.empty();
  const std::unique_ptr<double[]> Q =
      fused ? nullptr : std::make_unique_for_overwrite<double[]>(9 * static_cast<std::size_t>(m.K));
  std::vector<double> rhs(3 * static_cast<std::size_t>(m.nf)), b;
  auto local_step = [&] { return m.local_step(X.data(), Q.get(), fused ? &b : nullptr); };
  auto global_step = [&] {
    if (!fused) return m.global_step(X.data(), Q.get(), rhs_const, rhs);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rhs.size(), 1 << 14), [&](const auto& r) {
      for (std::size_t i = r.begin(); i < r.end(); ++i) rhs[i] = b[i] + rhs_const[i];
    });
    return m.solve_free_rows(X.data(), rhs);
  };
  SolveResult result;
  // Energy of 1e-14 per unit rest volume (singular values within about 1e-7 of the ideal) is
  // converged whatever its relative change: a shell that starts optimal ran to the iteration
  // limit on rounding noise, and one whose minimum is exactly zero (a deform frame that returns
  // to the rest base) falls by a constant factor per iteration, which a relative test never stops.
  const double negligible_energy = 1e-14 * m.rest->volume.sum();
  auto t_local = Clock::now();
  double E = local_step() + m.soft_energy(X.data(), soft_targets);
  result.local_seconds += seconds_since(t_local);
  result.energy.push_back(E);
  // Anderson on the free rows (the kept ones never move): `before` holds them as the global step
  // starts (and then the combination), `image` as it ends while the combination is tried in X.
  detail::AndersonHistory<float> anderson(options.anderson_history);
  std::vector<double> before, image;
  const std::size_t free_values = 3 * static_cast<std::size_t>(m.nf);
  auto free_rows = [&](auto&& copy) { // copy(index in X, index in a free-row buffer)
    tbb::parallel_for(tbb::blocked_range<int>(0, m.nf, 1 << 12), [&](const auto& r) {
      for (int j = r.begin(); j < r.end(); ++j)
        for (int d = 0; d < 3; ++d) copy(3 * static_cast<std::size_t>(m.free_vertices[j]) + d, 3 * static_cast<std::size_t>(j) + d);
    });
  };
  auto gather_free = [&](std::vector<double>& out) { free_rows([&](std::size_t x, std::size_t f) { out[f] = X[x]; }); };
  auto scatter_free = [&](const std::vector<double>& in) { free_rows([&](std::size_t x, std::size_t f) { X[x] = in[f]; }); };
  if (options.anderson_history > 0)
    for (auto* v : {&before, &image}) detail::assign_populated(*v, free_values); // 63 MB each at sphere:9
  for (int it = 1; it <= options.max_iterations && m.nf > 0; ++it) {
    if (!before.empty()) gather_free(before);
    const auto t_global = Clock::now();
    result.linear_iterations += global_step();
    result.global_seconds += seconds_since(t_global);
    t_local = Clock::now();
    double E_new = 0;
    bool combined = false;
    if (!before.empty()) {
      gather_free(image);
      if (anderson.extrapolate(before.data(), image.data(), static_cast<Eigen::Index>(free_values), before.data())) {
        scatter_free(before);
        E_new = local_step() + m.soft_energy(X.data(), soft_targets);
        combined = E_new < E;
        if (!combined) {
          anderson.clear(); // fall back on the plain step, which cannot go up
          scatter_free(image);
        }
      }
    }
    if (!combined) E_new = local_step() + m.soft_energy(X.data(), soft_targets);
    result.local_seconds += seconds_since(t_local);
    result.energy.push_back(E_new);
    result.iterations = it;
    if (options.progress) options.progress(it, E_new, seconds_since(t0));
    const bool small_change = E <= negligible_energy || std::abs(E - E_new) < options.tolerance * E;
    E = E_new;
    if (small_change) {
      result.converged = true;
      break;
    }
  }
  from_row_major(X, Xio);
  result.seconds = seconds_since(t0);
  return result;
}

void ShellSolver::local_step(const Eigen::MatrixXd& X, LocalStep& step, const Eigen::MatrixXd& soft_targets) const {
  const Impl& m = *impl_;
  m.check_positions(X, "local_step");
  m.check_soft_targets(soft_targets, "local_step");
  const std::vector<double> x = to_row_major(X);
  step.Q.resize(9 * static_cast<std::size_t>(m.K));
  step.energy = m.local_step(x.data(), step.Q.data()) + m.soft_energy(x.data(), soft_targets);
}

void ShellSolver::global_step(Eigen::MatrixXd& X, const LocalStep& step, const Eigen::MatrixXd& soft_targets) const {
  const Impl& m = *impl_;
  m.check_positions(X, "global_step");
  m.check_soft_targets(soft_targets, "global_step");
  m.check_step(step, "global_step");
  if (m.nf == 0) return;
  std::vector<double> x = to_row_major(X);
  std::vector<double> rhs(3 * static_cast<std::size_t>(m.nf));
  m.global_step(x.data(), step.Q.data(), m.rhs_constant(x.data(), soft_targets), rhs);
  from_row_major(x, X);
}

Eigen::MatrixXd ShellSolver::half_gradient(const Eigen::MatrixXd& X, const LocalStep& step,
                                           const Eigen::MatrixXd& soft_targets) const {
  const Impl& m = *impl_;
  m.check_positions(X, "half_gradient");
  m.check_soft_targets(soft_targets, "half_gradient");
  m.check_step(step, "half_gradient");
  // 1/2 dE/dx_f = A_ff x_f - (b(R) + rhs_constant): what the global step solves, as a residual.
  const std::vector<double> x = to_row_major(X);
  const std::vector<double> rhs_const = m.rhs_constant(x.data(), soft_targets);
  m.ensure_gather();
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(m.N, 3);
  const auto& L = m.lff();
  tbb::parallel_for(0, m.nf, [&](int j) {
    double b[3];
    m.gather_rhs(j, step.Q.data(), b);
    for (int d = 0; d < 3; ++d) {
      double ax = 0;
      for (RowMatrix::InnerIterator e(L, j); e; ++e)
        ax += e.value() * x[3 * static_cast<std::size_t>(m.free_vertices[e.index()]) + d];
      g(m.free_vertices[j], d) = ax - b[d] - rhs_const[j + static_cast<std::size_t>(d) * m.nf];
    }
  });
  return g;
}

} // namespace gshell
