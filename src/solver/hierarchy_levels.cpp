#include "hierarchy_levels.h"

#include <gshell/solver/polar_decomposition.h>

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/LU>

#include <numeric>
#include <stdexcept>

namespace gshell::detail {

namespace {

constexpr int kGrain = 1024;
constexpr int kBatch = 64; // matrices per batched polar decomposition call

/// Row k of vol * G * R^T, the tet's share of the right-hand side at its corner k.
Eigen::RowVector3d corner_rhs(const Eigen::Matrix3d& Q, int k) {
  return k == 0 ? Eigen::RowVector3d(-Q.colwise().sum()) : Eigen::RowVector3d(Q.row(k - 1));
}

} // namespace

Eigen::SparseMatrix<double> stiffness_matrix(const RestTets& rest, int num_vertices) {
  // Column by column from each vertex's own tets (L is symmetric), not from 16 triplets per tet:
  // at a million tets those were 250 MB, plus Eigen's row-major copy with every duplicate, the
  // peak of a pose solver's setup. A column's entries sum their tets in ascending order, as
  // setFromTriplets did, so the matrix is the same to the bit.
  const int K = rest.size();
  std::vector<int> start(static_cast<std::size_t>(num_vertices) + 1, 0);
  for (int t = 0; t < K; ++t)
    for (int k = 0; k < 4; ++k) ++start[rest.T(t, k) + 1];
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<int> corner(start.back()); // 4 t + k, per vertex in ascending t
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int t = 0; t < K; ++t)
      for (int k = 0; k < 4; ++k) corner[fill[rest.T(t, k)]++] = 4 * t + k;
  }
  constexpr int kColumns = 4096;
  struct Block {
    std::vector<int> rows, count;
    std::vector<double> values;
  };
  std::vector<Block> blocks((num_vertices + kColumns - 1) / kColumns);
  tbb::parallel_for(0, static_cast<int>(blocks.size()), [&](int b) {
    Block& out = blocks[b];
    std::vector<std::pair<int, double>> column; // (row, sum) in order of first touch
    for (int v = b * kColumns; v < std::min(num_vertices, (b + 1) * kColumns); ++v) {
      column.clear();
      for (int s = start[v]; s < start[v + 1]; ++s) {
        const int t = corner[s] / 4, k = corner[s] % 4;
        const Eigen::Matrix<double, 4, 3> G = gradient_rows(rest.dm_inv(t));
        const Eigen::Matrix4d Kt = rest.volume(t) * G * G.transpose();
        for (int a = 0; a < 4; ++a) {
          const int r = rest.T(t, a);
          auto e = std::find_if(column.begin(), column.end(), [r](const auto& c) { return c.first == r; });
          if (e != column.end()) e->second += Kt(a, k);
          else column.emplace_back(r, Kt(a, k));
        }
      }
      std::sort(column.begin(), column.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
      out.count.push_back(static_cast<int>(column.size()));
      for (const auto& [r, value] : column) {
        out.rows.push_back(r);
        out.values.push_back(value);
      }
    }
  });
  Eigen::Index entries = 0;
  for (const Block& block : blocks) entries += static_cast<Eigen::Index>(block.rows.size());
  Eigen::SparseMatrix<double> L(num_vertices, num_vertices);
  L.resizeNonZeros(entries);
  int column = 0;
  Eigen::Index at = 0;
  for (const Block& block : blocks) {
    std::copy(block.rows.begin(), block.rows.end(), L.innerIndexPtr() + at);
    std::copy(block.values.begin(), block.values.end(), L.valuePtr() + at);
    for (int count : block.count) {
      L.outerIndexPtr()[column] = static_cast<int>(at);
      at += count;
      ++column;
    }
  }
  L.outerIndexPtr()[num_vertices] = static_cast<int>(at);
  return L;
}

// ---- reduced level ------------------------------------------------------------------------------

