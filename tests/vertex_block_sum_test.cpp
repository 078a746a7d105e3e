// Summing a Hessian's vertex blocks before they become triplets: the same sparse matrix, bit for
// bit, as the terms' own triplets, from one triplet per entry.
#include "guard/vertex_block_sum.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <utility>

namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

Eigen::SparseMatrix<double> matrix(const Triplets& t, int n) {
  Eigen::SparseMatrix<double> m(3 * n, 3 * n);
  m.setFromTriplets(t.begin(), t.end());
  return m;
}

TEST(VertexBlockSum, GivesTheMatrixOfTheTermsTripletsBitForBitFromOneTripletPerEntry) {
  // Random 3 x 3 terms (values of very different magnitude, so that the order of the sums shows;
  // some entries and some whole blocks zero) on the vertex pairs of a few "pairs" of 4 vertices
  // among 12, many terms per vertex pair. More terms than the table's first size: it grows.
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> vertex(0, 11), coin(0, 3);
  std::uniform_real_distribution<double> value(-1, 1), exponent(-12, 12);
  const double scale = 0.37;
  Triplets raw, extra;
  gshell::detail::VertexBlockSum sum(4);
  for (int term = 0; term < 3000; ++term) {
    const int a = vertex(rng), b = vertex(rng);
    Eigen::Matrix3d block;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) block(i, j) = coin(rng) == 0 ? 0.0 : value(rng) * std::pow(10.0, exponent(rng));
    if (term % 10 == 0) block.setZero();
    sum.add(a, b, block, scale);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (block(i, j) != 0) raw.emplace_back(3 * a + i, 3 * b + j, scale * block(i, j));
  }
  Triplets summed;
  sum.append_to(summed);

  // One triplet per entry that received a nonzero term, none for the others.
  std::map<std::pair<int, int>, int> count;
  for (const auto& t : summed) ++count[{t.row(), t.col()}];
  std::map<std::pair<int, int>, int> raw_count;
  for (const auto& t : raw) ++raw_count[{t.row(), t.col()}];
  EXPECT_EQ(count.size(), raw_count.size());
  for (const auto& [entry, c] : count) {
    EXPECT_EQ(c, 1);
    EXPECT_TRUE(raw_count.count(entry));
  }
  EXPECT_LT(summed.size(), raw.size() / 2);

  // The same matrix bit for bit, also with other terms after them (a second barrier's triplets).
  for (int k = 0; k < 500; ++k) extra.emplace_back(vertex(rng) * 3 + coin(rng) % 3, vertex(rng) * 3 + coin(rng) % 3, value(rng));
  for (const Triplets* after : std::vector<const Triplets*>{nullptr, &extra}) {
    Triplets a = raw, b = summed;
    if (after) {
      a.insert(a.end(), after->begin(), after->end());
      b.insert(b.end(), after->begin(), after->end());
    }
    const Eigen::SparseMatrix<double> ma = matrix(a, 12), mb = matrix(b, 12);
    ASSERT_EQ(ma.nonZeros(), mb.nonZeros());
    for (int k = 0; k < ma.outerSize(); ++k) {
      Eigen::SparseMatrix<double>::InnerIterator ia(ma, k), ib(mb, k);
      for (; ia && ib; ++ia, ++ib) {
        EXPECT_EQ(ia.row(), ib.row());
        EXPECT_EQ(ia.value(), ib.value()) << ia.row() << " " << ia.col(); // exact: the same sums
      }
    }
  }

  // Vertex pairs in the order of their first nonzero block.
  std::vector<std::pair<int, int>> first_seen;
  for (const auto& t : raw) {
    const std::pair<int, int> p{t.row() / 3, t.col() / 3};
    if (std::find(first_seen.begin(), first_seen.end(), p) == first_seen.end()) first_seen.push_back(p);
  }
  std::vector<std::pair<int, int>> order;
  for (const auto& t : summed)
    if (order.empty() || order.back() != std::pair<int, int>{t.row() / 3, t.col() / 3}) order.push_back({t.row() / 3, t.col() / 3});
  EXPECT_EQ(order, first_seen);
  EXPECT_EQ(sum.blocks(), first_seen.size());
}

} // namespace
