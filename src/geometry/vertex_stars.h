#pragma once
// Internal: the faces around every vertex, laid out for in-order passes over all vertices.
// Validation and mesh statistics visit each vertex's star instead of a global edge table, because
// on real models (vertex ids in no spatial order) random face access is what costs the time.
#include "geometry/disjoint_sets.h"
#include "geometry/first_touch.h"

#include <Eigen/Core>
#include <algorithm>
#include <numeric>
#include <vector>

namespace gshell::detail {

using RowMajorFaces = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// A face is usable for topology when its indices are in range and distinct.
inline bool face_usable(const RowMajorFaces& T, int f, int n) {
  const int a = T(f, 0), b = T(f, 1), c = T(f, 2);
  return a >= 0 && b >= 0 && c >= 0 && a < n && b < n && c < n && a != b && b != c && c != a;
}

/// One face seen from one of its corners.
struct Neighbour {
  int vertex;    ///< the other end of the edge
  int face;
  int corner;    ///< index of the corner in the vertex's star
  bool outgoing; ///< the face runs from the centre vertex to `vertex`
  int third;     ///< the face's third vertex (neither the centre nor `vertex`)
  bool operator<(const Neighbour& o) const { return vertex != o.vertex ? vertex < o.vertex : face < o.face; }
};

class VertexStars {
public:
  /// Usable faces only; `n` vertices.
  VertexStars(const RowMajorFaces& T, int n) : start_(n + 1, 0), usable_(T.rows(), 0) {
    const int m = static_cast<int>(T.rows());
    for (int f = 0; f < m; ++f) {
      if (!face_usable(T, f, n)) continue;
      usable_[f] = 1;
      for (int k = 0; k < 3; ++k) ++start_[T(f, k) + 1];
    }
    std::partial_sum(start_.begin(), start_.end(), start_.begin());
    assign_populated(corners_, static_cast<std::size_t>(start_.back())); // filled serially below
    std::vector<int> fill(start_.begin(), start_.end() - 1);
    for (int f = 0; f < m; ++f)
      if (usable_[f])
        for (int k = 0; k < 3; ++k) corners_[fill[T(f, k)]++] = {f, T(f, (k + 1) % 3), T(f, (k + 2) % 3)};
  }

  int degree(int v) const { return start_[v + 1] - start_[v]; }
  bool usable(int f) const { return usable_[f] != 0; }

  /// The i-th face at v (0 <= i < degree(v)) as (face, next, prev): the face runs v, next, prev.
  struct Corner {
    int face, next, prev;
  };
  const Corner& corner(int v, int i) const { return corners_[start_[v] + i]; }

  /// The two edges of every face at v, sorted by neighbour vertex (then face): the faces of edge
  /// (v, w) are one run of equal `vertex`.
  void neighbours(int v, std::vector<Neighbour>& out) const {
    out.clear();
    for (int i = 0; i < degree(v); ++i) {
      const Corner& c = corners_[start_[v] + i];
      out.push_back({c.next, c.face, i, true, c.prev});
      out.push_back({c.prev, c.face, i, false, c.next});
    }
    std::sort(out.begin(), out.end());
  }

private:
  std::vector<int> start_;
  std::vector<Corner> corners_;
  std::vector<char> usable_;
};

} // namespace gshell::detail
