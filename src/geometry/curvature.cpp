// Normal-cycle curvature (see the header for the conventions).
#include <gshell/geometry/curvature.h>

#include <gshell/error.h>

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace gshell {
namespace {

/// Upper triangle of a symmetric 3x3 tensor: xx, xy, xz, yy, yz, zz.
using SymTensor = std::array<double, 6>;

/// Faces around each vertex in compressed rows: faces of v are ids[start[v] .. start[v+1]).
struct VertexFaces {
  std::vector<int> start, ids;
};

VertexFaces vertex_faces(const Eigen::MatrixXi& F, int n) {
  VertexFaces vf;
  vf.start.assign(n + 1, 0);
  for (int f = 0; f < F.rows(); ++f)
    for (int j = 0; j < 3; ++j) ++vf.start[F(f, j) + 1];
  for (int v = 0; v < n; ++v) vf.start[v + 1] += vf.start[v];
  vf.ids.resize(vf.start[n]);
  std::vector<int> fill(vf.start.begin(), vf.start.end() - 1);
  for (int f = 0; f < F.rows(); ++f)
    for (int j = 0; j < 3; ++j) vf.ids[fill[F(f, j)]++] = f;
  return vf;
}

void check_input(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, int rings, const char* what) {
  if (rings < 1) throw InputError(std::string("curvature: ") + what + " rings must be >= 1");
  if (F.cols() != 3 && F.rows() > 0) throw InputError("curvature: faces must be triangles");
  if (V.cols() != 3 && V.rows() > 0) throw InputError("curvature: vertices must be 3D");
  if (F.size() > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= V.rows()))
    throw InputError("curvature: face vertex index out of range");
}

/// Unit normals (zero for degenerate faces) and areas of all faces.
void face_normals_areas(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, Eigen::MatrixXd& N,
                        Eigen::VectorXd& A) {
  const Eigen::Index m = F.rows();
  N.resize(m, 3);
  A.resize(m);
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, m), [&](const auto& r) {
    for (Eigen::Index f = r.begin(); f < r.end(); ++f) {
      const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
      const Eigen::Vector3d x = (b - a).cross(c - a);
      const double len = x.norm();
      A(f) = 0.5 * len;
      N.row(f) = len > 0 ? Eigen::Vector3d(x / len) : Eigen::Vector3d::Zero();
    }
  });
}

/// Each face's share of the edge tensors: half of beta |e| e_hat e_hat^T for each of its 3 edges.
/// beta is measured from this face's side; the neighbour computes the same value for its half.
std::vector<SymTensor> face_edge_tensors(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                         const Eigen::MatrixXd& N, const VertexFaces& vf) {
  std::vector<SymTensor> T(F.rows());
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, F.rows()), [&](const auto& r) {
    for (Eigen::Index f = r.begin(); f < r.end(); ++f) {
      SymTensor t{};
      const Eigen::Vector3d nf = N.row(f);
      for (int j = 0; j < 3; ++j) {
        const int a = F(f, j), b = F(f, (j + 1) % 3);
        // The other face on edge (a,b): it must run the edge the other way round (b,a), and be
        // the only one (else the edge is boundary, non-manifold or misoriented: no contribution).
        int other = -1, count = 0;
        for (int k = vf.start[a]; k < vf.start[a + 1]; ++k) {
          const int g = vf.ids[k];
          if (g == f) continue;
          for (int i = 0; i < 3; ++i)
            if (F(g, i) == b) {
              ++count;
              if (F(g, (i + 1) % 3) == a) other = g;
            }
        }
        if (count != 1 || other < 0) continue;
        const Eigen::Vector3d ng = N.row(other);
        const Eigen::Vector3d edge = V.row(b) - V.row(a);
        const double len = edge.norm();
        if (len == 0 || nf.isZero() || ng.isZero()) continue;
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
      T[f] = t;
    }
  });
  return T;
}

/// Scratch space of one thread for gathering rings without clearing arrays between elements.
struct RingScratch {
  std::vector<std::uint32_t> vertex_mark, face_mark;
  std::uint32_t stamp = 0;
  std::vector<int> vertices, frontier_end;
};

