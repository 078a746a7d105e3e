#include <gshell/geometry/mesh_topology.h>

#include "vertex_stars.h"

#include <gshell/error.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <utility>

namespace gshell {
using detail::DisjointSets;

namespace {

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

std::vector<char> used_vertices(const Eigen::MatrixXi& elements, Eigen::Index n) {
  std::vector<char> used(static_cast<std::size_t>(std::max<Eigen::Index>(n, 0)), 0);
  for (Eigen::Index r = 0; r < elements.rows(); ++r)
    for (Eigen::Index c = 0; c < elements.cols(); ++c)
      if (const int v = elements(r, c); v >= 0 && v < n) used[static_cast<std::size_t>(v)] = 1;
  return used;
}

std::vector<int> inward_closed_parts(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  const int n = static_cast<int>(V.rows()), m = F.cols() == 3 ? static_cast<int>(F.rows()) : 0;
  DisjointSets parts(n); // roots are the lowest ids
  for (int f = 0; f < m; ++f)
    if (face_usable(F, f, n)) parts.unite(F(f, 0), F(f, 1)), parts.unite(F(f, 0), F(f, 2));
  // Signed tets from each part's lowest vertex: near the part, so that far from the origin the
  // terms do not cancel in rounding.
  std::vector<double> volume(n, 0), magnitude(n, 0);
  for (int f = 0; f < m; ++f) {
    if (!face_usable(F, f, n)) continue;
    const int root = parts.find(F(f, 0));
    const Eigen::Vector3d o = V.row(root).transpose();
    const Eigen::Vector3d a = V.row(F(f, 0)).transpose() - o, b = V.row(F(f, 1)).transpose() - o,
                          c = V.row(F(f, 2)).transpose() - o;
    const double det = a.dot(b.cross(c));
    volume[root] += det;
    magnitude[root] += std::abs(det);
  }
  std::vector<int> inward;
  for (int v = 0; v < n; ++v)
    if (parts.find(v) == v && magnitude[v] > 0 && volume[v] < -1e-6 * magnitude[v]) inward.push_back(v);
  if (inward.empty()) return inward; // the usual case: no edge table needed (generation runs this)
  // An open part has no inside, whatever its sign.
  const EdgeIncidence incidence = edge_incidence(F, n);
  std::vector<char> open(n, 0);
  for (int e = 0; e < incidence.num_edges(); ++e)
    if (incidence.valence(e) == 1) open[parts.find(incidence.edges(e, 0))] = 1;
  inward.erase(std::remove_if(inward.begin(), inward.end(), [&](int v) { return open[v]; }), inward.end());
  return inward;
}

std::string inward_closed_parts_message(const std::vector<int>& parts) {
  if (parts.empty()) return {};
  const bool one = parts.size() == 1;
  return std::to_string(parts.size()) + " closed part" + (one ? " has its" : "s have their") +
         " faces pointing inwards (" + (one ? "the part" : "e.g. the part") + " with vertex " +
         std::to_string(parts.front()) + " encloses a negative volume): a shell grows into the solid there; "
         "reverse the faces for an outward one (a mirrored export flips them)";
}

MeshStats mesh_stats(const TriMesh& mesh) {
  MeshStats s;
  const int n = mesh.V.cols() == 3 ? mesh.num_vertices() : 0;
  s.vertices = mesh.num_vertices();
  s.faces = mesh.num_faces();
  detail::RowMajorFaces T; // row-major copies: the pass below visits faces and vertices at random
  if (mesh.F.cols() == 3) T = mesh.F;
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> P;
  if (n > 0) P = mesh.V;

  // Edge (v, w), v < w, is counted at v, from v's star: same figures as edge_incidence, in order.
  const detail::VertexStars stars(T, n);
  DisjointSets pieces(n), boundary_pieces(n);
  std::vector<char> on_boundary(n, 0);
  std::vector<detail::Neighbour> around;
  double mean_length = 0;
  int used_vertices = 0, finite_edges = 0;
  for (int v = 0; v < n; ++v) {
    if (stars.degree(v) == 0) continue;
    ++used_vertices;
    stars.neighbours(v, around);
    for (size_t i = 0; i < around.size();) {
      size_t j = i + 1;
      while (j < around.size() && around[j].vertex == around[i].vertex) ++j;
      const int w = around[i].vertex;
      if (v < w) {
        ++s.edges;
        // info describes meshes gshell refuses too: lengths near 1e300 or 1e-300 overflow or
        // underflow when squared, so those are measured again with scaling.
        double length = (P.row(v) - P.row(w)).norm();
        if (length == 0 || std::isinf(length)) length = (P.row(v) - P.row(w)).stableNorm();
        if (std::isfinite(length)) { // a running mean: a sum of lengths near 1e300 would overflow
          ++finite_edges;
          mean_length += (length - mean_length) / finite_edges;
        }
        pieces.unite(v, w);
        if (j - i == 1) {
          ++s.boundary_edges;
          boundary_pieces.unite(v, w);
          on_boundary[v] = on_boundary[w] = 1;
        }
      }
      i = j;
    }
  }
  int used_faces = 0;
  for (int f = 0; f < static_cast<int>(T.rows()); ++f) used_faces += stars.usable(f);
  for (int v = 0; v < n; ++v) {
    if (stars.degree(v) > 0 && pieces.find(v) == v) ++s.components;
    if (on_boundary[v] && boundary_pieces.find(v) == v) ++s.boundary_loops;
  }
  s.unreferenced_vertices = n - used_vertices;
  s.mean_edge_length = mean_length;
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

void grow_by_rings(const Eigen::MatrixXi& F, int rings, std::vector<char>& flags) {
  if (F.size() > 0 && (F.cols() != 3 || F.minCoeff() < 0 || static_cast<std::size_t>(F.maxCoeff()) >= flags.size()))
    throw InputError("grow_by_rings: F must be m x 3 with ids in [0, " + std::to_string(flags.size()) +
                     ") (one flag per vertex)");
  for (int ring = 0; ring < rings; ++ring) {
    std::vector<char> grown = flags;
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      if (flags[F(f, 0)] || flags[F(f, 1)] || flags[F(f, 2)])
        for (int k = 0; k < 3; ++k) grown[F(f, k)] = 1;
    flags = std::move(grown);
  }
}

} // namespace gshell
