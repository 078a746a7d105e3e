#pragma once
// Symmetric positive definite solves for the hierarchical solver: supernodal CHOLMOD for the
// full level when available, dense Cholesky for small reduced levels, Eigen's simplicial
// Cholesky otherwise.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <vector>

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
  /// `ordering` (optional, a permutation of 0..n-1): the fill-reducing ordering to use instead of
  /// choosing one (CHOLMOD: its analysis tries AMD, then METIS, which on a large system costs as
  /// much as the numeric factorisation; a caller factoring a slowly changing system can hand
  /// back an earlier `ordering()`). With `max_entries` > 0, a given ordering whose factor would
  /// have more entries than that is dropped for one chosen afresh. Returns whether the factor
  /// uses the given ordering.
  bool factor(const Eigen::SparseMatrix<double>& A, bool many_solves = true, const std::vector<int>* ordering = nullptr,
              double max_entries = 0);
  /// The fill-reducing permutation of the last sparse factor (row k of the factor is row
  /// ordering()[k] of A); empty for a dense factor or without CHOLMOD.
  std::vector<int> ordering() const;
  /// Entries of the last sparse factor (0 for a dense one or without CHOLMOD).
  double factor_entries() const;
  /// B <- A^-1 B, one column per right-hand side.
  void solve_in_place(Eigen::MatrixXd& B) const;
  int size() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

} // namespace gshell::detail
