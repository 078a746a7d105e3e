// Normal-cycle curvature (see the header for the conventions).
#include <gshell/geometry/curvature.h>

#include <gshell/error.h>

#include "geometry/first_touch.h"

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace gshell {
namespace {

/// Faces as contiguous rows (Eigen's column-major F puts a face's 3 ids far apart in memory).
using FaceRows = std::vector<std::array<int, 3>>;

/// A face's share of the edge tensors, upper triangle (xx, xy, xz, yy, yz, zz), then its area;
/// padded to a cache line so ring sums read one line per face.
struct alignas(64) WeightedTensor {
  std::array<double, 8> v{};
};

/// Compressed rows: the items of row r are ids[start[r] .. start[r+1]).
struct Csr {
  std::vector<int> start, ids;
  int begin(int r) const { return start[r]; }
  int end(int r) const { return start[r + 1]; }
};

Csr vertex_faces(const FaceRows& F, int n) {
  Csr vf;
  vf.start.assign(n + 1, 0);
  for (const auto& f : F)
    for (int v : f) ++vf.start[v + 1];
  for (int v = 0; v < n; ++v) vf.start[v + 1] += vf.start[v];
  vf.ids.resize(vf.start[n]);
  std::vector<int> fill(vf.start.begin(), vf.start.end() - 1);
  for (int f = 0; f < static_cast<int>(F.size()); ++f)
    for (int v : F[f]) vf.ids[fill[v]++] = f;
  return vf;
}

/// Distinct neighbours of every vertex (vertices sharing a face with it), ascending. Gathered per
/// vertex into a slot of two ids per incident face, then compacted: no list per vertex to
/// allocate (2.6 M of them at sphere:9 took longer than the gathering).
Csr vertex_neighbours(const FaceRows& F, const Csr& vf, int n) {
  std::vector<int> slot(n + 1, 0), count(n, 0);
  for (int v = 0; v < n; ++v) slot[v + 1] = slot[v] + 2 * (vf.end(v) - vf.begin(v));
  std::vector<int> gathered(slot[n]);
  tbb::parallel_for(tbb::blocked_range<int>(0, n), [&](const auto& r) {
    for (int v = r.begin(); v < r.end(); ++v) {
      int* const first = gathered.data() + slot[v];
      int* last = first;
      for (int k = vf.begin(v); k < vf.end(v); ++k)
        for (int w : F[vf.ids[k]])
          if (w != v) *last++ = w;
      std::sort(first, last);
      count[v] = static_cast<int>(std::unique(first, last) - first);
    }
  });
  Csr nb;
  nb.start.assign(n + 1, 0);
  for (int v = 0; v < n; ++v) nb.start[v + 1] = nb.start[v] + count[v];
  nb.ids.resize(nb.start[n]);
  tbb::parallel_for(tbb::blocked_range<int>(0, n), [&](const auto& r) {
    for (int v = r.begin(); v < r.end(); ++v)
      std::copy_n(gathered.begin() + slot[v], count[v], nb.ids.begin() + nb.start[v]);
  });
  return nb;
}

void check_input(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, int rings, const char* what) {
  if (rings < 1) throw InputError(std::string("curvature: ") + what + " rings must be >= 1");
  if (F.cols() != 3 && F.rows() > 0) throw InputError("curvature: faces must be triangles");
  if (V.cols() != 3 && V.rows() > 0) throw InputError("curvature: vertices must be 3D");
  if (F.size() > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= V.rows()))
    throw InputError("curvature: face vertex index out of range");
}

/// Spreads the low 10 bits of x so that two zero bits follow each (for 3D Morton codes).
std::uint32_t spread_bits(std::uint32_t x) {
  x &= 0x3ff;
  x = (x | (x << 16)) & 0x030000ff;
  x = (x | (x << 8)) & 0x0300f00f;
  x = (x | (x << 4)) & 0x030c30c3;
  x = (x | (x << 2)) & 0x09249249;
  return x;
}

/// Faces sorted along a Morton curve through their centroids. Ring sums read the tensors of ~40
/// nearby faces each; in this order the faces processed one after another share most of them,
/// so they come from cache instead of memory (input meshes often list faces in no useful order).
std::vector<int> spatial_face_order(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  const Eigen::Index m = F.rows();
  std::vector<std::pair<std::uint32_t, int>> keyed(m);
  if (m == 0) return {};
  const Eigen::RowVector3d lo = V.colwise().minCoeff();
  const double extent = std::max((V.colwise().maxCoeff() - lo).maxCoeff(), 1e-300);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, m), [&](const auto& r) {
    for (Eigen::Index f = r.begin(); f < r.end(); ++f) {
      const Eigen::RowVector3d c = (V.row(F(f, 0)) + V.row(F(f, 1)) + V.row(F(f, 2))) / 3.0;
      std::uint32_t key = 0;
      for (int i = 0; i < 3; ++i) {
        const double unit = std::clamp((c(i) - lo(i)) / extent, 0.0, 1.0);
        key |= spread_bits(static_cast<std::uint32_t>(unit * 1023.0)) << i;
      }
      keyed[f] = {key, static_cast<int>(f)};
    }
  });
  std::sort(keyed.begin(), keyed.end());
  std::vector<int> order(m);
  for (Eigen::Index i = 0; i < m; ++i) order[i] = keyed[i].second;
  return order;
}

