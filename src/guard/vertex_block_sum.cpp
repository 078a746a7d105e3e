#include "guard/vertex_block_sum.h"

#include <bit>

namespace gshell::detail {
namespace {

std::uint64_t key(int a, int b) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) | static_cast<std::uint32_t>(b);
}
// Fibonacci hashing: the vertex ids of neighbouring pairs are close, the product spreads them.
std::uint64_t hash(std::uint64_t k) { return (k * 0x9E3779B97F4A7C15ull) >> 20; }

} // namespace

VertexBlockSum::VertexBlockSum(std::size_t expected_blocks) {
  sums_.reserve(expected_blocks);
  table_.assign(std::bit_ceil(std::max<std::size_t>(64, 2 * expected_blocks)), -1);
  mask_ = table_.size() - 1;
}

int VertexBlockSum::slot(int a, int b) {
  const std::uint64_t k = key(a, b);
  for (std::uint64_t h = hash(k) & mask_;; h = (h + 1) & mask_) {
    const int s = table_[h];
    if (s < 0) {
      if (2 * (sums_.size() + 1) > table_.size()) { // keep the table at most half full
        grow();
        return slot(a, b);
      }
      table_[h] = static_cast<int>(sums_.size());
      sums_.push_back({a, b});
      return table_[h];
    }
    if (key(sums_[s].a, sums_[s].b) == k) return s;
  }
}

void VertexBlockSum::grow() {
  table_.assign(2 * table_.size(), -1);
  mask_ = table_.size() - 1;
  for (std::size_t s = 0; s < sums_.size(); ++s) {
    std::uint64_t h = hash(key(sums_[s].a, sums_[s].b)) & mask_;
    while (table_[h] >= 0) h = (h + 1) & mask_;
    table_[h] = static_cast<int>(s);
  }
}

void VertexBlockSum::append_to(std::vector<Eigen::Triplet<double>>& triplets) const {
  for (const Sum& s : sums_)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (s.nonzero & (1u << (3 * i + j))) triplets.emplace_back(3 * s.a + i, 3 * s.b + j, s.value[3 * i + j]);
}

} // namespace gshell::detail
