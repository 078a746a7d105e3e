#pragma once
// The boundary surface of a shell's layer: its top, its base and, on open surfaces, the side walls
// over the base's boundary edges. A shell is valid when this surface does not intersect itself
// (and no tet is inverted); contact handling and the certificate both work on it.
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace gshell {

enum class BoundaryPart : std::uint8_t {
  Base, ///< a base face, reversed (its normal points away from the layer)
  Top,  ///< a top face, as the base face it sits over
  Wall, ///< one of the two triangles of a side quad over a boundary edge of the base
};

/// Triangles over the 2n shell vertices (base i is i, top i is n + i), every one oriented with its
/// normal pointing out of the layer when the top lies on the normal side of the base.
struct ShellBoundary {
  Eigen::MatrixXi F;              ///< rows: m base faces, then m top faces, then the walls
  std::vector<BoundaryPart> part; ///< per row of F
  /// Per row of F: the base face it belongs to (for a wall triangle, the face owning the
  /// boundary edge it stands on).
  std::vector<int> face;

  int size() const { return static_cast<int>(F.rows()); }
};

/// The boundary surface of the shell over base faces F (m x 3, counter-clockwise, n vertices).
/// Row f is base face f reversed, row m + f top face f (ids + n). Every base edge with a single
/// face, running i -> j in that face, adds the quad base i, base j, top j, top i, cut along the
/// same diagonal as the prism tets (base(min) - top(max), build_prism_tets), as two triangles
/// in the order the boundary edges first appear in F.
/// \throws InputError when F is not m x 3, an index is outside [0, n) or a face repeats an index.
ShellBoundary shell_boundary(const Eigen::MatrixXi& F, int n);

} // namespace gshell
