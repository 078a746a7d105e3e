#include <gshell/geometry/mesh_topology.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

namespace gshell {
namespace {

/// Union-find with path halving; enough for the linear-size graphs here.
class DisjointSets {
public:
  explicit DisjointSets(int n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0); }
  int find(int x) {
    while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
    return x;
  }
  void unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

private:
  std::vector<int> parent_;
};

bool face_usable(const Eigen::MatrixXi& F, int f, int num_vertices) {
  for (int k = 0; k < 3; ++k)
    if (F(f, k) < 0 || F(f, k) >= num_vertices) return false;
  return F(f, 0) != F(f, 1) && F(f, 1) != F(f, 2) && F(f, 2) != F(f, 0);
}

} // namespace

EdgeIncidence edge_incidence(const Eigen::MatrixXi& F, int num_vertices) {
  EdgeIncidence out;
  const int m = F.cols() == 3 ? static_cast<int>(F.rows()) : 0;
  out.face_used.assign(F.rows(), 0);
  // Bucket half-edges by their smaller endpoint (counting sort), then sort each small bucket by
  // the larger endpoint: linear time, no hashing.
  std::vector<int> bucket_start(num_vertices + 1, 0);
  for (int f = 0; f < m; ++f) {
    if (!face_usable(F, f, num_vertices)) continue;
    out.face_used[f] = 1;
    for (int k = 0; k < 3; ++k) ++bucket_start[std::min(F(f, k), F(f, (k + 1) % 3)) + 1];
  }
  std::partial_sum(bucket_start.begin(), bucket_start.end(), bucket_start.begin());
  std::vector<std::pair<int, int>> bucket(bucket_start.back()); // (larger endpoint, half-edge)
  {
    std::vector<int> fill(bucket_start.begin(), bucket_start.end() - 1);
    for (int f = 0; f < m; ++f) {
      if (!out.face_used[f]) continue;
      for (int k = 0; k < 3; ++k) {
        const int a = F(f, k), b = F(f, (k + 1) % 3);
        bucket[fill[std::min(a, b)]++] = {std::max(a, b), 3 * f + k};
      }
    }
  }
  std::vector<int> group_of(3 * static_cast<size_t>(m), -1);
  int groups = 0;
  for (int v = 0; v < num_vertices; ++v) {
    const auto begin = bucket.begin() + bucket_start[v], end = bucket.begin() + bucket_start[v + 1];
    std::sort(begin, end);
    for (auto it = begin; it != end; ++it) {
      if (it != begin && it->first != (it - 1)->first) ++groups;
      group_of[it->second] = groups;
    }
    if (begin != end) ++groups;
  }
  // Renumber edges by first appearance and lay out their half-edges in ascending order.
  std::vector<int> edge_of_group(groups, -1), size(groups, 0);
  int edges = 0;
  for (size_t h = 0; h < group_of.size(); ++h) {
    if (group_of[h] < 0) continue;
    int& e = edge_of_group[group_of[h]];
    if (e < 0) e = edges++;
    ++size[e];
  }
  out.edges.resize(edges, 2);
  out.offsets.assign(edges + 1, 0);
  for (int e = 0; e < edges; ++e) out.offsets[e + 1] = out.offsets[e] + size[e];
  out.halfedges.resize(out.offsets.back());
  std::vector<int> fill(out.offsets.begin(), out.offsets.end() - 1);
  for (size_t h = 0; h < group_of.size(); ++h) {
    if (group_of[h] < 0) continue;
    const int e = edge_of_group[group_of[h]];
    if (fill[e] == out.offsets[e]) {
      const int f = static_cast<int>(h / 3), k = static_cast<int>(h % 3);
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      out.edges(e, 0) = std::min(a, b);
      out.edges(e, 1) = std::max(a, b);
    }
    out.halfedges[fill[e]++] = static_cast<int>(h);
  }
  return out;
}

Eigen::MatrixXi unique_edges(const Eigen::MatrixXi& F) {
  const int n = F.size() > 0 ? F.maxCoeff() + 1 : 0;
  return edge_incidence(F, n).edges;
}

int count_boundary_loops(const EdgeIncidence& incidence, int num_vertices) {
  DisjointSets sets(num_vertices);
  std::vector<char> on_boundary(num_vertices, 0);
  for (int e = 0; e < incidence.num_edges(); ++e) {
    if (incidence.valence(e) != 1) continue;
    const int a = incidence.edges(e, 0), b = incidence.edges(e, 1);
    sets.unite(a, b);
    on_boundary[a] = on_boundary[b] = 1;
  }
  int loops = 0;
  for (int v = 0; v < num_vertices; ++v)
    if (on_boundary[v] && sets.find(v) == v) ++loops;
  return loops;
}

MeshStats mesh_stats(const TriMesh& mesh) {
  MeshStats s;
  const int n = mesh.V.cols() == 3 ? mesh.num_vertices() : 0;
  s.vertices = mesh.num_vertices();
  s.faces = mesh.num_faces();
  const EdgeIncidence inc = edge_incidence(mesh.F, n);
  s.edges = inc.num_edges();

  std::vector<char> referenced(n, 0);
  int used_faces = 0;
  for (int f = 0; f < static_cast<int>(inc.face_used.size()); ++f) {
    if (!inc.face_used[f]) continue;
    ++used_faces;
    for (int k = 0; k < 3; ++k) referenced[mesh.F(f, k)] = 1;
  }
  const int used_vertices = static_cast<int>(std::count(referenced.begin(), referenced.end(), 1));
  s.unreferenced_vertices = n - used_vertices;

  DisjointSets sets(n);
  double length_sum = 0;
  for (int e = 0; e < s.edges; ++e) {
    const int a = inc.edges(e, 0), b = inc.edges(e, 1);
    sets.unite(a, b);
    length_sum += (mesh.V.row(a) - mesh.V.row(b)).norm();
    if (inc.valence(e) == 1) ++s.boundary_edges;
  }
  for (int v = 0; v < n; ++v)
    if (referenced[v] && sets.find(v) == v) ++s.components;
  s.mean_edge_length = s.edges > 0 ? length_sum / s.edges : 0.0;
  s.boundary_loops = count_boundary_loops(inc, n);
  s.euler_characteristic = used_vertices - s.edges + used_faces;
  s.genus = (2.0 * s.components - s.boundary_loops - s.euler_characteristic) / 2.0;

  bool any = false;
  for (int v = 0; v < n; ++v) {
    const Eigen::Vector3d p = mesh.V.row(v).transpose();
    if (!p.allFinite()) continue;
    s.bbox_min = any ? s.bbox_min.cwiseMin(p) : p;
    s.bbox_max = any ? s.bbox_max.cwiseMax(p) : p;
    any = true;
  }
  return s;
}

} // namespace gshell
