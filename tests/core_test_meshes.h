#pragma once
// Small meshes for the core tests, generated here so these tests need no other module.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>
#include <utility>
#include <vector>

namespace gshell::test {

struct SimpleMesh {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
};

inline SimpleMesh icosphere(int level, double radius = 1.0) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Eigen::Vector3d> v = {{-1, t, 0}, {1, t, 0},   {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                    {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
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
    std::vector<Eigen::Vector3i> g;
    for (const auto& tri : f) {
      const int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], a, c});
      g.push_back({tri[1], b, a});
      g.push_back({tri[2], c, b});
      g.push_back({a, b, c});
    }
    f = g;
  }
  SimpleMesh m;
  m.V.resize(v.size(), 3);
  for (std::size_t i = 0; i < v.size(); ++i) m.V.row(i) = radius * v[i].transpose();
  m.F.resize(f.size(), 3);
  for (std::size_t i = 0; i < f.size(); ++i) m.F.row(i) = f[i].transpose();
  return m;
}

inline SimpleMesh torus(int nu = 32, int nv = 16, double R = 1.0, double r = 0.4) {
  SimpleMesh m;
  m.V.resize(nu * nv, 3);
  m.F.resize(2 * nu * nv, 3);
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * M_PI * i / nu, w = 2 * M_PI * j / nv;
      m.V.row(i * nv + j) << (R + r * std::cos(w)) * std::cos(u), (R + r * std::cos(w)) * std::sin(u), r * std::sin(w);
    }
  int f = 0;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const int a = i * nv + j, b = ((i + 1) % nu) * nv + j, c = ((i + 1) % nu) * nv + (j + 1) % nv,
                d = i * nv + (j + 1) % nv;
      m.F.row(f++) << a, b, c; // outward normals
      m.F.row(f++) << a, c, d;
    }
  return m;
}

/// Open square [-1,1]^2 in z = 0 with normal +z; `wavy` bends it into a height field.
inline SimpleMesh plane(int res = 16, double wavy = 0.0) {
  SimpleMesh m;
  m.V.resize((res + 1) * (res + 1), 3);
  m.F.resize(2 * res * res, 3);
  for (int i = 0; i <= res; ++i)
    for (int j = 0; j <= res; ++j) {
      const double x = -1 + 2.0 * i / res, y = -1 + 2.0 * j / res;
      m.V.row(i * (res + 1) + j) << x, y, wavy * std::sin(2 * x) * std::cos(3 * y);
    }
  int f = 0;
  for (int i = 0; i < res; ++i)
    for (int j = 0; j < res; ++j) {
      const int a = i * (res + 1) + j, b = (i + 1) * (res + 1) + j, c = b + 1, d = a + 1;
      m.F.row(f++) << a, b, c;
      m.F.row(f++) << a, c, d;
    }
  return m;
}

/// Same surface with shuffled vertex ids and face order, and rotated face corners.
inline SimpleMesh permuted(const SimpleMesh& in, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<int> perm(in.V.rows());
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), rng);
  std::vector<int> forder(in.F.rows());
  std::iota(forder.begin(), forder.end(), 0);
  std::shuffle(forder.begin(), forder.end(), rng);
  SimpleMesh m;
  m.V.resize(in.V.rows(), 3);
  for (Eigen::Index i = 0; i < in.V.rows(); ++i) m.V.row(perm[i]) = in.V.row(i);
  m.F.resize(in.F.rows(), 3);
  for (Eigen::Index f = 0; f < in.F.rows(); ++f) {
    const int shift = static_cast<int>(rng() % 3);
    for (int k = 0; k < 3; ++k) m.F(f, k) = perm[in.F(forder[f], (k + shift) % 3)];
  }
  return m;
}

} // namespace gshell::test
