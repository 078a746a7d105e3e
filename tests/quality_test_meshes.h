#pragma once
// Small meshes built by hand for the quality tests (independent of the builtin generators).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <map>
#include <utility>
#include <vector>

namespace gshell::test {

struct HandMesh {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
};

/// Icosahedron subdivided `level` times, vertices projected on the sphere of `radius` at `centre`;
/// outward-facing faces, closed and welded.
inline HandMesh icosphere(int level, double radius = 1.0,
                          const Eigen::Vector3d& centre = Eigen::Vector3d::Zero()) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> v = {{-1, t, 0}, {1, t, 0},  {-1, -t, 0}, {1, -t, 0},
                                    {0, -1, t}, {0, 1, t},  {0, -1, -t}, {0, 1, -t},
                                    {t, 0, -1}, {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  std::vector<Eigen::Vector3i> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                    {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                    {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                    {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& p : v) p.normalize();
  for (int l = 0; l < level; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      return mid[key] = static_cast<int>(v.size()) - 1;
    };
    std::vector<Eigen::Vector3i> next;
    for (const auto& tri : f) {
      const int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
      next.push_back({tri[0], a, c});
      next.push_back({tri[1], b, a});
      next.push_back({tri[2], c, b});
      next.push_back({a, b, c});
    }
    f = std::move(next);
  }
  HandMesh m;
  m.V.resize(static_cast<Eigen::Index>(v.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i) m.V.row(i) = (centre + radius * v[i]).transpose();
  m.F.resize(static_cast<Eigen::Index>(f.size()), 3);
  for (std::size_t i = 0; i < f.size(); ++i) m.F.row(i) = f[i].transpose();
  return m;
}

/// Square [-s, s]^2 in the plane z = 0 split into res x res quads, two triangles each.
inline HandMesh grid_plane(int res, double s = 1.0) {
  HandMesh m;
  m.V.resize((res + 1) * (res + 1), 3);
  for (int j = 0; j <= res; ++j)
    for (int i = 0; i <= res; ++i)
      m.V.row(j * (res + 1) + i) << -s + 2 * s * i / res, -s + 2 * s * j / res, 0.0;
  m.F.resize(2 * res * res, 3);
  int k = 0;
  for (int j = 0; j < res; ++j)
    for (int i = 0; i < res; ++i) {
      const int a = j * (res + 1) + i, b = a + 1, c = a + res + 1, d = c + 1;
      m.F.row(k++) << a, b, d;
      m.F.row(k++) << a, d, c;
    }
  return m;
}

} // namespace gshell::test
