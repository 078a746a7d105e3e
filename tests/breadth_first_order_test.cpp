// The CG path's row order: a breadth-first renumbering of a sparse system and the symmetric
// permutation that applies it.
#include "solver/breadth_first_order.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cstdlib>
#include <numeric>
#include <random>
#include <vector>

using gshell::detail::breadth_first_order;
using gshell::detail::permute_symmetric;
using gshell::detail::RowMajorMatrix;

namespace {

// The 5-point Laplacian (shifted to be positive definite) of a k x k grid whose points carry the
// ids label[i + k j]; entries distinct so that a misplaced one shows.
RowMajorMatrix grid_matrix(int k, const std::vector<int>& label) {
  std::vector<Eigen::Triplet<double>> entries;
  auto id = [&](int i, int j) { return label[i + k * j]; };
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      entries.emplace_back(id(i, j), id(i, j), 5.0 + 0.001 * id(i, j));
      if (i + 1 < k) {
        const double w = -1.0 - 0.0001 * (id(i, j) + id(i + 1, j));
        entries.emplace_back(id(i, j), id(i + 1, j), w);
        entries.emplace_back(id(i + 1, j), id(i, j), w);
      }
      if (j + 1 < k) {
        const double w = -1.0 - 0.0001 * (id(i, j) + id(i, j + 1));
        entries.emplace_back(id(i, j), id(i, j + 1), w);
        entries.emplace_back(id(i, j + 1), id(i, j), w);
      }
    }
  RowMajorMatrix A(k * k, k * k);
  A.setFromTriplets(entries.begin(), entries.end());
  A.makeCompressed();
  return A;
}

// 0..n-1 in a random order.
std::vector<int> shuffled(int n, unsigned seed) {
  std::vector<int> label(n);
  std::iota(label.begin(), label.end(), 0);
  std::shuffle(label.begin(), label.end(), std::mt19937(seed));
  return label;
}

int bandwidth(const RowMajorMatrix& A) {
  int b = 0;
  for (int r = 0; r < A.outerSize(); ++r)
    for (RowMajorMatrix::InnerIterator it(A, r); it; ++it) b = std::max(b, std::abs(r - static_cast<int>(it.index())));
  return b;
}

} // namespace

TEST(BreadthFirstOrder, BringsAShuffledGridsNeighboursTogether) {
  // A 40 x 40 grid numbered at random: neighbours lie anywhere (bandwidth near n). In breadth-first
  // order a row's neighbours are in its own or an adjacent level set of the search, and a grid's
  // level sets hold at most 2k points, so no neighbour is more than 4k rows away.
  const int k = 40, n = k * k;
  const RowMajorMatrix A = grid_matrix(k, shuffled(n, 3));
  ASSERT_GT(bandwidth(A), n / 2);

  const std::vector<int> order = breadth_first_order(A);
  std::vector<int> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  std::vector<int> all(n);
  std::iota(all.begin(), all.end(), 0);
  EXPECT_EQ(sorted, all) << "not a permutation";
  EXPECT_EQ(order[0], 0) << "the search starts at the lowest row";
  EXPECT_LE(bandwidth(permute_symmetric(A, order)), 4 * k);
  EXPECT_EQ(breadth_first_order(A), order) << "not deterministic";
}

TEST(BreadthFirstOrder, PermutesSymmetricallyEntryByEntry) {
  // Row and column `new` of P A P^T are row and column order[new] of A, every entry in place,
  // columns ascending; two separate grids (two connected parts) are both ordered.
  const int k = 12, n = k * k;
  const RowMajorMatrix one = grid_matrix(k, shuffled(n, 5));
  std::vector<Eigen::Triplet<double>> entries;
  for (int r = 0; r < n; ++r)
    for (RowMajorMatrix::InnerIterator it(one, r); it; ++it) {
      entries.emplace_back(2 * r, 2 * static_cast<int>(it.index()), it.value()); // interleaved ids
      entries.emplace_back(2 * r + 1, 2 * static_cast<int>(it.index()) + 1, 2 * it.value());
    }
  RowMajorMatrix A(2 * n, 2 * n);
  A.setFromTriplets(entries.begin(), entries.end());
  A.makeCompressed();

  const std::vector<int> order = breadth_first_order(A);
  ASSERT_EQ(static_cast<int>(order.size()), 2 * n);
  const RowMajorMatrix B = permute_symmetric(A, order);
  ASSERT_EQ(B.nonZeros(), A.nonZeros());
  const Eigen::MatrixXd a = Eigen::MatrixXd(A), b = Eigen::MatrixXd(B);
  for (int r = 0; r < 2 * n; ++r)
    for (int c = 0; c < 2 * n; ++c) ASSERT_EQ(b(r, c), a(order[r], order[c])) << r << ", " << c;
  for (int r = 0; r < 2 * n; ++r)
    EXPECT_TRUE(std::is_sorted(B.innerIndexPtr() + B.outerIndexPtr()[r], B.innerIndexPtr() + B.outerIndexPtr()[r + 1]));
  // The first part is searched completely before the second begins.
  const auto second = std::find_if(order.begin(), order.end(), [](int r) { return r % 2 == 1; });
  EXPECT_TRUE(std::all_of(second, order.end(), [](int r) { return r % 2 == 1; }));
}
