#include "hierarchy_linear.h"

#include "blas_threads.h"

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>
#ifdef GSHELL_HAVE_CHOLMOD
#include <cholmod.h>
#endif

#include <mutex>
#include <stdexcept>
#include <string>

namespace gshell::detail {

namespace {
// Below this size a dense factor beats sparse bookkeeping (a reduced level of <= 64 clusters).
constexpr int kDenseLimit = 256;
} // namespace

struct SpdSolver::Impl {
  int n = 0;
  enum class Kind { Dense, Sparse } kind = Kind::Dense;
  Eigen::LLT<Eigen::MatrixXd> dense;
#ifdef GSHELL_HAVE_CHOLMOD
  cholmod_common cm;
  cholmod_factor* factor = nullptr;
  std::mutex mutex; // CHOLMOD's workspace is shared: one solve at a time
  // Solution and workspaces of cholmod_solve2, kept between solves (reallocating them costs more
  // than a small level's solve).
  cholmod_dense *x = nullptr, *y = nullptr, *e = nullptr;
  Impl() {
    cholmod_start(&cm);
    cm.print = 0;
    cm.error_handler = nullptr;
    cm.supernodal = CHOLMOD_AUTO;
  }
  ~Impl() {
    cholmod_free_dense(&x, &cm);
    cholmod_free_dense(&y, &cm);
    cholmod_free_dense(&e, &cm);
    if (factor) cholmod_free_factor(&factor, &cm);
    cholmod_finish(&cm);
  }
#else
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> sparse;
#endif
};

SpdSolver::SpdSolver() : impl_(std::make_unique<Impl>()) {}
SpdSolver::~SpdSolver() = default;
SpdSolver::SpdSolver(SpdSolver&&) noexcept = default;
SpdSolver& SpdSolver::operator=(SpdSolver&&) noexcept = default;

int SpdSolver::size() const { return impl_->n; }

bool SpdSolver::factor(const Eigen::SparseMatrix<double>& A, bool many_solves, const std::vector<int>* ordering,
                       double max_entries) {
  Impl& s = *impl_;
  s.n = static_cast<int>(A.rows());
  if (s.n <= kDenseLimit) {
    s.kind = Impl::Kind::Dense;
    s.dense.compute(Eigen::MatrixXd(A).selfadjointView<Eigen::Lower>());
    if (s.dense.info() != Eigen::Success) throw std::runtime_error("reduced matrix is not positive definite");
    return false;
  }
  s.kind = Impl::Kind::Sparse;
#ifdef GSHELL_HAVE_CHOLMOD
  Eigen::SparseMatrix<double> lower = A.triangularView<Eigen::Lower>();
  lower.makeCompressed();
  cholmod_sparse M;
  M.nrow = M.ncol = static_cast<size_t>(s.n);
  M.nzmax = static_cast<size_t>(lower.nonZeros());
  M.p = lower.outerIndexPtr();
  M.i = lower.innerIndexPtr();
  M.nz = nullptr;
  M.x = lower.valuePtr();
  M.z = nullptr;
  M.stype = -1; // lower triangle stored
  M.itype = CHOLMOD_INT;
  M.xtype = CHOLMOD_REAL;
  M.dtype = CHOLMOD_DOUBLE;
  M.sorted = 1;
  M.packed = 1;
  if (s.factor) cholmod_free_factor(&s.factor, &s.cm);
  bool given_kept = false;
  if (ordering) {
    if (static_cast<int>(ordering->size()) != s.n) throw std::invalid_argument("SpdSolver: ordering of the wrong size");
    std::vector<int> given = *ordering; // cholmod_analyze_p takes a non-const pointer
    s.cm.nmethods = 1;
    s.cm.method[0].ordering = CHOLMOD_GIVEN;
    s.factor = cholmod_analyze_p(&M, given.data(), nullptr, 0, &s.cm);
    s.cm.nmethods = 0; // back to CHOLMOD's own choice (AMD, then METIS) for every other analysis
    // The symbolic analysis already knows the fill: an ordering that fills far more than
    // `max_entries` is dropped before the numeric work it would cost.
    if (s.factor && max_entries > 0 && s.cm.lnz > max_entries) {
      cholmod_free_factor(&s.factor, &s.cm);
      s.factor = cholmod_analyze(&M, &s.cm);
    } else {
      given_kept = s.factor != nullptr;
    }
  } else {
    s.factor = cholmod_analyze(&M, &s.cm);
  }
  if (!s.factor) throw std::runtime_error("CHOLMOD analysis failed (status " + std::to_string(s.cm.status) + ")");
  if (!cholmod_factorize_small_serially(&M, s.factor, &s.cm) || s.cm.status == CHOLMOD_NOT_POSDEF ||
      s.factor->minor < s.factor->n)
    throw std::runtime_error("system matrix is not positive definite");
  // A simplicial LL^T solves three right-hand sides faster than the supernodal form (no BLAS
  // call per supernode): convert once.
  if (many_solves && !cholmod_change_factor(CHOLMOD_REAL, 1, 0, 1, 1, s.factor, &s.cm))
    throw std::runtime_error("CHOLMOD factor conversion failed");
  return given_kept;
#else
  s.sparse.compute(A);
  if (s.sparse.info() != Eigen::Success) throw std::runtime_error("system matrix is not positive definite");
  return false;
#endif
}

std::vector<int> SpdSolver::ordering() const {
#ifdef GSHELL_HAVE_CHOLMOD
  const Impl& s = *impl_;
  if (s.kind == Impl::Kind::Sparse && s.factor && s.factor->Perm) {
    const int* perm = static_cast<const int*>(s.factor->Perm);
    return std::vector<int>(perm, perm + s.n);
  }
#endif
  return {};
}

double SpdSolver::factor_entries() const {
#ifdef GSHELL_HAVE_CHOLMOD
  const Impl& s = *impl_;
  if (s.kind == Impl::Kind::Sparse && s.factor) return s.cm.lnz;
#endif
  return 0;
}

void SpdSolver::solve_in_place(Eigen::MatrixXd& B) const {
  Impl& s = *impl_;
  if (s.kind == Impl::Kind::Dense) {
    s.dense.solveInPlace(B);
    return;
  }
#ifdef GSHELL_HAVE_CHOLMOD
  std::lock_guard<std::mutex> lock(s.mutex);
  cholmod_dense rhs;
  rhs.nrow = static_cast<size_t>(B.rows());
  rhs.ncol = static_cast<size_t>(B.cols());
  rhs.nzmax = rhs.nrow * rhs.ncol;
  rhs.d = rhs.nrow;
  rhs.x = B.data();
  rhs.z = nullptr;
  rhs.xtype = CHOLMOD_REAL;
  rhs.dtype = CHOLMOD_DOUBLE;
  if (!cholmod_solve2(CHOLMOD_A, s.factor, &rhs, nullptr, &s.x, nullptr, &s.y, &s.e, &s.cm) || !s.x)
    throw std::runtime_error("CHOLMOD solve failed");
  std::copy(static_cast<const double*>(s.x->x), static_cast<const double*>(s.x->x) + B.size(), B.data());
#else
  B = s.sparse.solve(B);
#endif
}

} // namespace gshell::detail