/// Everything both estimates share: faces as rows (in spatial order: `original[f]` is the input
/// row of internal face f), unit normals (zero for degenerate faces),
/// each face's tensor share and area, and the adjacency used to gather rings.
struct CurvatureData {
  int n = 0;
  FaceRows F;
  std::vector<int> original;
  std::vector<Eigen::Vector3d> normal;
  std::vector<WeightedTensor> tensor;
  Csr vertex_faces, neighbours;
};

/// The other face on the directed edge a->b of face f: it must run the edge b->a and be the only
/// other face on it (else the edge is boundary, non-manifold or misoriented: -1, no contribution).
int opposite_face(const CurvatureData& d, int f, int a, int b) {
  int other = -1, count = 0;
  for (int k = d.vertex_faces.begin(a); k < d.vertex_faces.end(a); ++k) {
    const int g = d.vertex_faces.ids[k];
    if (g == f) continue;
    const auto& t = d.F[g];
    for (int i = 0; i < 3; ++i)
      if (t[i] == b) {
        ++count;
        if (t[(i + 1) % 3] == a) other = g;
      }
  }
  return count == 1 ? other : -1;
}

CurvatureData prepare(const Eigen::MatrixXd& V, const Eigen::MatrixXi& Fm) {
  CurvatureData d;
  d.n = static_cast<int>(V.rows());
  const int m = static_cast<int>(Fm.rows());
  d.original = spatial_face_order(V, Fm);
  // The per-face arrays are hundreds of MB at millions of faces: faulted in from all threads.
  detail::assign_populated(d.F, m);
  detail::assign_populated(d.normal, m, Eigen::Vector3d::Zero().eval());
  detail::assign_populated(d.tensor, m);
  tbb::parallel_for(tbb::blocked_range<int>(0, m), [&](const auto& r) {
    for (int f = r.begin(); f < r.end(); ++f) {
      const int g = d.original[f];
      d.F[f] = {Fm(g, 0), Fm(g, 1), Fm(g, 2)};
    }
  });
  auto vertex = [&](int i) { return Eigen::Vector3d(V(i, 0), V(i, 1), V(i, 2)); };
  tbb::parallel_for(tbb::blocked_range<int>(0, m), [&](const auto& r) {
    for (int f = r.begin(); f < r.end(); ++f) {
      const auto& t = d.F[f];
      const Eigen::Vector3d x = (vertex(t[1]) - vertex(t[0])).cross(vertex(t[2]) - vertex(t[0]));
      const double len = x.norm();
      d.normal[f] = len > 0 ? Eigen::Vector3d(x / len) : Eigen::Vector3d::Zero();
      d.tensor[f].v[6] = 0.5 * len;
    }
  });
  d.vertex_faces = vertex_faces(d.F, d.n);
  d.neighbours = vertex_neighbours(d.F, d.vertex_faces, d.n);
  // Half of beta |e| e_hat e_hat^T for each of the face's edges. beta is measured from this
  // face's side; the neighbour computes the same value for its half.
  tbb::parallel_for(tbb::blocked_range<int>(0, m), [&](const auto& r) {
    for (int f = r.begin(); f < r.end(); ++f) {
      auto& t = d.tensor[f].v;
      const Eigen::Vector3d& nf = d.normal[f];
      if (nf.isZero()) continue;
      for (int j = 0; j < 3; ++j) {
        const int a = d.F[f][j], b = d.F[f][(j + 1) % 3];
        const int g = opposite_face(d, f, a, b);
        if (g < 0 || d.normal[g].isZero()) continue;
        const Eigen::Vector3d& ng = d.normal[g];
        const Eigen::Vector3d edge = vertex(b) - vertex(a);
        const double len = edge.norm();
        if (len == 0) continue;
        const Eigen::Vector3d e = edge / len;
        // Convex (normals diverging across the edge) gives n_f x n_g along f's edge direction.
        const double beta = std::atan2(nf.cross(ng).dot(e), nf.dot(ng));
        const double w = 0.5 * beta * len;
        t[0] += w * e.x() * e.x();
        t[1] += w * e.x() * e.y();
        t[2] += w * e.x() * e.z();
        t[3] += w * e.y() * e.y();
        t[4] += w * e.y() * e.z();
        t[5] += w * e.z() * e.z();
      }
    }
  });
  return d;
}

