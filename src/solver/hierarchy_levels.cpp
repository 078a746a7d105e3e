#include "hierarchy_levels.h"

#include <gshell/solver/polar_decomposition.h>

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/LU>

#include <numeric>
#include <stdexcept>

namespace gshell::detail {

namespace {

constexpr int kGrain = 1024;
constexpr int kBatch = 64; // matrices per batched polar decomposition call

/// Gradient rows g_k (F = sum_k x_k g_k^T) of a tet from its inverse rest edge matrix.
Eigen::Matrix<double, 4, 3> gradient_rows(const Eigen::Matrix3d& Dm_inv) {
  Eigen::Matrix<double, 4, 3> G;
  G.row(0) = -Dm_inv.colwise().sum();
  G.bottomRows(3) = Dm_inv;
  return G;
}

/// Row k of vol * G * R^T, the tet's share of the right-hand side at its corner k.
Eigen::RowVector3d corner_rhs(const Eigen::Matrix3d& Q, int k) {
  return k == 0 ? Eigen::RowVector3d(-Q.colwise().sum()) : Eigen::RowVector3d(Q.row(k - 1));
}

} // namespace

Eigen::SparseMatrix<double> stiffness_matrix(const RestTets& rest, int num_vertices) {
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(16 * static_cast<size_t>(rest.size()));
  for (int t = 0; t < rest.size(); ++t) {
    const Eigen::Matrix<double, 4, 3> G = gradient_rows(rest.Dm_inv[t]);
    const Eigen::Matrix4d K = rest.volume(t) * G * G.transpose();
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) entries.emplace_back(rest.T(t, a), rest.T(t, b), K(a, b));
  }
  Eigen::SparseMatrix<double> L(num_vertices, num_vertices);
  L.setFromTriplets(entries.begin(), entries.end());
  return L;
}

// ---- reduced level ------------------------------------------------------------------------------

ReducedLevel::ReducedLevel(const RestTets& rest, const Eigen::MatrixXd& rest_vertices,
                           const std::vector<int>& cluster_of_base, int num_clusters,
                           const Eigen::SparseMatrix<double>& L, const std::vector<int>& constrained, double weight,
                           bool cluster_rotations)
    : rest_(rest), N_(static_cast<int>(rest_vertices.rows())), m_(num_clusters), constrained_(constrained),
      weight_(weight), cluster_rotations_(cluster_rotations) {
  const int n = N_ / 2;
  cluster_.resize(N_);
  for (int v = 0; v < N_; ++v) cluster_[v] = cluster_of_base[v < n ? v : v - n];

  Eigen::MatrixXd centroid = Eigen::MatrixXd::Zero(m_, 3);
  Eigen::VectorXi count = Eigen::VectorXi::Zero(m_);
  for (int v = 0; v < N_; ++v) {
    centroid.row(cluster_[v]) += rest_vertices.row(v);
    ++count(cluster_[v]);
  }
  for (int j = 0; j < m_; ++j) centroid.row(j) /= std::max(1, count(j));
  centroid_ = centroid;
  local_coords_.resize(N_, 3);
  for (int v = 0; v < N_; ++v) local_coords_.row(v) = rest_vertices.row(v) - centroid.row(cluster_[v]);

  // Exact border-tet rotations: split the tets into cluster interiors and border tets.
  interior_volume_ = Eigen::VectorXd::Zero(m_);
  for (int t = 0; t < rest.size() && !cluster_rotations_; ++t) {
    const int c = cluster_[rest.T(t, 0)];
    bool inside = true;
    for (int k = 1; k < 4; ++k) inside = inside && cluster_[rest.T(t, k)] == c;
    if (inside) {
      interior_volume_(c) += rest.volume(t);
      continue;
    }
    BorderTet bt;
    bt.tet = t;
    for (int k = 0; k < 4; ++k) {
      bt.cluster[k] = cluster_[rest.T(t, k)];
      bt.coords[k] = local_coords_.row(rest.T(t, k)).transpose();
    }
    border_.push_back(bt);
  }

  // B: x_v^T = [u_v - c_j, 1] Z_j, so the reduced matrix is B^T (L + springs) B.
  std::vector<Eigen::Triplet<double>> bt;
  bt.reserve(4 * static_cast<size_t>(N_));
  for (int v = 0; v < N_; ++v) {
    for (int k = 0; k < 3; ++k) bt.emplace_back(v, 4 * cluster_[v] + k, local_coords_(v, k));
    bt.emplace_back(v, 4 * cluster_[v] + 3, 1.0);
  }
  Eigen::SparseMatrix<double> B(N_, 4 * m_);
  B.setFromTriplets(bt.begin(), bt.end());
  Eigen::SparseMatrix<double> springs_diag(N_, N_);
  std::vector<Eigen::Triplet<double>> sd;
  for (int v : constrained_) sd.emplace_back(v, v, weight_);
  springs_diag.setFromTriplets(sd.begin(), sd.end());
  const Eigen::SparseMatrix<double> Bt = B.transpose();
  A_ = Bt * ((L + springs_diag) * B);
  solver_.factor(A_);
  if (cluster_rotations_) {
    A_elastic_ = Bt * (L * B);
    build_pairs();
  }

  std::vector<Eigen::Matrix4d> moments(m_, Eigen::Matrix4d::Zero());
  for (int v = 0; v < N_; ++v) {
    Eigen::Vector4d u;
    u << local_coords_.row(v).transpose(), 1.0;
    moments[cluster_[v]] += u * u.transpose();
  }
  fit_inverse_.resize(m_);
  for (int j = 0; j < m_; ++j) fit_inverse_[j] = moments[j].inverse();

  Z_rest_ = Eigen::MatrixXd::Zero(4 * m_, 3);
  for (int j = 0; j < m_; ++j) {
    Z_rest_.block(4 * j, 0, 3, 3).setIdentity();
    Z_rest_.row(4 * j + 3) = centroid.row(j);
  }
  Z_ = Z_rest_;
}

