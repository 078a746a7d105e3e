#include "hierarchy_linear.h"

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>
#ifdef GSHELL_HAVE_CHOLMOD
#include <Eigen/CholmodSupport>
#endif

#include <stdexcept>

namespace gshell::detail {

namespace {
// Below this size a dense factor beats sparse bookkeeping (a reduced level of <= 64 clusters).
constexpr int kDenseLimit = 256;
// Above this size the supernodal factor pays off.
constexpr int kSupernodalLimit = 4000;
} // namespace

struct SpdSolver::Impl {
  int n = 0;
  Eigen::LLT<Eigen::MatrixXd> dense;
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> simplicial;
#ifdef GSHELL_HAVE_CHOLMOD
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>> supernodal;
#endif
  enum class Kind { Dense, Simplicial, Supernodal } kind = Kind::Dense;
};

SpdSolver::SpdSolver() : impl_(std::make_unique<Impl>()) {}
SpdSolver::~SpdSolver() = default;
SpdSolver::SpdSolver(SpdSolver&&) noexcept = default;
SpdSolver& SpdSolver::operator=(SpdSolver&&) noexcept = default;

int SpdSolver::size() const { return impl_->n; }

void SpdSolver::factor(const Eigen::SparseMatrix<double>& A) {
  Impl& s = *impl_;
  s.n = static_cast<int>(A.rows());
  if (s.n <= kDenseLimit) {
    s.kind = Impl::Kind::Dense;
    const Eigen::MatrixXd D = Eigen::MatrixXd(A);
    s.dense.compute(D);
    if (s.dense.info() != Eigen::Success) throw std::runtime_error("reduced matrix is not positive definite");
    return;
  }
#ifdef GSHELL_HAVE_CHOLMOD
  if (s.n > kSupernodalLimit) {
    s.kind = Impl::Kind::Supernodal;
    s.supernodal.compute(A);
    if (s.supernodal.info() != Eigen::Success) throw std::runtime_error("system matrix is not positive definite");
    return;
  }
#endif
  s.kind = Impl::Kind::Simplicial;
  s.simplicial.compute(A);
  if (s.simplicial.info() != Eigen::Success) throw std::runtime_error("system matrix is not positive definite");
}

void SpdSolver::solve_in_place(Eigen::MatrixXd& B) const {
  const Impl& s = *impl_;
  switch (s.kind) {
  case Impl::Kind::Dense: s.dense.solveInPlace(B); return;
  case Impl::Kind::Simplicial: B = s.simplicial.solve(B); return;
  case Impl::Kind::Supernodal:
#ifdef GSHELL_HAVE_CHOLMOD
    B = s.supernodal.solve(B);
#endif
    return;
  }
}

} // namespace gshell::detail
