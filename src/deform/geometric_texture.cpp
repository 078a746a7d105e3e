#include <gshell/deform/geometric_texture.h>

#include <gshell/deform/embedding.h>
#include <gshell/error.h>
#include <gshell/geometry/weld_vertices.h>
#include <gshell/shell/prism_tets.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

namespace gshell {

namespace {

double signed_volume(const Eigen::MatrixXd& X, const Eigen::RowVector4i& tet) {
  const Eigen::Vector3d a = X.row(tet(0)), b = X.row(tet(1)), c = X.row(tet(2)), d = X.row(tet(3));
  return (b - a).cross(c - a).dot(d - a);
}

void check_tiling(const TriMesh& tile, int repeat_u, int repeat_v) {
  if (repeat_u < 1 || repeat_v < 1) throw InputError("repeat needs two counts >= 1");
  // Meshes index their vertices with int: a count beyond that cannot be written, however much
  // memory there is (bumps:1000 tiled 200 x 200 asked for 4e10 vertices).
  const double copies = static_cast<double>(repeat_u) * repeat_v;
  const double vertices = copies * tile.num_vertices(), faces = copies * tile.num_faces();
  if (std::max({copies, vertices, faces}) > std::numeric_limits<int>::max()) {
    char what[200];
    std::snprintf(what, sizeof what,
                  "%d x %d tiles of %d vertices and %d faces make %.3g vertices and %.3g faces, more than a mesh "
                  "can hold (%d): use fewer repeats or a coarser tile",
                  repeat_u, repeat_v, tile.num_vertices(), tile.num_faces(), vertices, faces,
                  std::numeric_limits<int>::max());
    throw InputError(what);
  }
}

} // namespace

TextureSpaceTets texture_space_tets(const Eigen::MatrixXi& F, const Eigen::MatrixXd& UV, const Eigen::MatrixXi& FUV) {
  const int k = static_cast<int>(UV.rows());
  TextureSpaceTets out;
  out.X.resize(2 * k, 3);
  out.X.topLeftCorner(k, 2) = UV;
  out.X.bottomLeftCorner(k, 2) = UV;
  out.X.topRightCorner(k, 1).setZero();
  out.X.bottomRightCorner(k, 1).setOnes();
  // Corners come from the base's vertex ids (the min-index rule), so tet t here and shell tet t
  // are the same cut of the same prism, whatever the UV ids are.
  const Eigen::MatrixXi corners = prism_tet_corners(F);
  out.T.resize(corners.rows(), 4);
  for (Eigen::Index t = 0; t < corners.rows(); ++t) {
    const Eigen::Index f = t / 3;
    for (int c = 0; c < 4; ++c) {
      const int corner = corners(t, c);
      out.T(t, c) = corner < 3 ? FUV(f, corner) : k + FUV(f, corner - 3);
    }
  }
  return out;
}

TriMesh tile_texture_space(const TriMesh& tile, int repeat_u, int repeat_v, const Eigen::Vector2d& uv_min,
                           const Eigen::Vector2d& uv_max) {
  check_tiling(tile, repeat_u, repeat_v);
  const int copies = repeat_u * repeat_v;
  const int nv = tile.num_vertices(), nf = tile.num_faces();
  TriMesh out;
  out.V.resize(static_cast<Eigen::Index>(copies) * nv, 3);
  out.F.resize(static_cast<Eigen::Index>(copies) * nf, 3);
  const Eigen::Vector2d size = uv_max - uv_min;
  int copy = 0;
  for (int j = 0; j < repeat_v; ++j)
    for (int i = 0; i < repeat_u; ++i, ++copy) {
      for (int v = 0; v < nv; ++v) {
        const Eigen::Index r = static_cast<Eigen::Index>(copy) * nv + v;
        out.V(r, 0) = uv_min.x() + size.x() * (i + tile.V(v, 0)) / repeat_u;
        out.V(r, 1) = uv_min.y() + size.y() * (j + tile.V(v, 1)) / repeat_v;
        out.V(r, 2) = tile.V(v, 2);
      }
      out.F.middleRows(static_cast<Eigen::Index>(copy) * nf, nf) = tile.F.array() + copy * nv;
    }
  if (tile.has_uv()) { // each copy has the tile's own texture coordinates: a tile's image repeats with it
    const int nt = static_cast<int>(tile.UV.rows());
    out.UV = tile.UV.replicate(copies, 1);
    out.FUV.resize(out.F.rows(), 3);
    for (int c = 0; c < copies; ++c)
      out.FUV.middleRows(static_cast<Eigen::Index>(c) * nf, nf) = tile.FUV.array() + c * nt;
  }
  return out;
}

GeometricTexture map_geometric_texture(const Shell& shell, const TriMesh& uv_source, const TriMesh& tile,
                                       int repeat_u, int repeat_v) {
  check_tiling(tile, repeat_u, repeat_v);
  if (!uv_source.has_uv()) throw InputError("the shell's base has no texture coordinates (OBJ vt)");
  if (uv_source.F.rows() != shell.F.rows() || uv_source.F != shell.F)
    throw InputError("the UV mesh's faces differ from the shell's");
  if (tile.num_vertices() == 0 || tile.num_faces() == 0) throw InputError("the tile is empty");
  if (!tile.V.allFinite()) throw InputError("the tile has a non-finite coordinate");
  if (tile.F.minCoeff() < 0 || tile.F.maxCoeff() >= tile.num_vertices())
    throw InputError("the tile has a face index out of range");
  if (!uv_source.UV.allFinite()) throw InputError("the base has a non-finite texture coordinate");
  const TextureSpaceTets tex = texture_space_tets(shell.F, uv_source.UV, uv_source.FUV);
  GeometricTexture out;
  out.uv_min = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  out.uv_max = -out.uv_min;
  for (Eigen::Index f = 0; f < uv_source.FUV.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector2d uv = uv_source.UV.row(uv_source.FUV(f, c)).transpose();
      out.uv_min = out.uv_min.cwiseMin(uv);
      out.uv_max = out.uv_max.cwiseMax(uv);
    }
  const TriMesh tiled = tile_texture_space(tile, repeat_u, repeat_v, out.uv_min, out.uv_max);

  Embedding e;
  try {
    e = embed_points(tex.X, tex.T, tiled.V);
  } catch (const InputError&) {
    throw InputError("every UV triangle of the base is degenerate");
  }
  const Eigen::MatrixXi shell_tets = build_prism_tets(shell.F, shell.num_base_vertices());
  const Eigen::MatrixXd X = shell.vertices();
  // Where a texture tet and its shell tet have opposite orientations (a mirrored UV island: its
  // UV triangles wound against their faces), the map turns what it carries inside out.
  std::vector<char> reverses(e.size());
  for (int p = 0; p < e.size(); ++p) {
    const int t = e.tet(p);
    e.vertices.row(p) = shell_tets.row(t);
    reverses[p] = signed_volume(tex.X, tex.T.row(t)) * signed_volume(X, shell_tets.row(t)) < 0;
  }

  TriMesh mapped = tiled;
  mapped.V = carry(e, X);
  // A face most of whose corners the map reverses is wound the other way round, so that it keeps
  // the side it faces in the tile (outwards, for a closed tile): the map reverses the whole face.
  for (Eigen::Index f = 0; f < mapped.F.rows(); ++f) {
    if (reverses[mapped.F(f, 0)] + reverses[mapped.F(f, 1)] + reverses[mapped.F(f, 2)] < 2) continue;
    ++out.reversed_faces;
    std::swap(mapped.F(f, 1), mapped.F(f, 2));
    if (mapped.has_uv()) std::swap(mapped.FUV(f, 1), mapped.FUV(f, 2));
  }
  // Neighbouring copies share the points of their common border, which map to one position: joined
  // there, the tiles make one surface instead of a patch per tile. Only points on the tile's
  // border are: a tile's own coincident points inside it (two triangles touching at a corner, a
  // deliberate cut) stay apart, as in the tile. Where a UV seam cuts the layout (around a
  // cylinder: u = 0 and u = 1), the two sides' points map through different texture tets to one
  // position up to rounding, which grows with the coordinates (a torus 1e5 from the origin: its
  // seam points 1.5e-11 apart), hence a tolerance of the output's size or its farthest
  // coordinate, whichever is larger.
  const int nv = tile.num_vertices();
  std::vector<char> on_tile_border(mapped.V.rows());
  const auto at_edge = [](double x) { return std::abs(x) < 1e-9 || std::abs(x - 1) < 1e-9; };
  for (Eigen::Index p = 0; p < mapped.V.rows(); ++p)
    on_tile_border[p] = at_edge(tile.V(p % nv, 0)) || at_edge(tile.V(p % nv, 1));
  const double diagonal = (mapped.V.colwise().maxCoeff() - mapped.V.colwise().minCoeff()).norm();
  const double size = std::max(diagonal, mapped.V.cwiseAbs().maxCoeff());
  out.mesh = weld_boundary_vertices(mapped, &out.joined, &out.vertex_of_point, 1e-12 * size, on_tile_border);
  out.points = e.size();
  out.outside = static_cast<int>(e.outside.size());
  out.max_outside_distance = e.max_outside_distance;
  return out;
}

// Every builtin: spec, so that one that is not a tile (builtin:sphere) is named as such by
// make_builtin_tile instead of being read as a file of an unknown format.
bool is_builtin_tile(const std::string& spec) { return spec.rfind("builtin:", 0) == 0; }

TriMesh make_builtin_tile(const std::string& spec) {
  int res = 16;
  if (spec != "builtin:bumps") {
    const std::string prefix = "builtin:bumps:";
    std::size_t used = 0;
    const std::string number = spec.rfind(prefix, 0) == 0 ? spec.substr(prefix.size()) : std::string();
    try {
      res = std::stoi(number, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (number.empty() || used != number.size())
      throw InputError(spec + ": unknown tile (built-in tiles: builtin:bumps[:N])");
    if (res < 1 || res > 1024) throw InputError(spec + ": tile resolution must be in 1..1024");
  }
  TriMesh tile;
  tile.V.resize((res + 1) * (res + 1), 3);
  for (int j = 0; j <= res; ++j)
    for (int i = 0; i <= res; ++i) {
      const double x = static_cast<double>(i) / res, y = static_cast<double>(j) / res;
      const double sx = std::sin(std::numbers::pi * x), sy = std::sin(std::numbers::pi * y);
      tile.V.row(j * (res + 1) + i) << x, y, 0.1 + 0.8 * sx * sx * sy * sy;
    }
  tile.F.resize(2 * res * res, 3);
  for (int j = 0; j < res; ++j)
    for (int i = 0; i < res; ++i) {
      const int a = j * (res + 1) + i, b = a + 1, c = a + res + 1, d = c + 1;
      tile.F.row(2 * (j * res + i)) << a, b, d;
      tile.F.row(2 * (j * res + i) + 1) << a, d, c;
    }
  return tile;
}

} // namespace gshell
