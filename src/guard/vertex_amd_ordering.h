#pragma once
// A fill-reducing ordering of a system in 3 x 3 vertex blocks, found on the vertex graph.
//
// The guarded solver's local systems have one row per vertex and axis (rows 3k..3k+2: vertex k),
// and the barriers couple the axes of every vertex they touch. Eigen's AMD on the scalar pattern
// spends most of a repair's analysis on a graph with 9 entries per vertex pair; the same
// approximate minimum degree on the vertex graph (one entry per pair) costs a ninth of that, and
// eliminating each vertex's three rows together is what the coupled blocks call for anyway.
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>

#include <algorithm>
#include <vector>

namespace gshell::detail {

/// An ordering functor for Eigen's simplicial factorisations (the OrderingType of
/// Eigen::SimplicialLDLT): AMD on the pattern of 3 x 3 blocks, each vertex's rows kept together in
/// axis order. Precondition: the matrix is 3k x 3k with a symmetric pattern (Eigen hands the
/// ordering the full self-adjoint matrix).
template <typename StorageIndex>
struct VertexAmdOrdering {
  using PermutationType = Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, StorageIndex>;

  template <typename MatrixType>
  void operator()(const MatrixType& A, PermutationType& perm) {
    const Eigen::Index n = A.cols() / 3;
    // The block pattern, column by column: each vertex's rows give one entry per neighbouring
    // vertex (its three columns share their pattern but for the barriers' coupling, so all three
    // are read).
    std::vector<StorageIndex> outer(n + 1, 0), inner;
    std::vector<StorageIndex> rows;
    for (Eigen::Index j = 0; j < n; ++j) {
      rows.clear();
      for (int d = 0; d < 3; ++d)
        for (typename MatrixType::InnerIterator it(A, 3 * j + d); it; ++it)
          rows.push_back(static_cast<StorageIndex>(it.row() / 3));
      std::sort(rows.begin(), rows.end());
      rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
      inner.insert(inner.end(), rows.begin(), rows.end());
      outer[j + 1] = static_cast<StorageIndex>(inner.size());
    }
    Eigen::SparseMatrix<double, Eigen::ColMajor, StorageIndex> blocks(n, n);
    blocks.resizeNonZeros(static_cast<Eigen::Index>(inner.size()));
    std::copy(outer.begin(), outer.end(), blocks.outerIndexPtr());
    std::copy(inner.begin(), inner.end(), blocks.innerIndexPtr());
    std::fill(blocks.valuePtr(), blocks.valuePtr() + inner.size(), 1.0);
    PermutationType vertex_perm;
    Eigen::internal::minimum_degree_ordering(blocks, vertex_perm);
    perm.resize(3 * n);
    for (Eigen::Index k = 0; k < n; ++k)
      for (int d = 0; d < 3; ++d) perm.indices()(3 * k + d) = static_cast<StorageIndex>(3 * vertex_perm.indices()(k) + d);
  }
};

} // namespace gshell::detail