/// Sums the face tensors and areas over the `rings`-ring of triangles of the element whose
/// vertices are `seed`.
template <class Seed>
void ring_sum(const Seed& seed, int rings, const Eigen::MatrixXi& F, const VertexFaces& vf,
              const std::vector<SymTensor>& T, const Eigen::VectorXd& A, RingScratch& s,
              SymTensor& sum, double& area) {
  if (++s.stamp == 0) { // wrapped around: old marks could alias the new stamp
    std::fill(s.vertex_mark.begin(), s.vertex_mark.end(), 0);
    std::fill(s.face_mark.begin(), s.face_mark.end(), 0);
    s.stamp = 1;
  }
  const std::uint32_t stamp = s.stamp;
  s.vertices.clear();
  for (int v : seed)
    if (s.vertex_mark[v] != stamp) {
      s.vertex_mark[v] = stamp;
      s.vertices.push_back(v);
    }
  // Grow the vertex set by rings-1 edge steps (neighbours = vertices of incident faces).
  std::size_t layer_begin = 0;
  for (int step = 1; step < rings; ++step) {
    const std::size_t layer_end = s.vertices.size();
    for (std::size_t i = layer_begin; i < layer_end; ++i) {
      const int v = s.vertices[i];
      for (int k = vf.start[v]; k < vf.start[v + 1]; ++k)
        for (int j = 0; j < 3; ++j) {
          const int w = F(vf.ids[k], j);
          if (s.vertex_mark[w] != stamp) {
            s.vertex_mark[w] = stamp;
            s.vertices.push_back(w);
          }
        }
    }
    layer_begin = layer_end;
  }
  sum = SymTensor{};
  area = 0;
  for (int v : s.vertices)
    for (int k = vf.start[v]; k < vf.start[v + 1]; ++k) {
      const int f = vf.ids[k];
      if (s.face_mark[f] == stamp) continue;
      s.face_mark[f] = stamp;
      for (int i = 0; i < 6; ++i) sum[i] += T[f][i];
      area += A(f);
    }
}

/// Principal curvatures from the averaged tensor, in the tangent plane orthogonal to unit `n`
/// with in-plane unit vector `t1`. Writes row `i` of the result.
void principal_from_tensor(const SymTensor& t, const Eigen::Vector3d& n, const Eigen::Vector3d& t1,
                           Eigen::Index i, PrincipalCurvatures& out) {
  Eigen::Matrix3d T;
  T << t[0], t[1], t[2], t[1], t[3], t[4], t[2], t[4], t[5];
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
  pc.k1 = Eigen::VectorXd::Zero(count);
  pc.k2 = Eigen::VectorXd::Zero(count);
  pc.e1 = Eigen::MatrixXd::Zero(count, 3);
  pc.e2 = Eigen::MatrixXd::Zero(count, 3);
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
  const int n = static_cast<int>(V.rows());
  Eigen::MatrixXd N;
  Eigen::VectorXd A;
  face_normals_areas(V, F, N, A);
  const VertexFaces vf = vertex_faces(F, n);
  const std::vector<SymTensor> T = face_edge_tensors(V, F, N, vf);

  FaceCurvature out = allocate(F.rows());
  tbb::enumerable_thread_specific<RingScratch> scratch([&] {
    RingScratch s;
    s.vertex_mark.assign(n, 0);
    s.face_mark.assign(F.rows(), 0);
    return s;
  });
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, F.rows()), [&](const auto& r) {
    RingScratch& s = scratch.local();
    for (Eigen::Index f = r.begin(); f < r.end(); ++f) {
      const Eigen::Vector3d nf = N.row(f);
      const std::array<int, 3> seed{F(f, 0), F(f, 1), F(f, 2)};
      SymTensor sum;
      double area;
      ring_sum(seed, options.face_rings, F, vf, T, A, s, sum, area);
      if (nf.isZero() || area <= 0) continue;
      for (double& x : sum) x /= area;
      const Eigen::Vector3d t1 = (V.row(F(f, 1)) - V.row(F(f, 0))).normalized();
      principal_from_tensor(sum, nf, t1, f, out);
    }
  });
  return out;
}

VertexCurvature vertex_curvature(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                 const CurvatureOptions& options) {
  check_input(V, F, options.vertex_rings, "vertex");
  const int n = static_cast<int>(V.rows());
  Eigen::MatrixXd N;
  Eigen::VectorXd A;
  face_normals_areas(V, F, N, A);
  const VertexFaces vf = vertex_faces(F, n);
  const std::vector<SymTensor> T = face_edge_tensors(V, F, N, vf);

  VertexCurvature out = allocate(n);
  tbb::enumerable_thread_specific<RingScratch> scratch([&] {
    RingScratch s;
    s.vertex_mark.assign(n, 0);
    s.face_mark.assign(F.rows(), 0);
    return s;
  });
  tbb::parallel_for(tbb::blocked_range<int>(0, n), [&](const auto& r) {
    RingScratch& s = scratch.local();
    for (int v = r.begin(); v < r.end(); ++v) {
      Eigen::Vector3d normal = Eigen::Vector3d::Zero();
      for (int k = vf.start[v]; k < vf.start[v + 1]; ++k)
        normal += A(vf.ids[k]) * N.row(vf.ids[k]).transpose();
      if (normal.norm() == 0) continue;
      normal.normalize();
      const std::array<int, 1> seed{v};
      SymTensor sum;
      double area;
      ring_sum(seed, options.vertex_rings, F, vf, T, A, s, sum, area);
      if (area <= 0) continue;
      for (double& x : sum) x /= area;
      principal_from_tensor(sum, normal, some_tangent(normal), v, out);
    }
  });
  return out;
}

} // namespace gshell
