#pragma once
// Bounding-volume hierarchy over the triangles of a mesh for closest-point (distance) queries.
// Built once, then queried from many threads at once (queries are const).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace gshell::detail {

class ClosestPointTree {
public:
  /// F must index rows of V (checked by the caller) and be non-empty.
  ClosestPointTree(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

  /// Squared distance from q to the surface (model units squared). `bound2` is a known upper
  /// bound (e.g. the squared distance to a point on the surface); it only prunes the search and
  /// the result is min(bound2, true squared distance).
  double squared_distance(const Eigen::Vector3d& q, double bound2) const;

private:
  struct Face {
    Eigen::Vector3d a, b, c;
    bool flat = false; // collinear corners (up to ~1e-12 relative): measured by its edges
  };
  struct Node {
    Eigen::AlignedBox3d box;
    int first = 0;  // leaf: first index into order_; inner: index of the right child
    int count = 0;  // faces in a leaf, 0 for an inner node (its left child is the next node)
  };

  int build(int begin, int end, const std::vector<Eigen::Vector3d>& centroids);
  double face_squared_distance(const Face& f, const Eigen::Vector3d& q) const;

  std::vector<Face> faces_;
  std::vector<int> order_; // face ids, grouped by leaf
  std::vector<Node> nodes_;
};

} // namespace gshell::detail
