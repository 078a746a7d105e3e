#pragma once
// Internal: union-find over 0..n-1 (mesh components, boundary loops, vertex fans, the parts of a
// shell that handles must anchor).
#include <algorithm>
#include <numeric>
#include <vector>

namespace gshell::detail {

/// Union-find with path halving over 0..n-1.
class DisjointSets {
public:
  explicit DisjointSets(int n = 0) { reset(n); }
  void reset(int n) {
    parent_.resize(n);
    std::iota(parent_.begin(), parent_.end(), 0);
  }
  int find(int x) {
    while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
    return x;
  }
  /// True if a and b were in different sets.
  bool unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a == b) return false;
    parent_[std::max(a, b)] = std::min(a, b);
    return true;
  }

private:
  std::vector<int> parent_;
};

} // namespace gshell::detail
