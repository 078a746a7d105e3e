#include <gshell/deform/embedding.h>

#include <gshell/deform/tet_locator.h>
#include <gshell/error.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <string>

namespace gshell {

Embedding embed_points(const Eigen::MatrixXd& X_rest, const Eigen::MatrixXi& T, const Eigen::MatrixXd& P,
                       const EmbedProgress& progress) {
  if (P.cols() != 3) throw InputError("embedded points must have 3 coordinates");
  for (Eigen::Index p = 0; p < P.rows(); ++p)
    if (!P.row(p).allFinite())
      throw InputError("embedded point " + std::to_string(p) + " has a non-finite coordinate");
  const TetLocator locator(X_rest, T);
  if (locator.usable_tets() == 0)
    throw InputError("the shell has no tet of non-zero volume to embed points in (all are flat)");

  const int n = static_cast<int>(P.rows());
  Embedding e;
  e.tet.resize(n);
  e.vertices.resize(n, 4);
  e.bary.resize(n, 4);
  std::vector<char> is_outside(n, 0);
  Eigen::VectorXd distance = Eigen::VectorXd::Zero(n);
  // 2M points around bunny00's shell took 5.7 s: blocks of 2^16 report about every 0.2 s.
  constexpr int kBlock = 1 << 16;
  for (int begin = 0; begin < n; begin += kBlock) {
    const int end = std::min(n, begin + kBlock);
    tbb::parallel_for(begin, end, [&](int p) {
      const TetHit hit = locator.locate(P.row(p).transpose());
      e.tet(p) = hit.tet;
      e.vertices.row(p) = T.row(hit.tet);
      e.bary.row(p) = hit.bary.transpose();
      is_outside[p] = hit.inside ? 0 : 1;
      distance(p) = hit.distance;
    });
    if (progress) progress(end, n);
  }
  for (int p = 0; p < n; ++p)
    if (is_outside[p]) {
      e.outside.push_back(p);
      e.max_outside_distance = std::max(e.max_outside_distance, distance(p));
    }
  return e;
}

Eigen::MatrixXd carry(const Embedding& embedding, const Eigen::MatrixXd& X) {
  const int n = embedding.size();
  // The embedding may come from another shell than X (a caller's bookkeeping error).
  if (X.cols() != 3 || (n > 0 && embedding.vertices.maxCoeff() >= X.rows()))
    throw InputError("carry: X (" + std::to_string(X.rows()) + " x " + std::to_string(X.cols()) +
                     ") lacks vertices the embedding's tets use");
  Eigen::MatrixXd out(n, 3);
  for (int p = 0; p < n; ++p) {
    Eigen::RowVector3d q = Eigen::RowVector3d::Zero();
    for (int k = 0; k < 4; ++k) q += embedding.bary(p, k) * X.row(embedding.vertices(p, k));
    out.row(p) = q;
  }
  return out;
}

} // namespace gshell
