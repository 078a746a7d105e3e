#pragma once
// Meshes generated in code, so demos and tests need no files. Spec strings: `builtin:NAME[:RES]`.
//
//   spec               RES means                                  default  vertices (default)
//   builtin:sphere     subdivision level of the icosahedron       4        10*4^RES+2 (2562)
//   builtin:torus      segments around the big circle (RES/2      64       RES*(RES/2) (2048)
//                      around the tube)
//   builtin:plane      quads along each side                       32       (RES+1)^2 (1089)
//   builtin:cylinder   segments around (rows along: round(RES/pi)) 64       RES*(round(RES/pi)+1) (1344)
//   builtin:bowl       rings from the bottom pole to the rim       40       ~2.6*RES^2 (4155)
//
// Allowed RES ranges are in builtin_resolution_range(). Every face is counter-clockwise seen from
// the outside (outward normals); open meshes are oriented as stated per function.
#include <gshell/mesh.h>
#include <string>
#include <utility>

namespace gshell {

/// Icosphere: the icosahedron subdivided `level` times (4x faces per level) and projected onto
/// the sphere. level 0 = 12 vertices; default level 4 = 2562 vertices. Closed, genus 0. No UVs.
/// \throws InputError naming the parameter when level is outside builtin_resolution_range("sphere") or
///         radius is not a positive finite number.
TriMesh make_sphere(int level = 4, double radius = 1.0);

/// `mesh` with every face split into four at its edges' midpoints, `times` times over (the surface
/// unchanged, 4x the faces each time; texture coordinates are dropped). The split make_sphere
/// uses, without its projection onto the sphere.
/// \throws InputError when times < 0.
TriMesh midpoint_subdivision(const TriMesh& mesh, int times);

/// Torus around the z axis with `res` segments around the big circle and res/2 (integer division)
/// around the tube: res*(res/2) vertices. Radii R=1, r=0.4 by default. Closed, genus 1.
/// UV = (angle around z / 2pi, angle around the tube / 2pi), with seams (UV grid (res+1) x (res/2+1)).
/// \throws InputError naming the parameter when res is outside builtin_resolution_range("torus") or
///         a radius is not a positive finite number.
TriMesh make_torus(int res = 64, double major_radius = 1.0, double minor_radius = 0.4);

/// Open square patch [-h,h]^2 (h = half_size) in the z=0 plane, res x res quads split into
/// triangles, normal +z: (res+1)^2 vertices, 2 res^2 faces. UV = ((x+h)/2h, (y+h)/2h).
/// \throws InputError naming the parameter when res is outside builtin_resolution_range("plane") or
///         half_size is not a positive finite number.
TriMesh make_plane(int res = 32, double half_size = 1.0);

/// Open tube around the z axis (z in [-height/2, height/2]), `res` segments around and
/// rows = max(1, round(res*height / (2 pi radius))) rows along (round(res/pi) for the defaults), so
/// the quads are near square: res*(rows+1) vertices, shared across the seam (one connected
/// manifold). Normals point away from the axis. UV = (angle/2pi, (z + height/2)/height); the UV grid
/// has an extra seam column (res+1 columns).
/// \throws InputError naming the parameter when res is outside builtin_resolution_range("cylinder") or
///         radius or height is not a positive finite number.
TriMesh make_cylinder(int res = 64, double radius = 1.0, double height = 2.0);

/// Open hemisphere (bowl) z <= 0 of radius `radius` centred at the origin, rim at z = 0: `res`
/// rings of latitude from the bottom pole to the rim, equally spaced in angle, each ring with
/// about as many segments as make near-equilateral triangles (~2.6 res^2 vertices; the default
/// res = 40 gives 4155 vertices, so a shell over it has ~8.3K vertices like the paper's basket).
/// Normals point away from the sphere's centre (the convex side). UV: azimuthal equidistant
/// map of the hemisphere onto the disk of radius 1/2 around (1/2, 1/2) (pole at the centre).
/// \throws InputError naming the parameter when res is outside builtin_resolution_range("bowl") or
///         radius is not a positive finite number.
TriMesh make_bowl(int res = 40, double radius = 1.0);

/// True for strings starting with "builtin:".
bool is_builtin_spec(const std::string& spec);

/// Inclusive range of RES accepted by make_builtin for `name` ("sphere", "torus", ...).
/// \throws InputError for an unknown name.
std::pair<int, int> builtin_resolution_range(const std::string& name);

/// Builds the mesh named by a spec such as "builtin:sphere" or "builtin:torus:96".
/// \throws InputError ("SPEC: problem") on an unknown name or a bad resolution (not an integer,
/// out of the range above).
TriMesh make_builtin(const std::string& spec);

} // namespace gshell
