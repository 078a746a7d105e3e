#include "guard/low_rank_inverse.h"

#include <Eigen/LU>

#include <algorithm>
#include <cstddef>

namespace gshell::detail {

namespace {

// Columns of A^-1 solved at once: one pass over the factor serves them all, but the block is
// nf doubles per column; at most about 32 MB of it.
int columns_per_pass(int nf) {
  constexpr long kBlockDoubles = 4L << 20;
  return static_cast<int>(std::clamp<long>(kBlockDoubles / std::max(nf, 1), 1, 32));
}

} // namespace

void LowRankInverse::keep(const ShellSolver& A, const std::vector<int>& vertices) {
  const int nf = static_cast<int>(A.free_vertices().size());
  if (static_cast<int>(slot_.size()) != nf) {
    slot_.assign(nf, -1);
    vertex_.assign(capacity_, -1);
    G_.setZero(capacity_, capacity_);
  }
  std::vector<int> fresh;
  for (int v : vertices)
    if (slot_[v] < 0) fresh.push_back(v);
  if (fresh.empty()) return;
  int empty = static_cast<int>(std::count(vertex_.begin(), vertex_.end(), -1));
  if (empty < static_cast<int>(fresh.size())) { // make room: let go of kept vertices S does not need
    std::vector<char> needed(nf, 0);
    for (int v : vertices) needed[v] = 1;
    for (int s = 0; s < capacity_ && empty < static_cast<int>(fresh.size()); ++s)
      if (vertex_[s] >= 0 && !needed[vertex_[s]]) {
        slot_[vertex_[s]] = -1;
        vertex_[s] = -1;
        ++empty;
      }
  }
  int next = 0;
  for (int v : fresh) {
    while (vertex_[next] >= 0) ++next;
    vertex_[next] = v;
    slot_[v] = next;
  }
  const int pass = columns_per_pass(nf);
  for (std::size_t first = 0; first < fresh.size(); first += pass) {
    const int count = static_cast<int>(std::min<std::size_t>(pass, fresh.size() - first));
    Eigen::MatrixXd columns = Eigen::MatrixXd::Zero(nf, count);
    for (int c = 0; c < count; ++c) columns(fresh[first + c], c) = 1;
    A.apply_inverse(columns);
    columns_solved_ += count;
    for (int c = 0; c < count; ++c) {
      const int own = slot_[fresh[first + c]];
      for (int s = 0; s < capacity_; ++s)
        if (vertex_[s] >= 0) G_(s, own) = G_(own, s) = columns(vertex_[s], c);
    }
  }
}

bool LowRankInverse::solve(const ShellSolver& A, const std::vector<int>& vertices, const Eigen::SparseMatrix<double>& H,
                           const Eigen::MatrixXd& y, Eigen::MatrixXd& x) {
  const int s = static_cast<int>(vertices.size());
  if (s == 0 || s > capacity_) return false;
  keep(A, vertices);
  // M = I + (G_SS (x) I3) H: row 3i + d of G H sums G(i, j) H(3j + d, c) over j.
  Eigen::MatrixXd M = Eigen::MatrixXd::Identity(3 * s, 3 * s);
  std::vector<int> slot(s);
  for (int k = 0; k < s; ++k) slot[k] = slot_[vertices[k]];
  for (int c = 0; c < H.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(H, c); it; ++it) {
      const int j = static_cast<int>(it.row()) / 3, d = static_cast<int>(it.row()) % 3;
      for (int i = 0; i < s; ++i) M(3 * i + d, c) += G_(slot[i], slot[j]) * it.value();
    }
  Eigen::VectorXd yS(3 * s);
  for (int k = 0; k < s; ++k)
    for (int d = 0; d < 3; ++d) yS[3 * k + d] = y(vertices[k], d);
  const Eigen::VectorXd t = M.partialPivLu().solve(yS);
  if (!t.allFinite()) return false;
  const Eigen::VectorXd Ht = H * t;
  Eigen::MatrixXd correction = Eigen::MatrixXd::Zero(y.rows(), 3);
  for (int k = 0; k < s; ++k)
    for (int d = 0; d < 3; ++d) correction(vertices[k], d) = Ht[3 * k + d];
  A.apply_inverse(correction);
  x = y - correction;
  return true;
}

} // namespace gshell::detail
