#pragma once
// Symmetric positive definite solves for the hierarchical solver: supernodal CHOLMOD for the
// full level when available, dense Cholesky for small reduced levels, Eigen's simplicial
// Cholesky otherwise.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>

namespace gshell::detail {

class SpdSolver {
public:
  SpdSolver();
  ~SpdSolver();
  SpdSolver(SpdSolver&&) noexcept;
  SpdSolver& operator=(SpdSolver&&) noexcept;

  /// Factors A (lower triangle is enough). Throws std::runtime_error if A is not positive definite.
  void factor(const Eigen::SparseMatrix<double>& A);
  /// B <- A^-1 B, one column per right-hand side.
  void solve_in_place(Eigen::MatrixXd& B) const;
  int size() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace gshell::detail
