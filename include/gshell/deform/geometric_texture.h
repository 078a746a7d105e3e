#pragma once
// Geometric texture through the shell map (paper §4.1 Fig. 5; docs/design.md "Embedded
// detail and geometric textures").
// Texture space: (u, v, h) with (u, v) the base's texture coordinates and h in [0,1] the height
// in the shell (0 = base, 1 = top). Over each UV triangle stands the texture-space prism
// UV triangle x [0,1], cut into 3 tets by the same min-index rule as the shell's prism, so
// texture tet t corresponds to shell tet t and maps to it affinely.
#include <gshell/mesh.h>
#include <gshell/shell/shell.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <string>
#include <vector>

namespace gshell {

/// The texture-space prisms of a mesh with UVs: 2k points (UV id u at height 0 is point u, at
/// height 1 point k+u) and 3m tets, row t matching build_prism_tets(F, n) row t vertex by vertex.
struct TextureSpaceTets {
  Eigen::MatrixXd X; ///< 2k x 3: (u, v, h)
  Eigen::MatrixXi T; ///< 3m x 4
};
TextureSpaceTets texture_space_tets(const Eigen::MatrixXi& F, const Eigen::MatrixXd& UV, const Eigen::MatrixXi& FUV);

/// repeat_u x repeat_v copies of a tile (x, y in [0,1], z = height) laid side by side over the
/// rectangle `uv_min`..`uv_max` of texture space; copy (i, j) covers
/// [i/U, (i+1)/U] x [j/V, (j+1)/V] of that rectangle. Heights are kept; the tile's texture
/// coordinates, if it has any, are every copy's (corner by corner). \throws InputError when a
/// repeat count is below 1 or the copies would hold more vertices or faces than an int indexes.
TriMesh tile_texture_space(const TriMesh& tile, int repeat_u, int repeat_v, const Eigen::Vector2d& uv_min,
                           const Eigen::Vector2d& uv_max);

struct GeometricTexture {
  /// The tiled texture mapped into the shell, with the tile's texture coordinates; copies that
  /// meet are joined (weld_boundary_vertices)
  TriMesh mesh;
  int points = 0;                  ///< tiled vertices mapped (before the join)
  int joined = 0;                  ///< of them, removed by the join: border points of neighbouring copies
  /// Per tiled vertex (copy c = i + j * repeat_u holds tile vertex v at c * tile vertices + v),
  /// its vertex in `mesh`.
  std::vector<int> vertex_of_point;
  /// Faces wound the other way round from the tile's, to face as they do in the tile: those over
  /// mirrored UV islands (UV triangles wound against their faces), which the map turns inside out.
  int reversed_faces = 0;
  int outside = 0;                 ///< of them, outside every texture-space prism (extrapolated from the nearest tet)
  double max_outside_distance = 0; ///< in texture-space units
  Eigen::Vector2d uv_min = Eigen::Vector2d::Zero(), uv_max = Eigen::Vector2d::Ones(); ///< the tiled UV rectangle
};

/// Tiles `tile` repeat_u x repeat_v times over the bounding rectangle of the base's UVs
/// (`uv_source` has the shell's faces and vertex count, with UV/FUV; see read_shell_folder), maps
/// every tiled vertex tet by tet into the shell, winds faces the map reverses the other way round
/// and joins the border points that neighbouring copies share (any boundary vertices of the
/// result within 1e-12 of its bounding box diagonal of each other: a tile whose borders match
/// gives one surface, closed across the layout's UV seams where the base is).
/// \throws InputError when the base has no UVs or a non-finite one, its faces differ from the
///         shell's, every UV triangle is degenerate, the tile is empty, non-finite or has a face
///         id out of range, a repeat count is < 1, or the tiles would hold more vertices or
///         faces than an int indexes.
GeometricTexture map_geometric_texture(const Shell& shell, const TriMesh& uv_source, const TriMesh& tile,
                                       int repeat_u = 1, int repeat_v = 1);

/// Built-in tiles for tests and demos: "builtin:bumps[:N]" is an N x N height-field grid
/// (default 16) over [0,1]^2 with z = 0.1 + 0.8 sin^2(pi x) sin^2(pi y): one round bump per tile,
/// equal heights along the tile's edges so neighbouring tiles join without gaps.
/// is_builtin_tile is true for every "builtin:" spec; make_builtin_tile refuses those that are not
/// tiles.
bool is_builtin_tile(const std::string& spec);
/// \throws InputError naming `spec` when it is not builtin:bumps[:N] with N in 1..1024.
TriMesh make_builtin_tile(const std::string& spec);

} // namespace gshell
