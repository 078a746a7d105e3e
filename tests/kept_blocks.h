#pragma once
// The barriers' Hessians restricted to kept vertices (their `kept_vertices` argument), as the
// tests of both barriers check them: the whole Hessian's triplets filtered, value for value and
// in their order.
#include <Eigen/SparseCore>
#include <algorithm>
#include <vector>

namespace gshell::test {

// Triplets whose row and column vertices (index / 3) are both flagged, in their order.
inline std::vector<Eigen::Triplet<double>> kept_blocks(const std::vector<Eigen::Triplet<double>>& all,
                                                       const std::vector<char>& kept) {
  std::vector<Eigen::Triplet<double>> out;
  for (const auto& t : all)
    if (kept[t.row() / 3] && kept[t.col() / 3]) out.push_back(t);
  return out;
}

inline bool same_triplets(const std::vector<Eigen::Triplet<double>>& a, const std::vector<Eigen::Triplet<double>>& b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](const auto& x, const auto& y) {
    return x.row() == y.row() && x.col() == y.col() && x.value() == y.value();
  });
}

} // namespace gshell::test
