#include <gshell/guard/extrusion_directions.h>

#include <gshell/error.h>

#include "geometry/vertex_stars.h"
#include "quality/exact_faces.h"

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>
#include <string>

namespace gshell {

namespace {

// Above this many faces at a vertex the triple candidates (O(k^4) work) are skipped: the pair
// candidates still find the optimum when at most two faces are active, and such vertices (fans of
// long thin triangles) are rare.
constexpr int kMaxFacesForTriples = 48;

double margin_of(const std::vector<Eigen::Vector3d>& normals, const Eigen::Vector3d& d, double stop_below) {
  double m = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& n : normals) {
    m = std::min(m, n.dot(d));
    if (m < stop_below) break; // cannot beat the best candidate so far
  }
  return m;
}

// The unit d maximising min_f n_f . d. On the sphere the optimum is fixed by at most three active
// faces: it is a face normal (one active), the normalised sum of two normals (two active, on their
// bisector), or a point equally far from three normals (three active). Enumerating these
// candidates and keeping the best is exact for small stars.
void best_direction(const std::vector<Eigen::Vector3d>& normals, Eigen::Vector3d& best, double& best_margin) {
  const int k = static_cast<int>(normals.size());
  auto consider = [&](const Eigen::Vector3d& d) {
    const double m = margin_of(normals, d, best_margin);
    if (m > best_margin) {
      best_margin = m;
      best = d;
    }
  };
  for (int a = 0; a < k; ++a) consider(normals[a]);
  for (int a = 0; a < k; ++a)
    for (int b = a + 1; b < k; ++b) {
      const Eigen::Vector3d s = normals[a] + normals[b];
      const double len = s.norm();
      if (len > 1e-12) consider(s / len);
    }
  if (k > kMaxFacesForTriples) return;
  for (int a = 0; a < k; ++a)
    for (int b = a + 1; b < k; ++b)
      for (int c = b + 1; c < k; ++c) {
        const Eigen::Vector3d x = (normals[b] - normals[a]).cross(normals[c] - normals[a]);
        const double len = x.norm();
        if (!(len > 1e-12)) continue;
        consider(x / len);
        consider(-x / len);
      }
}

// At a vertex v on the rim of an open surface, the side wall over each boundary edge (v, j)
// leaves v between the edge and d: near v it is the planar sector spanned by b_j - b_v and d. If
// that sector cuts through one of v's other faces, the wall meets that face however thin the
// layer (both are sectors at v). Decided exactly on a wall triangle with those sides (a triangle
// and a face sharing only v meet beyond v exactly when their sectors do).
bool walls_clear(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const detail::VertexStars& stars, int v,
                 const Eigen::Vector3d& d, std::vector<detail::Neighbour>& neighbours) {
  using detail::ExactPoint;
  stars.neighbours(v, neighbours); // the faces of edge (v, w) are one run of equal `vertex`
  const Eigen::Vector3d b = V.row(v);
  for (std::size_t i = 0; i < neighbours.size(); ++i) {
    const int j = neighbours[i].vertex;
    const bool rim = (i == 0 || neighbours[i - 1].vertex != j) &&
                     (i + 1 == neighbours.size() || neighbours[i + 1].vertex != j);
    if (!rim) continue;
    const Eigen::Vector3d e = V.row(j);
    const Eigen::Vector3d lift = b + (e - b).norm() * d;
    const detail::ExactFace wall = detail::exact_face( // its third corner is a new point: an id no face has
        {v, j, -1}, {ExactPoint(b.x(), b.y(), b.z()), ExactPoint(e.x(), e.y(), e.z()),
                     ExactPoint(lift.x(), lift.y(), lift.z())});
    for (int c = 0; c < stars.degree(v); ++c) {
      const detail::VertexStars::Corner& corner = stars.corner(v, c);
      if (corner.next != j && corner.prev != j && // not the face along the edge itself
          detail::faces_intersect_beyond_shared(wall, detail::exact_face(V, F, corner.face)))
        return false;
    }
  }
  return true;
}

} // namespace

std::vector<int> rim_vertices_with_blocked_walls(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                                 const Eigen::MatrixXd& directions, const std::vector<int>& vertices) {
  std::vector<int> blocked;
  if (vertices.empty()) return blocked;
  const detail::VertexStars stars(detail::RowMajorFaces(F), static_cast<int>(V.rows()));
  std::vector<detail::Neighbour> neighbours;
  for (int v : vertices)
    if (!walls_clear(V, F, stars, v, directions.row(v).transpose(), neighbours)) blocked.push_back(v);
  std::sort(blocked.begin(), blocked.end());
  return blocked;
}

ExtrusionDirections extrusion_directions(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double normal_margin) {
  const int n = static_cast<int>(V.rows()), m = static_cast<int>(F.rows());
  if (V.cols() != 3 || (m > 0 && F.cols() != 3)) throw InputError("extrusion_directions: need n x 3 V and m x 3 F");
  // Unit face normals (zero for faces without area) and the faces around every vertex.
  std::vector<Eigen::Vector3d> face_normal(m);
  std::vector<int> start(n + 1, 0);
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = F(f, k);
      if (v < 0 || v >= n) throw InputError("extrusion_directions: face " + std::to_string(f) + " has vertex id " +
                                            std::to_string(v) + " out of range");
      ++start[v + 1];
    }
  for (int v = 0; v < n; ++v) start[v + 1] += start[v];
  std::vector<int> star(start[n]);
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int f = 0; f < m; ++f)
      for (int k = 0; k < 3; ++k) star[fill[F(f, k)]++] = f;
  }
  tbb::parallel_for(0, m, [&](int f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::Vector3d x = (b - a).cross(c - a);
    const double len = x.norm();
    face_normal[f] = len > 0 ? Eigen::Vector3d(x / len) : Eigen::Vector3d::Zero();
  });

  ExtrusionDirections out;
  out.direction = Eigen::MatrixXd::Zero(n, 3);
  out.margin = Eigen::VectorXd::Ones(n);
  std::vector<char> bad(n, 0);
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 512), [&](const tbb::blocked_range<int>& range) {
    std::vector<Eigen::Vector3d> normals;
    for (int v = range.begin(); v < range.end(); ++v) {
      normals.clear();
      Eigen::Vector3d sum = Eigen::Vector3d::Zero(); // area-weighted normal
      for (int s = start[v]; s < start[v + 1]; ++s) {
        const int f = star[s];
        if (face_normal[f].squaredNorm() == 0) continue;
        normals.push_back(face_normal[f]);
        const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
        sum += (b - a).cross(c - a);
      }
      if (normals.empty()) continue;
      Eigen::Vector3d best = Eigen::Vector3d::Zero();
      double best_margin = -std::numeric_limits<double>::infinity();
      if (sum.norm() > 0) {
        const Eigen::Vector3d normal = sum.normalized();
        best_margin = margin_of(normals, normal, -std::numeric_limits<double>::infinity());
        best = normal;
      }
      if (!(best_margin >= normal_margin)) best_direction(normals, best, best_margin);
      out.direction.row(v) = best.transpose();
      out.margin[v] = best_margin;
      bad[v] = !(best_margin > 0);
    }
  });
  for (int v = 0; v < n; ++v)
    if (bad[v]) out.unextrudable.push_back(v);
  return out;
}

} // namespace gshell
