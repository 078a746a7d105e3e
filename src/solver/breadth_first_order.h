#pragma once
// Internal: a row order of a sparse system in which each row's neighbours lie close to it in
// memory, for the solvers that walk rows neighbour by neighbour (conjugate gradients and the
// multigrid's sweeps; docs/scale.md "Row order").
#include <Eigen/SparseCore>
#include <vector>

namespace gshell::detail {

using RowMajorMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>;

/// The rows of a structurally symmetric square matrix in the order a breadth-first search over
/// its graph reaches them (Cuthill-McKee's order without its degree sort): each connected part
/// from its lowest row, parts in the order of those rows. order[new] = old.
std::vector<int> breadth_first_order(const RowMajorMatrix& A);

/// P A P^T for order[new] = old (row and column `new` of the result are row and column
/// order[new] of A), compressed, columns ascending in every row.
RowMajorMatrix permute_symmetric(const RowMajorMatrix& A, const std::vector<int>& order);

} // namespace gshell::detail
