#include <gshell/geometry/weld_vertices.h>

#include <gshell/geometry/mesh_topology.h>

#include <algorithm>
#include <tuple>

namespace gshell {

namespace {

// Candidates within `tolerance` of each other, chained: a sweep along x over the sorted
// candidates (the tolerance is meant to be tiny, so each sweep is short), then union-find.
std::vector<std::pair<int, int>> nearby_vertices(const Eigen::MatrixXd& V, std::vector<int> candidates,
                                                 double tolerance) {
  std::sort(candidates.begin(), candidates.end(), [&](int a, int b) { return V(a, 0) < V(b, 0); });
  std::vector<int> root(candidates.size());
  for (std::size_t i = 0; i < root.size(); ++i) root[i] = static_cast<int>(i);
  const auto find = [&](int i) {
    while (root[i] != i) i = root[i] = root[root[i]];
    return i;
  };
  for (std::size_t i = 0; i < candidates.size(); ++i)
    for (std::size_t j = i + 1; j < candidates.size() && V(candidates[j], 0) - V(candidates[i], 0) <= tolerance; ++j)
      if ((V.row(candidates[i]) - V.row(candidates[j])).norm() <= tolerance)
        root[find(static_cast<int>(i))] = find(static_cast<int>(j));
  std::vector<int> lowest(candidates.size(), -1); // per set root: its lowest vertex id
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    int& l = lowest[find(static_cast<int>(i))];
    if (l < 0 || candidates[i] < l) l = candidates[i];
  }
  std::vector<std::pair<int, int>> pairs;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const int kept = lowest[find(static_cast<int>(i))];
    if (kept != candidates[i]) pairs.emplace_back(kept, candidates[i]);
  }
  std::sort(pairs.begin(), pairs.end(), [](const auto& p, const auto& q) { return p.second < q.second; });
  return pairs;
}

} // namespace

std::vector<std::pair<int, int>> coincident_vertices(const Eigen::MatrixXd& V, std::vector<int> candidates,
                                                     double tolerance) {
  if (tolerance > 0) return nearby_vertices(V, std::move(candidates), tolerance);
  const auto key = [&](int v) { return std::tuple(V(v, 0), V(v, 1), V(v, 2), v); };
  std::sort(candidates.begin(), candidates.end(), [&](int a, int b) { return key(a) < key(b); });
  std::vector<std::pair<int, int>> pairs;
  for (std::size_t i = 1, first = 0; i < candidates.size(); ++i) {
    const int a = candidates[first], b = candidates[i];
    if (V(a, 0) == V(b, 0) && V(a, 1) == V(b, 1) && V(a, 2) == V(b, 2))
      pairs.emplace_back(a, b);
    else
      first = i;
  }
  std::sort(pairs.begin(), pairs.end(), [](const auto& p, const auto& q) { return p.second < q.second; });
  return pairs;
}

TriMesh weld_boundary_vertices(const TriMesh& mesh, int* merged, std::vector<int>* ids, double tolerance,
                               const std::vector<char>& joinable) {
  const int n = mesh.num_vertices();
  const EdgeIncidence incidence = edge_incidence(mesh.F, n);
  std::vector<char> on_boundary(n, 0);
  for (int e = 0; e < incidence.num_edges(); ++e)
    if (incidence.valence(e) == 1) on_boundary[incidence.edges(e, 0)] = on_boundary[incidence.edges(e, 1)] = 1;
  std::vector<int> candidates;
  for (int v = 0; v < n; ++v)
    if (on_boundary[v] && (joinable.empty() || joinable[v])) candidates.push_back(v);
  std::vector<int> target(n);
  for (int v = 0; v < n; ++v) target[v] = v;
  const auto pairs = coincident_vertices(mesh.V, std::move(candidates), tolerance);
  for (const auto& [kept, gone] : pairs) target[gone] = kept;
  // New ids: the kept vertices in their order; a removed one takes its kept vertex's id (lower,
  // so already numbered).
  std::vector<int> id(n);
  int next = 0;
  for (int v = 0; v < n; ++v) id[v] = target[v] == v ? next++ : id[target[v]];
  TriMesh out;
  out.V.resize(next, 3);
  for (int v = 0; v < n; ++v)
    if (target[v] == v) out.V.row(id[v]) = mesh.V.row(v);
  out.F.resize(mesh.F.rows(), 3);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) out.F(f, k) = id[mesh.F(f, k)];
  out.UV = mesh.UV;
  out.FUV = mesh.FUV;
  if (merged) *merged = static_cast<int>(pairs.size());
  if (ids) *ids = std::move(id);
  return out;
}

} // namespace gshell