/// Scratch space of one thread for gathering rings without clearing arrays between elements.
struct RingScratch {
  std::vector<std::uint32_t> vertex_mark, face_mark;
  std::uint32_t stamp = 0;
  std::vector<int> vertices;

  explicit RingScratch(const CurvatureData& d) : vertex_mark(d.n, 0), face_mark(d.F.size(), 0) {}

  std::uint32_t next_stamp() {
    if (++stamp == 0) { // wrapped around: old marks could alias the new stamp
      std::fill(vertex_mark.begin(), vertex_mark.end(), 0);
      std::fill(face_mark.begin(), face_mark.end(), 0);
      stamp = 1;
    }
    return stamp;
  }
};

/// Sum of the face tensors and areas over the `rings`-ring of triangles of the element whose
/// own vertices are `seed`: the faces touching any vertex within rings-1 edges of the seed.
template <class Seed>
WeightedTensor ring_sum(const Seed& seed, int rings, const CurvatureData& d, RingScratch& s) {
  const std::uint32_t stamp = s.next_stamp();
  s.vertices.clear();
  for (int v : seed)
    if (s.vertex_mark[v] != stamp) {
      s.vertex_mark[v] = stamp;
      s.vertices.push_back(v);
    }
  std::size_t layer_begin = 0;
  for (int step = 1; step < rings; ++step) {
    const std::size_t layer_end = s.vertices.size();
    for (std::size_t i = layer_begin; i < layer_end; ++i) {
      const int v = s.vertices[i];
      for (int k = d.neighbours.begin(v); k < d.neighbours.end(v); ++k) {
        const int w = d.neighbours.ids[k];
        if (s.vertex_mark[w] != stamp) {
          s.vertex_mark[w] = stamp;
          s.vertices.push_back(w);
        }
      }
    }
    layer_begin = layer_end;
  }
  WeightedTensor sum;
  for (int v : s.vertices)
    for (int k = d.vertex_faces.begin(v); k < d.vertex_faces.end(v); ++k) {
      const int f = d.vertex_faces.ids[k];
      if (s.face_mark[f] == stamp) continue;
      s.face_mark[f] = stamp;
      for (int i = 0; i < 7; ++i) sum.v[i] += d.tensor[f].v[i];
    }
  return sum;
}

