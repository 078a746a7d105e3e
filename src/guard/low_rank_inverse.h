#pragma once
// Exact solves with the guarded solver's model matrix A + H where the barriers act on a few
// vertices: A's factor plus a small dense system, no iterations.
#include <gshell/solver/shell_solver.h>

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

namespace gshell::detail {

/// Solves (A + H) x = b, A the ShellSolver's free system (prefactored; one matrix for the three
/// axes) and H symmetric positive semidefinite over the coordinates of a few free vertices S
/// (local index 3 k + axis for the k-th vertex of S). By the Woodbury identity, with y = A^-1 b,
/// G = (A^-1)_SS and E the injection of S,
///   x = y - A^-1 E H t,   (I + G H) t = y_S   (t is x on S),
/// and I + G H is invertible (similar to I + G^1/2 H G^1/2 >= I). A does not change, so G is kept
/// between calls: a vertex new to S costs one column of A^-1, a call one more solve with A's
/// factor, where CG preconditioned by A^-1 takes one per iteration (ten and more near stiff
/// contacts, each a pass over the whole factor).
class LowRankInverse {
public:
  /// Keeps G over at most `capacity` vertices (0: solve always declines).
  explicit LowRankInverse(int capacity = 0) : capacity_(capacity) {}

  /// x <- (A + H)^-1 b given y = A^-1 b (nf x 3); `vertices` S (free indices, distinct) and H
  /// (3|S| x 3|S|) as above. False, x untouched, when S has more than capacity vertices or the
  /// small system gives no finite solution.
  bool solve(const ShellSolver& A, const std::vector<int>& vertices, const Eigen::SparseMatrix<double>& H,
             const Eigen::MatrixXd& y, Eigen::MatrixXd& x);

  int capacity() const { return capacity_; }
  /// Columns of A^-1 solved for since construction (one per vertex new to the kept set).
  long columns_solved() const { return columns_solved_; }

private:
  // Makes every vertex of S own a slot of G, solving the columns of the new ones.
  void keep(const ShellSolver& A, const std::vector<int>& vertices);

  int capacity_ = 0;
  std::vector<int> slot_;   // free index -> its slot in G, or -1
  std::vector<int> vertex_; // slot -> free index, or -1 (empty)
  Eigen::MatrixXd G_;       // capacity x capacity: (A^-1)_ij between the slots' vertices
  long columns_solved_ = 0;
};

} // namespace gshell::detail
