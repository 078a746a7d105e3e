#include "guard/reused_ordering.h"

#include "solver/hierarchy_linear.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <utility>

namespace gshell::detail {

namespace {
// The remembered ordering is used while at most this fraction of the region's vertices are new
// to it...
constexpr double kMaxNewVertices = 0.05;
// ...and while the factor it gives has at most this many times the entries of the fresh one.
constexpr double kMaxFillGrowth = 1.25;
} // namespace

void ReusedOrdering::clear() {
  rank_.clear();
  remembered_ = 0;
  fresh_entries_ = 0;
}

// dofs: the ordering of A's rows, each (vertex, axis) where it was remembered. A row new to the
// ordering goes just before its earliest neighbour (its elimination then joins only its own
// neighbours, as in a minimum-degree ordering), rows whose neighbours are new as well before
// theirs, and rows not connected to any remembered one last (where they add no fill to the
// rest); placed last instead, a few thousand scattered new vertices made a dense block and one
// factorisation took five minutes. False when there is nothing remembered or too many vertices
// are new.
bool ReusedOrdering::order(const Eigen::SparseMatrix<double>& A, const std::vector<int>& vertices,
                           std::vector<int>& dofs) const {
  if (remembered_ == 0) return false;
  const std::size_t n = vertices.size();
  constexpr double kUnplaced = std::numeric_limits<double>::infinity();
  std::vector<double> key(3 * n, kUnplaced);
  std::vector<Eigen::Index> fresh_rows;
  for (std::size_t k = 0; k < n; ++k) {
    const int v = vertices[k];
    const bool known = v >= 0 && v < static_cast<int>(rank_.size() / 3) && rank_[3 * v] >= 0;
    if (!known) {
      if (static_cast<double>(fresh_rows.size() / 3 + 1) > kMaxNewVertices * static_cast<double>(n)) return false;
      for (int d = 0; d < 3; ++d) fresh_rows.push_back(static_cast<Eigen::Index>(3 * k + d));
    } else {
      for (int d = 0; d < 3; ++d) key[3 * k + d] = rank_[3 * v + d];
    }
  }
  // New rows take their keys ring by ring out from the remembered ones (a few passes; what is
  // left unconnected stays last).
  for (int pass = 0; pass < 8 && !fresh_rows.empty(); ++pass) {
    std::vector<std::pair<Eigen::Index, double>> placed;
    std::vector<Eigen::Index> still;
    for (Eigen::Index row : fresh_rows) {
      double first = kUnplaced;
      for (Eigen::SparseMatrix<double>::InnerIterator it(A, row); it; ++it) first = std::min(first, key[it.row()]);
      if (first < kUnplaced) placed.emplace_back(row, first - 0.5);
      else still.push_back(row);
    }
    if (placed.empty()) break;
    for (const auto& [row, k] : placed) key[row] = k;
    fresh_rows = std::move(still);
  }
  dofs.resize(3 * n);
  std::iota(dofs.begin(), dofs.end(), 0);
  std::stable_sort(dofs.begin(), dofs.end(), [&](int a, int b) { return key[a] < key[b]; });
  return true;
}

bool ReusedOrdering::factor(SpdSolver& solver, const Eigen::SparseMatrix<double>& A, const std::vector<int>& vertices,
                            int num_ids) {
  std::vector<int> dofs;
  const bool given = order(A, vertices, dofs);
  if (solver.factor(A, /*many_solves=*/false, given ? &dofs : nullptr, kMaxFillGrowth * fresh_entries_)) return true;
  clear();
  const std::vector<int> perm = solver.ordering();
  if (perm.empty()) return false;
  rank_.assign(3 * static_cast<std::size_t>(num_ids), -1);
  for (std::size_t k = 0; k < perm.size(); ++k) rank_[3 * vertices[perm[k] / 3] + perm[k] % 3] = static_cast<int>(k);
  remembered_ = vertices.size();
  fresh_entries_ = solver.factor_entries();
  return false;
}

} // namespace gshell::detail
