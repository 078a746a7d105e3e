#pragma once
// Principal curvatures from the normal-cycle curvature tensor (Cohen-Steiner & Morvan 2003),
// as the curvature-sensitive ideal prisms need them (paper §4.1; docs/design.md "Principal
// curvatures").
//
// Tensor of a region B (a set of triangles):
//   T(B) = 1/area(B) * sum_edges beta(e) |e ∩ B| e_hat e_hat^T
// beta(e) = signed dihedral angle between the normals of e's two faces: positive where the
// surface is convex seen from the side the normals point to (a sphere with outward normals has
// beta > 0 everywhere). Boundary and non-manifold edges contribute nothing. An edge on the border
// of B counts with half its length (B's border runs along it: each of an edge's two faces owns
// one half), so T(B) is the area-weighted mean of per-face tensors and needs no edge bookkeeping.
//
// T is projected onto the tangent plane (the face's plane, or the plane orthogonal to the
// vertex normal). Its eigenvector with the largest |eigenvalue| is the direction of MINIMUM
// curvature: the edges along which the surface bends are orthogonal to the bending direction
// (a cylinder's bent edges run along its axis). So the curvature along one eigenvector is the
// other eigenvector's eigenvalue.
//
// Units: curvatures in 1/(model units), signed with the convention above (kappa_1 >= kappa_2);
// directions are unit vectors in the tangent plane, e_1 ⟂ e_2, and e_1 x e_2 points along the
// normal (a right-handed frame (e_1, e_2, n)). Directions are defined up to sign; where
// kappa_1 == kappa_2 (umbilic) they are an arbitrary orthonormal pair.
#include <gshell/eigen_abi.h>
#include <Eigen/Core>

namespace gshell {

/// Principal curvatures and directions, one row / entry per element (face or vertex).
struct PrincipalCurvatures {
  Eigen::VectorXd k1;  ///< larger principal curvature (signed)
  Eigen::VectorXd k2;  ///< smaller principal curvature (signed), k2 <= k1
  Eigen::MatrixXd e1;  ///< rows: unit direction of k1 in the tangent plane
  Eigen::MatrixXd e2;  ///< rows: unit direction of k2 in the tangent plane

  Eigen::VectorXd mean() const { return 0.5 * (k1 + k2); }      ///< (k1 + k2) / 2
  Eigen::VectorXd gaussian() const { return k1.cwiseProduct(k2); } ///< k1 * k2
};
using FaceCurvature = PrincipalCurvatures;
using VertexCurvature = PrincipalCurvatures;

/// Size of the averaging region B, in rings of triangles. The k-ring of a face or vertex is the
/// set of triangles touching a vertex within k-1 edges of the element's own vertices: a face's
/// 1-ring is every face sharing a vertex with it, a vertex's 1-ring is its fan of faces, and each
/// further ring adds one layer. The paper averages over a face's 2-ring (about 37 faces on a
/// regular mesh); a vertex's 2-ring is about 24 faces.
struct CurvatureOptions {
  int face_rings = 2;   ///< >= 1
  int vertex_rings = 2; ///< >= 1
};

/// Per-face curvature: tensor averaged over the face's `face_rings`-ring of triangles, projected
/// onto the face's plane. Zero-area faces get zero curvature.
/// \throws InputError when V is not n x 3, F not m x 3, a face index is out of range or
///         options.face_rings < 1.
FaceCurvature face_curvature(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                             const CurvatureOptions& options = {});

/// Per-vertex curvature: tensor averaged over the vertex's `vertex_rings`-ring of triangles,
/// projected onto the plane orthogonal to the area-weighted vertex normal. Vertices without faces
/// get zero curvature.
/// \throws InputError when V is not n x 3, F not m x 3, a face index is out of range or
///         options.vertex_rings < 1.
VertexCurvature vertex_curvature(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                 const CurvatureOptions& options = {});

} // namespace gshell