ReducedLevel::ReducedLevel(const RestTets& rest, const Eigen::MatrixXd& rest_vertices, const ClusterWeights& weights,
                           const std::vector<int>& home, const Eigen::SparseMatrix<double>& L,
                           const std::vector<int>& constrained, double weight, bool cluster_rotations)
    : rest_(rest), N_(static_cast<int>(rest_vertices.rows())), n_(N_ / 2), m_(weights.num_clusters),
      weights_(weights), constrained_(constrained), weight_(weight), cluster_rotations_(cluster_rotations) {
  if (weights_.num_vertices() != n_ || static_cast<int>(home.size()) != n_)
    throw std::invalid_argument("ReducedLevel: one weight list and one home cluster per base vertex");
  home_.resize(N_);
  for (int v = 0; v < N_; ++v) home_[v] = home[base_of(v)];

  // Centroids weighted like the maps act (any point would do: [u - c, 1] spans the same space).
  centroid_ = cluster_centroids(weights_, rest_vertices);
  const int entries = static_cast<int>(weights_.cluster.size());
  coords_.resize(2 * entries, 3);
  for (int i = 0; i < n_; ++i)
    for (int e = weights_.start[i]; e < weights_.start[i + 1]; ++e) {
      coords_.row(2 * e) = rest_vertices.row(i) - centroid_.row(weights_.cluster[e]);
      coords_.row(2 * e + 1) = rest_vertices.row(n_ + i) - centroid_.row(weights_.cluster[e]);
    }
  if (entries > 0 && coords_.squaredNorm() > 0) cluster_radius_ = std::sqrt(coords_.squaredNorm() / (2.0 * entries));

  // Exact rotations: tets whose corners all move with one cluster alone have F = M_j, unless
  // their rest shape is not their rest corners' (an override), which makes them border tets.
  interior_volume_ = Eigen::VectorXd::Zero(m_);
  for (int t = 0; t < rest.size() && !cluster_rotations_; ++t) {
    int c = -1;
    bool inside = !std::binary_search(rest.override_tets.begin(), rest.override_tets.end(), static_cast<int>(t));
    for (int k = 0; k < 4 && inside; ++k) {
      const int i = base_of(rest.T(t, k));
      inside = weights_.start[i + 1] - weights_.start[i] == 1 && (c < 0 || weights_.cluster[weights_.start[i]] == c);
      c = weights_.cluster[weights_.start[i]];
    }
    if (inside) interior_volume_(c) += rest.volume(t);
    else border_.push_back(t);
  }

  // x = B z, so the reduced matrix is B^T (L + springs) B.
  const Eigen::SparseMatrix<double> B = prolongation_matrix(weights_, rest_vertices, centroid_);
  B_ = B;
  Bt_ = B.transpose();
  Eigen::SparseMatrix<double> springs_diag(N_, N_);
  std::vector<Eigen::Triplet<double>> sd;
  for (int v : constrained_) sd.emplace_back(v, v, weight_);
  springs_diag.setFromTriplets(sd.begin(), sd.end());
  const Eigen::SparseMatrix<double> Bt = B.transpose();
  A_ = Bt * ((L + springs_diag) * B);
  solver_.factor(A_);
  fit_solver_.factor(Bt * B);
  if (cluster_rotations_) {
    A_elastic_ = Bt * (L * B);
    build_pairs();
  }

  Z_rest_ = Eigen::MatrixXd::Zero(4 * m_, 3);
  for (int j = 0; j < m_; ++j) {
    Z_rest_.block(4 * j, 0, 3, 3).setIdentity();
    Z_rest_.row(4 * j + 3) = centroid_.row(j);
  }
  Z_ = Z_rest_;
}

void ReducedLevel::reset() { Z_ = Z_rest_; }

Eigen::Vector3d ReducedLevel::position(int v) const {
  Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
  for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(B_, v); it; ++it) x += it.value() * Z_.row(it.col());
  return x.transpose();
}

Eigen::MatrixXd ReducedLevel::positions() const { return positions(Z_); }

Eigen::MatrixXd ReducedLevel::positions(const Eigen::MatrixXd& Z) const { return B_ * Z; }

void ReducedLevel::build_pairs() {
  using Block = Eigen::Matrix<double, 4, 3>;
  std::vector<std::vector<std::pair<int, Block>>> by_owner(m_);
  auto add = [&](int j, int i, const Block& w) {
    for (auto& [c, acc] : by_owner[j])
      if (c == i) {
        acc += w;
        return;
      }
    by_owner[j].emplace_back(i, w);
  };
  for (int t = 0; t < rest_.size(); ++t) {
    const int j = home_[rest_.T(t, 0)];
    const Eigen::Matrix<double, 4, 3> G = gradient_rows(rest_.dm_inv(t));
    const double vol = rest_.volume(t);
    total_volume_ += vol;
    for (int k = 0; k < 4; ++k) {
      const int v = rest_.T(t, k);
      for (int e = weights_.start[base_of(v)]; e < weights_.start[base_of(v) + 1]; ++e)
        add(j, weights_.cluster[e], (vol * weights_.weight[e]) * lifted(e, v) * G.row(k));
    }
  }
  pair_start_.assign(m_ + 1, 0);
  pairs_.clear();
  for (int j = 0; j < m_; ++j) {
    for (const auto& [i, w] : by_owner[j]) pairs_.push_back({i, w});
    pair_start_[j + 1] = static_cast<int>(pairs_.size());
  }
}

