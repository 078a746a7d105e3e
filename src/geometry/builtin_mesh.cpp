#include <gshell/geometry/builtin_mesh.h>

#include <gshell/error.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <numbers>
#include <unordered_map>
#include <vector>

namespace gshell {
namespace {

constexpr double kPi = std::numbers::pi;

using Rows3d = std::vector<Eigen::Vector3d>;
using Rows3i = std::vector<Eigen::Vector3i>;

Eigen::MatrixXd to_matrix(const Rows3d& rows) {
  Eigen::MatrixXd M(static_cast<Eigen::Index>(rows.size()), 3);
  for (size_t i = 0; i < rows.size(); ++i) M.row(static_cast<Eigen::Index>(i)) = rows[i].transpose();
  return M;
}

Eigen::MatrixXi to_matrix(const Rows3i& rows) {
  Eigen::MatrixXi M(static_cast<Eigen::Index>(rows.size()), 3);
  for (size_t i = 0; i < rows.size(); ++i) M.row(static_cast<Eigen::Index>(i)) = rows[i].transpose();
  return M;
}

/// Vertex id of grid node (i, j) in a grid with `columns` columns, row-major.
int grid_id(int i, int j, int columns) { return j * columns + i; }

/// Splits the quad (i,j)-(i+1,j)-(i+1,j+1)-(i,j+1) into two triangles with the same winding.
// The generators' parameters are the caller's: a resolution outside builtin_resolution_range or a
// size that is not a positive finite number is an InputError naming the parameter.
void check_parameters(const char* name, const char* res_name, int res,
                      std::initializer_list<std::pair<const char*, double>> sizes) {
  const auto [lo, hi] = builtin_resolution_range(name);
  if (res < lo || res > hi)
    throw InputError(std::string("make_") + name + ": " + res_name + " " + std::to_string(res) + " is out of range [" +
                     std::to_string(lo) + ", " + std::to_string(hi) + "]");
  for (const auto& [size_name, value] : sizes)
    if (!(value > 0) || !std::isfinite(value))
      throw InputError(std::string("make_") + name + ": " + size_name + " must be a positive finite number (got " +
                       std::to_string(value) + ")");
}

void add_quad(Rows3i& faces, int a, int b, int c, int d) {
  faces.emplace_back(a, b, c);
  faces.emplace_back(a, c, d);
}

// Faces of a grid of nu x rows quads whose vertex (i, j) is grid_id(i, j, nu), closed around in i
// (and in j when `wrap_rows`; otherwise the grid has rows + 1 vertex rows), and the same quads
// over the UV grid, which repeats the seam column (nu + 1 columns) and row.
void set_wrapped_grid_faces(TriMesh& mesh, int nu, int rows, bool wrap_rows) {
  Rows3i faces, uv_faces;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < nu; ++i) {
      const int i1 = (i + 1) % nu, j1 = wrap_rows ? (j + 1) % rows : j + 1;
      add_quad(faces, grid_id(i, j, nu), grid_id(i1, j, nu), grid_id(i1, j1, nu), grid_id(i, j1, nu));
      add_quad(uv_faces, grid_id(i, j, nu + 1), grid_id(i + 1, j, nu + 1), grid_id(i + 1, j + 1, nu + 1),
               grid_id(i, j + 1, nu + 1));
    }
  }
  mesh.F = to_matrix(faces);
  mesh.FUV = to_matrix(uv_faces);
}

/// Splits every face of (v, f) into four at its edges' midpoints, one new vertex per edge shared
/// by the edge's faces, placed by `place(a, b)` (a, b: the edge's vertex ids).
template <typename Place>
void split_at_edge_midpoints(Rows3d& v, Rows3i& f, Place&& place) {
  std::unordered_map<std::uint64_t, int> midpoint;
  midpoint.reserve(f.size() * 2);
  auto mid = [&](int a, int b) {
    const auto key = (static_cast<std::uint64_t>(std::min(a, b)) << 32) | static_cast<std::uint32_t>(std::max(a, b));
    auto [it, inserted] = midpoint.try_emplace(key, static_cast<int>(v.size()));
    if (inserted) v.push_back(place(a, b));
    return it->second;
  };
  Rows3i next;
  next.reserve(f.size() * 4);
  for (const auto& tri : f) {
    const int a = tri[0], b = tri[1], c = tri[2];
    const int ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
    next.emplace_back(a, ab, ca);
    next.emplace_back(b, bc, ab);
    next.emplace_back(c, ca, bc);
    next.emplace_back(ab, bc, ca);
  }
  f = std::move(next);
}

} // namespace