/// Principal curvatures from a ring sum, in the tangent plane orthogonal to unit `n` with
/// in-plane unit vector `t1`. Writes entry / row `i` of the result (left zero if the area is 0).
void principal_from_sum(const WeightedTensor& sum, const Eigen::Vector3d& n, const Eigen::Vector3d& t1,
                        Eigen::Index i, PrincipalCurvatures& out) {
  const auto& t = sum.v;
  const double area = t[6];
  if (!(area > 0)) return;
  Eigen::Matrix3d T;
  T << t[0], t[1], t[2], t[1], t[3], t[4], t[2], t[4], t[5];
  T /= area;
  const Eigen::Vector3d t2 = n.cross(t1);
  const double m11 = t1.dot(T * t1), m12 = t1.dot(T * t2), m22 = t2.dot(T * t2);
  const double half_sum = 0.5 * (m11 + m22);
  const double radius = std::hypot(0.5 * (m11 - m22), m12);
  const double theta = 0.5 * std::atan2(2 * m12, m11 - m22);
  // (lambda_plus, u_plus), (lambda_minus, u_minus) are the eigenpairs. The tensor swaps
  // directions: the curvature along u_plus is lambda_minus and vice versa.
  const Eigen::Vector3d u_plus = std::cos(theta) * t1 + std::sin(theta) * t2;
  const Eigen::Vector3d u_minus = -std::sin(theta) * t1 + std::cos(theta) * t2;
  out.k1(i) = half_sum + radius;
  out.k2(i) = half_sum - radius;
  out.e1.row(i) = u_minus;
  out.e2.row(i) = -u_plus; // (e1, e2, n) right-handed
}

PrincipalCurvatures allocate(Eigen::Index count) {
  PrincipalCurvatures pc;
  pc.k1.resize(count);
  pc.k2.resize(count);
  pc.e1.resize(count, 3);
  pc.e2.resize(count, 3);
  auto zero = [](auto& a) { // faulted in from all threads, then zeroed
    detail::populate_in_parallel(a.data(), static_cast<std::size_t>(a.size()) * sizeof(double));
    a.setZero();
  };
  zero(pc.k1);
  zero(pc.k2);
  zero(pc.e1);
  zero(pc.e2);
  return pc;
}

/// Any unit vector orthogonal to unit n.
Eigen::Vector3d some_tangent(const Eigen::Vector3d& n) {
  const Eigen::Vector3d axis = std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  return n.cross(axis).normalized();
}

} // namespace

FaceCurvature face_curvature(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                             const CurvatureOptions& options) {
  check_input(V, F, options.face_rings, "face");
  const CurvatureData d = prepare(V, F);
  FaceCurvature out = allocate(F.rows());
  tbb::enumerable_thread_specific<RingScratch> scratch([&] { return RingScratch(d); });
  tbb::parallel_for(tbb::blocked_range<int>(0, static_cast<int>(d.F.size())), [&](const auto& r) {
    RingScratch& s = scratch.local();
    for (int f = r.begin(); f < r.end(); ++f) {
      if (d.normal[f].isZero()) continue;
      const WeightedTensor sum = ring_sum(d.F[f], options.face_rings, d, s);
      const Eigen::Vector3d t1 = (V.row(d.F[f][1]) - V.row(d.F[f][0])).normalized();
      principal_from_sum(sum, d.normal[f], t1, d.original[f], out);
    }
  });
  return out;
}

VertexCurvature vertex_curvature(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                 const CurvatureOptions& options) {
  check_input(V, F, options.vertex_rings, "vertex");
  const CurvatureData d = prepare(V, F);
  VertexCurvature out = allocate(d.n);
  tbb::enumerable_thread_specific<RingScratch> scratch([&] { return RingScratch(d); });
  tbb::parallel_for(tbb::blocked_range<int>(0, d.n), [&](const auto& r) {
    RingScratch& s = scratch.local();
    for (int v = r.begin(); v < r.end(); ++v) {
      // Area-weighted vertex normal.
      Eigen::Vector3d normal = Eigen::Vector3d::Zero();
      for (int k = d.vertex_faces.begin(v); k < d.vertex_faces.end(v); ++k) {
        const int f = d.vertex_faces.ids[k];
        normal += d.tensor[f].v[6] * d.normal[f];
      }
      if (normal.norm() == 0) continue;
      normal.normalize();
      const WeightedTensor sum = ring_sum(std::array<int, 1>{v}, options.vertex_rings, d, s);
      principal_from_sum(sum, normal, some_tangent(normal), v, out);
    }
  });
  return out;
}

} // namespace gshell
