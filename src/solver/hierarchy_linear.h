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
  /// `many_solves`: a supernodal factor is converted to simplicial form, which solves a few
  /// right-hand sides at a time faster when that is done over and over; false keeps it
  /// supernodal (one solve of a large system: no copy of the factor).
  void factor(const Eigen::SparseMatrix<double>& A, bool many_solves = true);
  /// B <- A^-1 B, one column per right-hand side.
  void solve_in_place(Eigen::MatrixXd& B) const;
  int size() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace gshell::detail