void ReducedLevel::local_cluster_rotations(LocalCache& cache, bool with_energy) const {
  using Block = Eigen::Matrix<double, 4, 3>;
  std::vector<Block> Z(m_);
  for (int j = 0; j < m_; ++j) Z[j] = Z_.middleRows<4>(4 * j);
  std::vector<Eigen::Matrix3d> S(m_, Eigen::Matrix3d::Zero()), R(m_);
  for (int j = 0; j < m_; ++j)
    for (int p = pair_start_[j]; p < pair_start_[j + 1]; ++p) S[j].noalias() += Z[pairs_[p].cluster].transpose() * pairs_[p].W;
  closest_rotations(S.data(), R.data(), m_);
  cache.Q.resize(m_);
  for (int j = 0; j < m_; ++j) cache.Q[j] = R[j].transpose();
  cache.energy_valid = with_energy;
  if (!with_energy) return;
  // sum_t vol ||F_t - R_j||^2 = tr(Z^T A_elastic Z) - 2 sum_j tr(R_j^T S_j) + 3 * total volume.
  double e = (Z_.transpose() * (A_elastic_ * Z_)).trace() + 3.0 * total_volume_;
  for (int j = 0; j < m_; ++j) e -= 2.0 * R[j].cwiseProduct(S[j]).sum();
  cache.elastic = e;
}

void ReducedLevel::local(LocalCache& cache, bool with_energy) const {
  if (cluster_rotations_) {
    local_cluster_rotations(cache, with_energy);
    return;
  }
  const int nb = static_cast<int>(border_.size());
  cache.Q.resize(m_ + nb);
  // Summed in a fixed order after the parallel part, so energies are reproducible to the bit.
  std::vector<double>& energy = cache.element_energy;
  energy.resize(m_ + nb);
  // Every tet moved by cluster j alone has F = M_j: one polar decomposition serves all of them.
  std::vector<Eigen::Matrix3d> M(m_), R(m_);
  for (int j = 0; j < m_; ++j) M[j] = map(j);
  closest_rotations(M.data(), R.data(), m_);
  for (int j = 0; j < m_; ++j) {
    energy[j] = interior_volume_(j) * (M[j] - R[j]).squaredNorm();
    cache.Q[j] = interior_volume_(j) * R[j].transpose();
  }
  const Eigen::MatrixXd X = nb > 0 ? positions() : Eigen::MatrixXd();
  tbb::parallel_for(tbb::blocked_range<int>(0, nb, kGrain), [&](const tbb::blocked_range<int>& range) {
    Eigen::Matrix3d F[kBatch], Rb[kBatch];
    for (int b0 = range.begin(); b0 < range.end(); b0 += kBatch) {
      const int count = std::min(kBatch, range.end() - b0);
      for (int i = 0; i < count; ++i) {
        const int t = border_[b0 + i];
        Eigen::Matrix3d D;
        for (int k = 0; k < 3; ++k) D.col(k) = (X.row(rest_.T(t, k + 1)) - X.row(rest_.T(t, 0))).transpose();
        F[i] = D * rest_.dm_inv(t);
      }
      closest_rotations(F, Rb, count);
      for (int i = 0; i < count; ++i) {
        const int t = border_[b0 + i];
        energy[m_ + b0 + i] = rest_.volume(t) * (F[i] - Rb[i]).squaredNorm();
        cache.Q[m_ + b0 + i] = rest_.volume(t) * rest_.dm_inv(t) * Rb[i].transpose();
      }
    }
  });
  cache.elastic = std::accumulate(energy.begin(), energy.end(), 0.0);
  cache.energy_valid = true;
}

double ReducedLevel::springs(const Eigen::MatrixXd& targets) const {
  double e = 0;
  for (size_t r = 0; r < constrained_.size(); ++r)
    e += (position(constrained_[r]) - targets.row(r).transpose()).squaredNorm();
  return weight_ * e;
}

