#pragma once
// Meshes generated in code, so demos and tests need no files. Spec strings: `builtin:NAME[:RES]`.
#include <gshell/mesh.h>
#include <string>

namespace gshell {

/// Icosphere: the icosahedron subdivided `level` times (4x faces per level) and projected onto
/// the sphere. level 0 = 12 vertices; default level 4 = 2562 vertices. Closed, genus 0.
TriMesh make_sphere(int level = 4, double radius = 1.0);

/// Torus around the z axis with `res` segments around the big circle and res/2 around the tube.
/// Radii R=1, r=0.4 by default. Closed, genus 1. UVs along both circles.
TriMesh make_torus(int res = 64, double major_radius = 1.0, double minor_radius = 0.4);

/// Open square patch [-1,1]^2 in the z=0 plane, res x res quads split into triangles, normal +z.
/// UV = (x+1)/2, (y+1)/2.
TriMesh make_plane(int res = 32, double half_size = 1.0);

/// Open tube around the z axis, radius 1 and height 2 (z in [-1,1]), `res` segments around and
/// proportional rows along, outward normals. UV = (angle/2pi, (z+1)/2) with a seam column.
TriMesh make_cylinder(int res = 64, double radius = 1.0, double height = 2.0);

/// Open hemisphere (bowl) z <= 0 of radius 1, `res` rings; normals point outwards.
TriMesh make_bowl(int res = 32, double radius = 1.0);

/// True for strings starting with "builtin:".
bool is_builtin_spec(const std::string& spec);

/// Builds the mesh named by a spec such as "builtin:sphere" or "builtin:torus:96".
/// Throws InputError on an unknown name or bad resolution.
TriMesh make_builtin(const std::string& spec);

} // namespace gshell
