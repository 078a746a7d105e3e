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
  // Each edge is registered in the slot list of its smaller endpoint; a vertex has only a handful
  // of edges there, so a linear scan finds an edge again. Walking half-edges in order numbers the
  // edges by first appearance directly. Linear time, no hashing, no sorting.
  std::vector<int> slot_start(num_vertices + 1, 0);
  for (int f = 0; f < m; ++f) {
    if (!face_usable(F, f, num_vertices)) continue;
    out.face_used[f] = 1;
    for (int k = 0; k < 3; ++k) ++slot_start[std::min(F(f, k), F(f, (k + 1) % 3)) + 1];
  }
  std::partial_sum(slot_start.begin(), slot_start.end(), slot_start.begin());
  const int used_halfedges = slot_start.back();
  struct Range {
    int begin, end;
  };
  struct Slot {
    int other, edge, count;
  };
  std::vector<Range> range(num_vertices);
  for (int v = 0; v < num_vertices; ++v) range[v] = {slot_start[v], slot_start[v]};
  std::vector<Slot> slots(used_halfedges);
  std::vector<int> edge_of(3 * static_cast<size_t>(m), -1);
  std::vector<int> lo_of, hi_of;
  lo_of.reserve(used_halfedges / 2 + 1);
  hi_of.reserve(used_halfedges / 2 + 1);
  const int* col0 = F.data();
  const int* col1 = col0 + F.rows();
  const int* col2 = col1 + F.rows();
  for (int f = 0; f < m; ++f) {
    if (!out.face_used[f]) continue;
    const int corner[3] = {col0[f], col1[f], col2[f]};
    for (int k = 0; k < 3; ++k) {
      const int a = corner[k], b = corner[k == 2 ? 0 : k + 1], lo = std::min(a, b), hi = std::max(a, b);
      Range& r = range[lo];
      int e = -1;
      for (int i = r.begin; i < r.end; ++i)
        if (slots[i].other == hi) {
          e = slots[i].edge;
          ++slots[i].count;
          break;
        }
      if (e < 0) {
        e = static_cast<int>(lo_of.size());
        lo_of.push_back(lo);
        hi_of.push_back(hi);
        slots[r.end++] = {hi, e, 1};
      }
      edge_of[3 * f + k] = e;
    }
  }
  const int edges = static_cast<int>(lo_of.size());
  std::vector<int> size(edges, 0);
  for (int v = 0; v < num_vertices; ++v)
    for (int i = range[v].begin; i < range[v].end; ++i) size[slots[i].edge] = slots[i].count;
  out.edges.resize(edges, 2);
  out.offsets.assign(edges + 1, 0);
  for (int e = 0; e < edges; ++e) {
    out.edges(e, 0) = lo_of[e];
    out.edges(e, 1) = hi_of[e];
    out.offsets[e + 1] = out.offsets[e] + size[e];
  }
  out.halfedges.resize(used_halfedges);
  std::vector<int> fill(out.offsets.begin(), out.offsets.end() - 1);
  for (size_t h = 0; h < edge_of.size(); ++h)
    if (edge_of[h] >= 0) out.halfedges[fill[edge_of[h]]++] = static_cast<int>(h);
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
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> P; // row-major: edges visit vertices at random
  if (n > 0) P = mesh.V;
  double length_sum = 0;
  for (int e = 0; e < s.edges; ++e) {
    const int a = inc.edges(e, 0), b = inc.edges(e, 1);
    sets.unite(a, b);
    length_sum += (P.row(a) - P.row(b)).norm();
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
    const Eigen::Vector3d p = P.row(v).transpose();
    if (!p.allFinite()) continue;
    s.bbox_min = any ? s.bbox_min.cwiseMin(p) : p;
    s.bbox_max = any ? s.bbox_max.cwiseMax(p) : p;
    any = true;
  }
  return s;
}

} // namespace gshell