void ReducedLevel::reset() { Z_ = Z_rest_; }

Eigen::Vector3d ReducedLevel::position(int v) const {
  const int j = cluster_[v];
  return map(j) * local_coords_.row(v).transpose() + translation(j);
}

Eigen::MatrixXd ReducedLevel::positions() const { return positions(Z_); }

Eigen::MatrixXd ReducedLevel::positions(const Eigen::MatrixXd& Z) const {
  Eigen::MatrixXd X(N_, 3);
  for (int v = 0; v < N_; ++v) {
    const int j = cluster_[v];
    const Eigen::Matrix<double, 4, 3> Zj = Z.middleRows<4>(4 * j);
    X.row(v) = local_coords_.row(v) * Zj.topRows<3>() + Zj.row(3);
  }
  return X;
}

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
    const int j = cluster_[rest_.T(t, 0)];
    const Eigen::Matrix<double, 4, 3> G = gradient_rows(rest_.Dm_inv[t]);
    total_volume_ += rest_.volume(t);
    for (int k = 0; k < 4; ++k) {
      const int v = rest_.T(t, k);
      Eigen::Vector4d u;
      u << local_coords_.row(v).transpose(), 1.0;
      add(j, cluster_[v], rest_.volume(t) * u * G.row(k));
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
  // Every tet inside cluster j has F = M_j: one polar decomposition serves all of them.
  std::vector<Eigen::Matrix3d> M(m_), R(m_);
  std::vector<Eigen::Vector3d> T(m_);
  for (int j = 0; j < m_; ++j) {
    M[j] = map(j);
    T[j] = translation(j);
  }
  closest_rotations(M.data(), R.data(), m_);
  for (int j = 0; j < m_; ++j) {
    energy[j] = interior_volume_(j) * (M[j] - R[j]).squaredNorm();
    cache.Q[j] = interior_volume_(j) * R[j].transpose();
  }
  tbb::parallel_for(tbb::blocked_range<int>(0, nb, kGrain), [&](const tbb::blocked_range<int>& range) {
    Eigen::Matrix3d F[kBatch], Rb[kBatch];
    for (int b0 = range.begin(); b0 < range.end(); b0 += kBatch) {
      const int count = std::min(kBatch, range.end() - b0);
      for (int i = 0; i < count; ++i) {
        const BorderTet& bt = border_[b0 + i];
        Eigen::Vector3d x[4];
        for (int k = 0; k < 4; ++k) x[k].noalias() = M[bt.cluster[k]] * bt.coords[k] + T[bt.cluster[k]];
        Eigen::Matrix3d D;
        for (int k = 0; k < 3; ++k) D.col(k) = x[k + 1] - x[0];
        F[i] = D * rest_.Dm_inv[bt.tet];
      }
      closest_rotations(F, Rb, count);
      for (int i = 0; i < count; ++i) {
        const int t = border_[b0 + i].tet;
        energy[m_ + b0 + i] = rest_.volume(t) * (F[i] - Rb[i]).squaredNorm();
        cache.Q[m_ + b0 + i] = rest_.volume(t) * rest_.Dm_inv[t] * Rb[i].transpose();
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
  if (cluster_rotations_) {
    // d/dZ_i of sum_j tr(R_j^T S_j) = sum_j W_ji R_j^T; cache.Q[j] holds R_j^T.
    for (int j = 0; j < m_; ++j)
      for (int p = pair_start_[j]; p < pair_start_[j + 1]; ++p)
        acc[pairs_[p].cluster].noalias() += pairs_[p].W * cache.Q[j];
  } else {
  // Inside a cluster sum_k [u_k - c; 1] g_k^T = [I; 0] (rest F = I, rows of G sum to 0), so the
  // interior tets add vol * R^T to the M rows only; cache.Q[j] holds V_j * R_j^T.
  for (int j = 0; j < m_; ++j) acc[j].topRows<3>() = cache.Q[j];
  const int nb = static_cast<int>(border_.size());
  for (int b = 0; b < nb; ++b) {
    const BorderTet& bt = border_[b];
    const Eigen::Matrix3d& Q = cache.Q[m_ + b];
    for (int k = 0; k < 4; ++k) {
      const Eigen::RowVector3d q = corner_rhs(Q, k);
      Block& a = acc[bt.cluster[k]];
      a.topRows<3>().noalias() += bt.coords[k] * q;
      a.row(3) += q;
    }
  }
  }
  for (size_t r = 0; r < constrained_.size(); ++r) {
    const int v = constrained_[r];
    const Eigen::RowVector3d p = weight_ * targets.row(r);
    Block& a = acc[cluster_[v]];
    a.topRows<3>().noalias() += local_coords_.row(v).transpose() * p;
    a.row(3) += p;
  }
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

void ReducedLevel::fit(const Eigen::MatrixXd& X) {
  const Eigen::MatrixXd moments = restrict_field(X); // sum_v [u_v - c; 1] x_v^T per cluster
  for (int j = 0; j < m_; ++j) Z_.middleRows<4>(4 * j) = fit_inverse_[j] * moments.middleRows<4>(4 * j);
}

Eigen::MatrixXd ReducedLevel::restrict_field(const Eigen::MatrixXd& g) const {
  using Block = Eigen::Matrix<double, 4, 3>;
  std::vector<Block> acc(m_, Block::Zero());
  for (int v = 0; v < N_; ++v) {
    const Eigen::RowVector3d gv = g.row(v);
    Block& a = acc[cluster_[v]];
    a.topRows<3>().noalias() += local_coords_.row(v).transpose() * gv;
    a.row(3) += gv;
  }
  Eigen::MatrixXd out(4 * m_, 3);
  for (int j = 0; j < m_; ++j) out.middleRows<4>(4 * j) = acc[j];
  return out;
}

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

void ReducedLevel::apply_affine(const ReducedLevel& parent, const Eigen::MatrixXd& parent_before,
                                const std::vector<int>& parent_of) {
  for (int j = 0; j < m_; ++j) {
    const int p = parent_of[j];
    // The parent's displacement dM (u - c_p) + dt, written in this cluster's coordinates u - c_j.
    const Eigen::Matrix3d dMt = parent.Z_.block(4 * p, 0, 3, 3) - parent_before.block(4 * p, 0, 3, 3);
    const Eigen::RowVector3d dt = parent.Z_.row(4 * p + 3) - parent_before.row(4 * p + 3);
    Z_.block(4 * j, 0, 3, 3) += dMt;
    Z_.row(4 * j + 3) += (centroid_.row(j) - parent.centroid_.row(p)) * dMt + dt;
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
