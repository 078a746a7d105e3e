#pragma once
// Point location in a tet mesh (a shell, or the texture-space prisms of a base's UVs).
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <unordered_map>
#include <utility>
#include <vector>

namespace gshell {

/// Where a point lies relative to a tet mesh.
struct TetHit {
  int tet = -1;                            ///< containing tet, or the nearest one when outside
  Eigen::Vector4d bary = Eigen::Vector4d::Zero(); ///< affine coordinates w.r.t. that tet's 4 vertices (sum 1)
  bool inside = false;                     ///< all coordinates >= -kInsideTolerance
  double distance = 0;                     ///< Euclidean distance to the tet (0 when inside)
};

/// A hashed uniform grid over the tets' bounding boxes (cell size per axis = mean tet extent along
/// that axis, so thin shells and the flat texture-space prisms get sensible cells) finds the tet
/// holding a point; a bounding-volume hierarchy over the boundary faces of the tets, built at the
/// first point outside them, finds the nearest tet of a point outside (a search over rings of grid
/// cells cost the cube of the distance in tet sizes: 0.4 s per point half a radius inside a
/// sphere:8 shell). Built once, queried from many threads (locate is const and thread-safe).
class TetLocator {
public:
  /// Coordinates count as inside down to -kInsideTolerance: points on a shared face or on the
  /// shell's boundary surfaces are inside, whatever the rounding.
  static constexpr double kInsideTolerance = 1e-9;

  /// X: N x 3 points, T: K x 4 ids. Tets whose volume is negligible (below 1e-14 of their
  /// bounding box) cannot carry affine coordinates and are left out of the index.
  /// \throws InputError when X is not N x 3, T not K x 4, or a T id is outside 0..N-1.
  TetLocator(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T);

  /// The tet containing p (the one where p is deepest when several share it), or, when no tet
  /// contains p, the nearest tet with p's extrapolated affine coordinates in it. tet = -1 only
  /// when the mesh has no usable tet.
  TetHit locate(const Eigen::Vector3d& p) const;

  /// Affine coordinates of p in tet t (t must be a usable tet: not checked, this is the inner
  /// loop of locate).
  Eigen::Vector4d affine_coordinates(int t, const Eigen::Vector3d& p) const;

  int usable_tets() const { return static_cast<int>(usable_.size()); }

private:
  using Cell = Eigen::Matrix<std::int64_t, 3, 1>;
  Cell cell_of(const Eigen::Vector3d& p) const;
  std::uint64_t key(const Cell& c) const;
  const std::vector<int>* tets_in(const Cell& c) const;
  struct Boundary; // the boundary faces of the usable tets and their hierarchy
  const Boundary& boundary() const;

  Eigen::MatrixXd X_;
  Eigen::MatrixXi T_;
  std::vector<Eigen::Matrix3d> inverse_edges_; ///< [x1-x0, x2-x0, x3-x0]^-1 per tet
  std::vector<int> usable_;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero(), cell_size_ = Eigen::Vector3d::Ones();
  Cell lo_ = Cell::Zero(), hi_ = Cell::Zero(); ///< occupied cell range (inclusive)
  std::unordered_map<std::uint64_t, std::vector<int>> cells_;
  std::shared_ptr<Boundary> boundary_; ///< built by the first point outside every tet
};

} // namespace gshell
