#pragma once
// Internal: the parts of a base too small for the layer asked of them. Generation's thickness is
// one number for the whole mesh (a ratio of its bounding radius); a stray part of a scan (debris a
// thousandth of the model's size) then gets prisms hundreds of times its own size. No top near its
// own ideal prisms exists there: the paper's iterations fold it, the valid start presses it back
// nearly onto its base, and a repair that tries to lift it again has every boundary pair of the
// part inside its contact support (all pairs against all, at up to 20 s per iteration beside
// CGAL's elephant). Such parts keep the valid start's layer (docs/guarded-generation.md, "A tiny
// part beside a large one").
#include <Eigen/Core>

#include <vector>

namespace gshell::detail {

/// Vertices (ascending) of the connected parts of (V, F) whose bounding radius (about their own
/// bounding-box centre, as thickness ratios measure a mesh) is below `radius` (model units).
/// Vertices of no face belong to no part. Precondition: F's ids in [0, V.rows()).
std::vector<int> small_part_vertices(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double radius);

} // namespace gshell::detail
