#pragma once
// Vertex normals averaged over a neighbourhood of a given radius: the direction generation starts
// its top from (docs/scale.md, "A start smoothed at the layer's scale").
//
// The rigid-prism optimum does not follow the base's normals below the scale of the thickness: a
// tall prism on a small face is sheared by any turn of the normal across it, so the optimal top
// is the base's normal field averaged over about the layer's thickness. Local/global iterations
// spread such an average by about one face per iteration, so an offset start along the raw
// normals costs iterations that grow with thickness / edge length (bunny00 split twice, 603K
// vertices at thickness ratio 0.02: 16 paper iterations from the raw normals, 7 from normals
// smoothed over 0.3 of the thickness).
#include <gshell/eigen_abi.h>
#include <Eigen/Core>

namespace gshell {

struct NormalSmoothing {
  int iterations = 0;  ///< conjugate-gradient iterations taken (0 where the normals were smooth already)
};

/// Unit vertex normals after one implicit diffusion step of time radius^2 from the area-weighted
/// ones (vertex_normals): (M + radius^2 L) N = M N0, with M the lumped vertex areas and L the graph
/// Laplacian whose edge weights are (2/3) area / length^2 per incident face (positive on any mesh,
/// the cotangent Laplacian on a regular one), solved by Jacobi-preconditioned CG warm-started at N0
/// to a relative residual of 1e-2 (a start needs no more), then normalised. A vertex whose average
/// nearly cancels (the two sides of a thin sheet meeting at it) keeps its own normal. Where the
/// normals already meet that test (radius = 0, or smooth at this radius) the result is
/// vertex_normals exactly, found without building the iteration. Isolated vertices get a zero
/// normal.
/// \throws InputError when V is not n x 3, F not m x 3 with ids in [0, n), or radius is negative
///         or not finite.
Eigen::MatrixXd smoothed_vertex_normals(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double radius,
                                        NormalSmoothing* stats = nullptr);

} // namespace gshell