Eigen::MatrixXd ReducedLevel::rhs(const Eigen::MatrixXd& targets, const LocalCache& cache) const {
  using Block = Eigen::Matrix<double, 4, 3>;
  std::vector<Block> acc(m_, Block::Zero());
  // A force f at vertex v acts on the maps through B^T: sum_e w_e [u_v - c_j; 1] f.
  auto add_force = [&](int v, const Eigen::RowVector3d& f) {
    for (int e = weights_.start[base_of(v)]; e < weights_.start[base_of(v) + 1]; ++e)
      acc[weights_.cluster[e]].noalias() += (weights_.weight[e] * lifted(e, v)) * f;
  };
  if (cluster_rotations_) {
    // d/dZ_i of sum_j tr(R_j^T S_j) = sum_j W_ji R_j^T; cache.Q[j] holds R_j^T.
    for (int j = 0; j < m_; ++j)
      for (int p = pair_start_[j]; p < pair_start_[j + 1]; ++p)
        acc[pairs_[p].cluster].noalias() += pairs_[p].W * cache.Q[j];
  } else {
    // Inside a cluster sum_k [u_k - c; 1] g_k^T = [I; 0] (rest F = I, rows of G sum to 0), so the
    // tets it moves alone add vol * R^T to the M rows only; cache.Q[j] holds V_j * R_j^T.
    for (int j = 0; j < m_; ++j) acc[j].topRows<3>() = cache.Q[j];
    const int nb = static_cast<int>(border_.size());
    for (int b = 0; b < nb; ++b)
      for (int k = 0; k < 4; ++k) add_force(rest_.T(border_[b], k), corner_rhs(cache.Q[m_ + b], k));
  }
  for (size_t r = 0; r < constrained_.size(); ++r) add_force(constrained_[r], weight_ * targets.row(r));
  Eigen::MatrixXd out(4 * m_, 3);
  for (int j = 0; j < m_; ++j) out.middleRows<4>(4 * j) = acc[j];
  return out;
}

void ReducedLevel::solve(const Eigen::MatrixXd& rhs) {
  Z_ = rhs;
  solver_.solve_in_place(Z_);
}

Eigen::MatrixXd ReducedLevel::half_gradient(const Eigen::MatrixXd& targets, const LocalCache& cache) const {
  return A_ * Z_ - rhs(targets, cache);
}

void ReducedLevel::fit(const Eigen::MatrixXd& X) { fit_restricted(restrict_field(X)); }

void ReducedLevel::fit_restricted(const Eigen::MatrixXd& restricted) {
  Z_ = restricted;
  fit_solver_.solve_in_place(Z_);
}

Eigen::MatrixXd ReducedLevel::coarsen(const Eigen::MatrixXd& finer_restricted, const ReducedLevel& finer,
                                      const std::vector<int>& parent_of) const {
  // Finer cluster c's block is sum_u [u - c_c; 1] g_u^T; about this level's centroid c_p it is
  // that plus [c_c - c_p; 0] times its last row (sum_u g_u^T).
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(4 * m_, 3);
  for (int c = 0; c < finer.m_; ++c) {
    const int p = parent_of[c];
    const auto block = finer_restricted.middleRows<4>(4 * c);
    out.middleRows<4>(4 * p) += block;
    out.middleRows<3>(4 * p).noalias() += (finer.centroid_.row(c) - centroid_.row(p)).transpose() * block.row(3);
  }
  return out;
}

Eigen::MatrixXd ReducedLevel::restrict_field(const Eigen::MatrixXd& g) const { return Bt_ * g; }

std::vector<RigidChange> ReducedLevel::changes_since(const Eigen::MatrixXd& before) const {
  std::vector<RigidChange> out(m_);
  for (int j = 0; j < m_; ++j) {
    const Eigen::Matrix3d M0 = before.block(4 * j, 0, 3, 3).transpose();
    out[j].dR = closest_rotation(map(j)) * closest_rotation(M0).transpose();
    out[j].from = before.row(4 * j + 3).transpose();
    out[j].to = translation(j);
  }
  return out;
}

void ReducedLevel::apply_change(const ReducedLevel& parent, const Eigen::MatrixXd& parent_before,
                                const std::vector<int>& parent_of) {
  // Parent p moves u by dM (u - c_p) + dt = dM (u - c_c) + (dM (c_c - c_p) + dt) for u in cluster c.
  for (int c = 0; c < m_; ++c) {
    const int p = parent_of[c];
    const Eigen::Matrix<double, 4, 3> d = parent.Z_.middleRows<4>(4 * p) - parent_before.middleRows<4>(4 * p);
    Z_.middleRows<3>(4 * c) += d.topRows<3>();
    Z_.row(4 * c + 3) += d.row(3) + (centroid_.row(c) - parent.centroid_.row(p)) * d.topRows<3>();
  }
}

void ReducedLevel::apply(const std::vector<RigidChange>& parent_change, const std::vector<int>& parent_of) {
  for (int j = 0; j < m_; ++j) {
    const RigidChange& c = parent_change[parent_of[j]];
    // x = M (u - c_j) + t  ->  dR (x - from) + to: M' = dR M, t' = dR (t - from) + to
    Z_.block(4 * j, 0, 3, 3) = Z_.block(4 * j, 0, 3, 3) * c.dR.transpose();
    Z_.row(4 * j + 3) = c.apply(translation(j)).transpose();
  }
}

} // namespace gshell::detail
