#pragma once
// Sums a Hessian's 3 x 3 vertex blocks before they become triplets.
#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <cstdint>
#include <vector>

namespace gshell::detail {

/// The sum of many 3 x 3 blocks, each at a vertex pair (a, b) (rows 3a + i, columns 3b + j).
/// A barrier whose terms crowd around the same vertices (hundreds of contact pairs at every top
/// vertex of a thin strand) appends one triplet per summed entry instead of one per term: the
/// sparse matrix built from them is the same, bit for bit, when the terms are added in the order
/// their triplets would have been appended (an entry's sum is then formed in that order, from
/// its first nonzero term, as set_from_triplets forms it).
class VertexBlockSum {
public:
  /// `expected_blocks`: distinct vertex pairs expected (sizes the table; it grows as needed).
  explicit VertexBlockSum(std::size_t expected_blocks = 0);
  /// Adds scale * block(i, j) at (a, b) for the entries of `block` that are nonzero; an entry
  /// nothing nonzero was ever added to stays out of the triplets (as a zero term's triplet did).
  template <class Block> void add(int a, int b, const Block& block, double scale) {
    std::uint16_t nonzero = 0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (block(i, j) != 0) nonzero |= static_cast<std::uint16_t>(1u << (3 * i + j));
    if (!nonzero) return;
    Sum& s = sums_[slot(a, b)];
    s.nonzero |= nonzero;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (block(i, j) != 0) s.value[3 * i + j] += scale * block(i, j);
  }
  /// Appends the summed entries as triplets, vertex pairs in the order of their first nonzero
  /// block, each pair's entries row by row.
  void append_to(std::vector<Eigen::Triplet<double>>& triplets) const;
  std::size_t blocks() const { return sums_.size(); }

private:
  struct Sum {
    int a = 0, b = 0;
    std::uint16_t nonzero = 0; // one bit per entry, 3 i + j
    double value[9] = {};
  };
  int slot(int a, int b); // index into sums_, a new zero Sum the first time (a, b) is seen
  void grow();

  std::vector<Sum> sums_;
  std::vector<int> table_; // open addressing, linear probing: index into sums_, -1 empty
  std::uint64_t mask_ = 0;
};

} // namespace gshell::detail
