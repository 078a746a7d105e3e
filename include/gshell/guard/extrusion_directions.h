#pragma once
// Valid extrusion directions: per base vertex a unit direction d_i along which the top vertex can
// leave the base so that every prism around the vertex starts positively oriented. A prism of face
// f with corner i lifted by a small t along d_i gains volume at the rate t * area * (n_f . d_i), so
// d_i must see every incident face from its positive side: n_f . d_i > 0 for all faces f at i.
// The best such direction maximises the margin min_f n_f . d_i (the direction "Bijective Projection
// in a Shell", Jiang et al. 2020, solves a small LP for).
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <vector>

namespace gshell {

struct ExtrusionDirections {
  Eigen::MatrixXd direction; ///< n x 3 unit directions (zero rows for vertices no face uses)
  /// min over the faces at vertex i of n_f . d_i (a cosine in [-1, 1]; 1 for unused vertices).
  Eigen::VectorXd margin;
  /// Vertices where no direction sees every incident face from its positive side (the best
  /// margin is <= 0): the prisms around them cannot all be valid. Ascending. Their direction is the
  /// one with the largest (non-positive) margin.
  std::vector<int> unextrudable;
};

/// Directions for the base (V, F) (faces counter-clockwise, n x 3 / m x 3). Where the area-weighted
/// vertex normal (the paper's offset direction) keeps a margin of at least `normal_margin`, it is
/// taken as it is, so that smooth regions extrude exactly as the offset surface; elsewhere the
/// direction of largest margin (an exact max-min over the face normals, computed by enumerating its
/// possible active sets). Faces of zero area have no normal and are ignored.
/// \throws InputError when V or F does not have 3 columns or F has a vertex id outside 0..n-1.
ExtrusionDirections extrusion_directions(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                         double normal_margin = 0.5);

/// Those of `vertices` (base vertices of (V, F)) on the rim of an open surface whose side walls,
/// lifted along their row of `directions`, cut through one of the vertex's own faces: near the
/// vertex the wall over a boundary edge (v, j) is the sector spanned by b_j - b_v and the
/// direction, and if that sector crosses another face at v the two meet however thin the layer
/// is made (e.g. a rim folded flat back onto the faces next to it). Exact predicates on the
/// rounded lifted corner. Ascending.
std::vector<int> rim_vertices_with_blocked_walls(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                                 const Eigen::MatrixXd& directions, const std::vector<int>& vertices);

} // namespace gshell
