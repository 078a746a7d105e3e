#pragma once
// Internal: items sorted into numbered groups by a counting sort (the tets or faces at each vertex,
// the vertices each triangle owns), stored as one offsets array and one item array.
#include <algorithm>
#include <vector>

namespace gshell::detail {

/// Group g holds item[start[g] .. start[g + 1]), in the order its memberships were listed.
struct ItemGroups {
  std::vector<int> start, item;

  /// The items of the given groups, sorted, each once.
  std::vector<int> items_of(const std::vector<int>& groups) const {
    std::vector<int> found;
    for (int g : groups) found.insert(found.end(), item.begin() + start[g], item.begin() + start[g + 1]);
    std::sort(found.begin(), found.end());
    found.erase(std::unique(found.begin(), found.end()), found.end());
    return found;
  }
};

/// Groups 0..num_groups-1 from memberships: list(add) must call add(group, item) for every
/// membership, with 0 <= group < num_groups, and make the same calls each time (it runs twice:
/// once to count, once to place).
template <class List> ItemGroups group_items(int num_groups, List&& list) {
  ItemGroups g;
  g.start.assign(num_groups + 1, 0);
  list([&](int group, int) { ++g.start[group + 1]; });
  for (int i = 0; i < num_groups; ++i) g.start[i + 1] += g.start[i];
  g.item.resize(g.start[num_groups]);
  std::vector<int> next(g.start.begin(), g.start.end() - 1);
  list([&](int group, int item) { g.item[next[group]++] = item; });
  return g;
}

} // namespace gshell::detail
