#include "guard/shell_part.h"

#include "quality/boundary_rows.h"


#include <algorithm>

namespace gshell::detail {

namespace {

// Rows that are, or share a vertex with, a row flagged in `seed`.
std::vector<char> with_neighbouring_rows(const ShellBoundary& boundary, const std::vector<char>& seed, int num_vertices) {
  std::vector<char> corner(num_vertices, 0), out(seed);
  for (int r = 0; r < boundary.size(); ++r)
    if (seed[r])
      for (int k = 0; k < 3; ++k) corner[boundary.F(r, k)] = 1;
  for (int r = 0; r < boundary.size(); ++r)
    if (corner[boundary.F(r, 0)] || corner[boundary.F(r, 1)] || corner[boundary.F(r, 2)]) out[r] = 1;
  return out;
}

} // namespace

ShellPart shell_part(const RestTets& tets, const ShellBoundary& boundary, const Eigen::MatrixXd& X,
                     const std::vector<char>& moving, double travel, double contact_radius) {
  const int N = static_cast<int>(X.rows());
  ShellPart part;
  for (int t = 0; t < tets.size(); ++t)
    for (int j = 0; j < 4; ++j)
      if (moving[tets.T(t, j)]) {
        part.tet.push_back(t);
        break;
      }

  // Rows near a moving row, within its travel and the contact radius.
  std::vector<int> moving_rows;
  for (int r = 0; r < boundary.size(); ++r)
    if (moving[boundary.F(r, 0)] || moving[boundary.F(r, 1)] || moving[boundary.F(r, 2)]) moving_rows.push_back(r);
  const std::vector<char> keep =
      with_neighbouring_rows(boundary, rows_near(boundary, X, moving_rows, travel + contact_radius), N);

  std::vector<char> used(N, 0);
  for (int t : part.tet)
    for (int j = 0; j < 4; ++j) used[tets.T(t, j)] = 1;
  for (int r = 0; r < boundary.size(); ++r)
    if (keep[r]) {
      part.row.push_back(r);
      for (int k = 0; k < 3; ++k) used[boundary.F(r, k)] = 1;
    }
  std::vector<int> id(N, -1);
  for (int v = 0; v < N; ++v)
    if (used[v]) {
      id[v] = part.size();
      part.vertex.push_back(v);
    }

  const int K = static_cast<int>(part.tet.size());
  part.tets.T.resize(K, 4);
  part.tets.volume.resize(K);
  part.tets.Dm_inv.reserve(K);
  for (int k = 0; k < K; ++k) {
    const int t = part.tet[k];
    for (int j = 0; j < 4; ++j) part.tets.T(k, j) = id[tets.T(t, j)];
    part.tets.Dm_inv.push_back(tets.dm_inv(t));
    part.tets.volume[k] = tets.volume[t];
  }
  const int R = static_cast<int>(part.row.size());
  part.boundary.F.resize(R, 3);
  for (int k = 0; k < R; ++k) {
    const int r = part.row[k];
    for (int j = 0; j < 3; ++j) part.boundary.F(k, j) = id[boundary.F(r, j)];
    if (!boundary.part.empty()) part.boundary.part.push_back(boundary.part[r]);
    if (!boundary.face.empty()) part.boundary.face.push_back(boundary.face[r]);
  }
  part.X.resize(part.size(), 3);
  for (int i = 0; i < part.size(); ++i) {
    part.X.row(i) = X.row(part.vertex[i]);
    if (!moving[part.vertex[i]]) part.held.push_back(i);
  }
  return part;
}

void ShellPart::scatter_moving(const Eigen::MatrixXd& P, Eigen::MatrixXd& shell_X) const {
  std::vector<char> is_held(vertex.size(), 0);
  for (int i : held) is_held[i] = 1;
  for (int i = 0; i < size(); ++i)
    if (!is_held[i]) shell_X.row(vertex[i]) = P.row(i);
}

} // namespace gshell::detail