TriMesh make_sphere(int level, double radius) {
  check_parameters("sphere", "level", level, {{"radius", radius}});
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  Rows3d v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
              {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  Rows3i f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
              {11, 10, 2}, {10, 7, 6}, {7, 1, 8},   {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
              {3, 8, 9},  {4, 9, 5},  {2, 4, 11},  {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (auto& p : v) p.normalize();
  for (int l = 0; l < level; ++l)
    split_at_edge_midpoints(v, f, [&](int a, int b) -> Eigen::Vector3d { return (v[a] + v[b]).normalized(); });
  // The icosahedron list above is trusted for nothing: orient every face away from the centre.
  for (auto& tri : f) {
    const Eigen::Vector3d n = (v[tri[1]] - v[tri[0]]).cross(v[tri[2]] - v[tri[0]]);
    if (n.dot(v[tri[0]] + v[tri[1]] + v[tri[2]]) < 0) std::swap(tri[1], tri[2]);
  }
  TriMesh mesh;
  mesh.V = to_matrix(v) * radius;
  mesh.F = to_matrix(f);
  return mesh;
}

TriMesh make_torus(int res, double major_radius, double minor_radius) {
  check_parameters("torus", "res", res, {{"major_radius", major_radius}, {"minor_radius", minor_radius}});
  const int nu = res, nv = res / 2;
  TriMesh mesh;
  mesh.V.resize(nu * nv, 3);
  mesh.UV.resize((nu + 1) * (nv + 1), 2);
  for (int j = 0; j <= nv; ++j) {
    for (int i = 0; i <= nu; ++i) {
      const double u = 2 * kPi * i / nu, w = 2 * kPi * j / nv;
      mesh.UV.row(grid_id(i, j, nu + 1)) << static_cast<double>(i) / nu, static_cast<double>(j) / nv;
      if (i < nu && j < nv) {
        const double ring = major_radius + minor_radius * std::cos(w);
        mesh.V.row(grid_id(i, j, nu)) << ring * std::cos(u), ring * std::sin(u), minor_radius * std::sin(w);
      }
    }
  }
  // d/du x d/dv points out of the tube, so (i,j) -> (i+1,j) -> (i+1,j+1) is counter-clockwise.
  set_wrapped_grid_faces(mesh, nu, nv, true);
  return mesh;
}

TriMesh make_plane(int res, double half_size) {
  check_parameters("plane", "res", res, {{"half_size", half_size}});
  const int n = res + 1;
  TriMesh mesh;
  mesh.V.resize(n * n, 3);
  mesh.UV.resize(n * n, 2);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const double s = static_cast<double>(i) / res, t = static_cast<double>(j) / res;
      mesh.V.row(grid_id(i, j, n)) << (2 * s - 1) * half_size, (2 * t - 1) * half_size, 0.0;
      mesh.UV.row(grid_id(i, j, n)) << s, t;
    }
  }
  Rows3i faces;
  for (int j = 0; j < res; ++j)
    for (int i = 0; i < res; ++i)
      add_quad(faces, grid_id(i, j, n), grid_id(i + 1, j, n), grid_id(i + 1, j + 1, n), grid_id(i, j + 1, n));
  mesh.F = to_matrix(faces);
  mesh.FUV = mesh.F;
  return mesh;
}

TriMesh make_cylinder(int res, double radius, double height) {
  check_parameters("cylinder", "res", res, {{"radius", radius}, {"height", height}});
  const int rows = std::max(1, static_cast<int>(std::lround(res * height / (2 * kPi * radius))));
  TriMesh mesh;
  mesh.V.resize(res * (rows + 1), 3);
  mesh.UV.resize((res + 1) * (rows + 1), 2);
  for (int j = 0; j <= rows; ++j) {
    const double t = static_cast<double>(j) / rows;
    for (int i = 0; i <= res; ++i) {
      const double s = static_cast<double>(i) / res;
      mesh.UV.row(grid_id(i, j, res + 1)) << s, t;
      if (i < res)
        mesh.V.row(grid_id(i, j, res)) << radius * std::cos(2 * kPi * s), radius * std::sin(2 * kPi * s),
            (t - 0.5) * height;
    }
  }
  // d/dangle x d/dz points away from the axis.
  set_wrapped_grid_faces(mesh, res, rows, false);
  return mesh;
}

TriMesh make_bowl(int res, double radius) {
  check_parameters("bowl", "res", res, {{"radius", radius}});
  // Ring k sits at polar angle theta_k = k*h from the bottom pole (h = (pi/2)/res) and gets about
  // 2 pi sin(theta_k) / h segments, so its triangles are close to equilateral. Odd rings are turned
  // by half a segment so that equal-count neighbour rings make equilateral rather than right triangles.
  const double h = (kPi / 2) / res;
  std::vector<int> count(res + 1, 1), first(res + 1, 0);
  std::vector<double> offset(res + 1, 0.0);
  int total = 0;
  for (int k = 0; k <= res; ++k) {
    if (k > 0) count[k] = std::max(3, static_cast<int>(std::lround(2 * kPi * std::sin(k * h) / h)));
    offset[k] = (k % 2) ? 0.5 : 0.0;
    first[k] = total;
    total += count[k];
  }
  TriMesh mesh;
  mesh.V.resize(total, 3);
  mesh.UV.resize(total, 2);
  for (int k = 0; k <= res; ++k) {
    const double theta = k * h;
    for (int j = 0; j < count[k]; ++j) {
      const double phi = 2 * kPi * (j + offset[k]) / count[k];
      const double z = k == res ? 0.0 : -radius * std::cos(theta); // rim exactly at z = 0
      mesh.V.row(first[k] + j) << radius * std::sin(theta) * std::cos(phi), radius * std::sin(theta) * std::sin(phi), z;
      // Mirrored in v because the outside of the bowl is seen from below: UV triangles stay
      // counter-clockwise like the faces.
      const double r = 0.5 * theta / (kPi / 2);
      mesh.UV.row(first[k] + j) << 0.5 + r * std::cos(phi), 0.5 - r * std::sin(phi);
    }
  }
  // Strip between ring k-1 (a, nearer the pole) and ring k (b): walk around both rings, always
  // advancing on the ring whose next vertex comes first in angle. With phi growing and theta
  // growing, (a_i, a_i+1, b_j) and (a_i, b_j+1, b_j) are counter-clockwise seen from outside.
  Rows3i faces;
  for (int k = 1; k <= res; ++k) {
    const int na = count[k - 1], nb = count[k];
    auto a = [&](int i) { return first[k - 1] + i % na; };
    auto b = [&](int j) { return first[k] + j % nb; };
    if (na == 1) {
      for (int j = 0; j < nb; ++j) faces.emplace_back(a(0), b(j + 1), b(j));
      continue;
    }
    int i = 0, j = 0;
    while (i < na || j < nb) {
      const double next_a = (i + 1 + offset[k - 1]) / na, next_b = (j + 1 + offset[k]) / nb;
      if (j == nb || (i < na && next_a < next_b)) {
        faces.emplace_back(a(i), a(i + 1), b(j));
        ++i;
      } else {
        faces.emplace_back(a(i), b(j + 1), b(j));
        ++j;
      }
    }
  }
  mesh.F = to_matrix(faces);
  mesh.FUV = mesh.F;
  return mesh;
}

bool is_builtin_spec(const std::string& spec) { return spec.rfind("builtin:", 0) == 0; }

std::pair<int, int> builtin_resolution_range(const std::string& name) {
  // Upper limits keep every builtin below a few million vertices.
  if (name == "sphere") return {0, 9};
  if (name == "torus") return {6, 2048};
  if (name == "plane") return {1, 2048};
  if (name == "cylinder") return {3, 2048};
  if (name == "bowl") return {2, 1024};
  throw InputError("unknown builtin mesh '" + name + "' (known: sphere, torus, plane, cylinder, bowl)");
}

TriMesh make_builtin(const std::string& spec) {
  if (!is_builtin_spec(spec)) throw InputError(with_file(spec, "not a builtin spec (builtin:NAME[:RES])"));
  const std::string rest = spec.substr(8);
  const auto colon = rest.find(':');
  const std::string name = rest.substr(0, colon);
  std::pair<int, int> range;
  try {
    range = builtin_resolution_range(name);
  } catch (const InputError& e) {
    throw InputError(with_file(spec, e.what()));
  }
  int res = -1;
  if (colon != std::string::npos) {
    const std::string text = rest.substr(colon + 1);
    const char* end = text.data() + text.size();
    auto [ptr, ec] = std::from_chars(text.data(), end, res);
    if (text.empty() || ec != std::errc() || ptr != end)
      throw InputError(with_file(spec, "resolution '" + text + "' is not an integer"));
    if (res < range.first || res > range.second)
      throw InputError(with_file(spec, "resolution " + text + " is out of range [" + std::to_string(range.first) +
                                           ", " + std::to_string(range.second) + "] for builtin:" + name));
  }
  if (name == "sphere") return res < 0 ? make_sphere() : make_sphere(res);
  if (name == "torus") return res < 0 ? make_torus() : make_torus(res);
  if (name == "plane") return res < 0 ? make_plane() : make_plane(res);
  if (name == "cylinder") return res < 0 ? make_cylinder() : make_cylinder(res);
  return res < 0 ? make_bowl() : make_bowl(res);
}

TriMesh midpoint_subdivision(const TriMesh& mesh, int times) {
  if (times < 0) throw InputError("midpoint_subdivision: times must be >= 0 (got " + std::to_string(times) + ")");
  // Each split makes 4x the faces: past an int's range the ids cannot be stored (40 splits of an
  // icosahedron ended in std::bad_alloc).
  if (static_cast<double>(mesh.F.rows()) * std::pow(4.0, times) > std::numeric_limits<int>::max())
    throw InputError("midpoint_subdivision: " + std::to_string(times) + " splits of " + std::to_string(mesh.F.rows()) +
                     " faces make more faces than a mesh can hold (" + std::to_string(std::numeric_limits<int>::max()) + ")");
  Rows3d v(mesh.V.rows());
  for (int i = 0; i < mesh.V.rows(); ++i) v[i] = mesh.V.row(i).transpose();
  Rows3i f(mesh.F.rows());
  for (int i = 0; i < mesh.F.rows(); ++i) f[i] = mesh.F.row(i).transpose();
  for (int t = 0; t < times; ++t)
    split_at_edge_midpoints(v, f, [&](int a, int b) -> Eigen::Vector3d { return 0.5 * (v[a] + v[b]); });
  TriMesh out;
  out.V = to_matrix(v);
  out.F = to_matrix(f);
  return out;
}

} // namespace gshell
