// TEMPORARY probe (not to be committed): where do the reduced levels lose?
#include "../src/solver/hierarchy_levels.h"

#include <gshell/deform/handles.h>
#include <gshell/deform/pose.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/io/load_mesh.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/cluster_tree.h>
#include <gshell/solver/hierarchical_solver.h>
#include <gshell/solver/shell_solver.h>
#include <gshell/solver/polar_decomposition.h>

#include <Eigen/SparseCholesky>
#include <Eigen/Dense>
#include <Eigen/SVD>

#include <cstdio>
#include <fstream>
#include <queue>
#include <map>
#include <Eigen/Geometry>
#include <string>

using namespace gshell;

static Shell make_shell(const TriMesh& mesh, double ratio) {
  GenerateOptions options;
  options.method = ShellMethod::Rigid;
  options.thickness = thickness_from_ratio(mesh.V, ratio);
  options.count_intersections = false;
  return generate_shell(mesh.V, mesh.F, options).shell;
}

static HandleSet bowl_handles(const Shell& shell, const std::string& pull) {
  const Eigen::MatrixXd X = shell.vertices();
  const Eigen::RowVector3d lo = X.colwise().minCoeff(), hi = X.colwise().maxCoeff();
  const double R = 0.5 * (hi - lo).maxCoeff();
  Handle hold, move;
  for (int v = 0; v < X.rows(); ++v) {
    const Eigen::RowVector3d p = X.row(v);
    if (pull == "pull") {
      if (p.z() > -0.15 * R && p.x() < -0.5 * R) hold.vertices.push_back(v);
      if (p.z() > -0.15 * R && p.x() > 0.7 * R) move.vertices.push_back(v);
    } else if (pull == "half") {
      if (p.z() > -0.06 * R && p.x() < 0) hold.vertices.push_back(v);
      if (p.z() > -0.06 * R && p.x() >= 0) move.vertices.push_back(v);
    }
  }
  if (pull == "pull") move.translate = Eigen::Vector3d(0.8 * R, 0.2 * R, 0.5 * R);
  if (pull == "half") move.translate = Eigen::Vector3d(-0.6 * R, 0.1 * R, -0.6 * R);
  HandleSet set;
  set.handles = {hold, move};
  for (auto& h : set.handles) {
    h.center = Eigen::Vector3d::Zero();
    for (int v : h.vertices) h.center += X.row(v).transpose();
    h.center /= static_cast<double>(h.vertices.size());
  }
  return set;
}

// Blended weights: w_i(v) ~ phi(d_i(v)/h_i), d_i = graph distance to cluster i, h_i = alpha * rms radius.
static std::vector<std::vector<std::pair<int, double>>> blended_weights(const Eigen::MatrixXd& Vb, const Eigen::MatrixXi& F,
                                                                        const std::vector<int>& cluster_of, int m,
                                                                        double alpha) {
  const int n = Vb.rows();
  std::vector<std::vector<std::pair<int, double>>> adj(n);
  for (int f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      int a = F(f, k), b = F(f, (k + 1) % 3);
      double l = (Vb.row(a) - Vb.row(b)).norm();
      adj[a].push_back({b, l});
      adj[b].push_back({a, l});
    }
  std::vector<std::vector<int>> members(m);
  for (int i = 0; i < n; ++i) members[cluster_of[i]].push_back(i);
  std::vector<std::vector<std::pair<int, double>>> raw(n);
  std::vector<double> dist(n, 1e300);
  for (int c = 0; c < m; ++c) {
    Eigen::RowVector3d mean = Eigen::RowVector3d::Zero();
    for (int i : members[c]) mean += Vb.row(i);
    mean /= members[c].size();
    double r2 = 0;
    for (int i : members[c]) r2 += (Vb.row(i) - mean).squaredNorm();
    const double h = alpha * std::sqrt(r2 / members[c].size()) + 1e-300;
    using QE = std::pair<double, int>;
    std::priority_queue<QE, std::vector<QE>, std::greater<>> q;
    std::vector<int> touched;
    for (int i : members[c]) {
      dist[i] = 0;
      q.push({0, i});
      touched.push_back(i);
    }
    while (!q.empty()) {
      auto [d, v] = q.top();
      q.pop();
      if (d > dist[v]) continue;
      for (auto [w, l] : adj[v]) {
        const double nd = d + l;
        if (nd < dist[w] && nd < h) {
          if (dist[w] == 1e300) touched.push_back(w);
          dist[w] = nd;
          q.push({nd, w});
        }
      }
    }
    for (int v : touched) {
      const double s = dist[v] / h;
      const double phi = (1 - s * s) * (1 - s * s);
      if (phi > 0) raw[v].push_back({c, phi});
      dist[v] = 1e300;
    }
  }
  for (auto& r : raw) {
    double sum = 0;
    for (auto& [c, w] : r) sum += w;
    for (auto& [c, w] : r) w /= sum;
  }
  return raw;
}

static Eigen::SparseMatrix<double> basis(const Eigen::MatrixXd& U, int n, const std::vector<std::vector<std::pair<int, double>>>& w,
                                         int m) {
  std::vector<Eigen::RowVector3d> c(m, Eigen::RowVector3d::Zero());
  std::vector<double> wsum(m, 0);
  // centroid: plain mean of members (owner weight 1 for the owning cluster... use weighted mean)
  for (int v = 0; v < 2 * n; ++v)
    for (auto [j, ww] : w[v % n]) {
      c[j] += ww * U.row(v);
      wsum[j] += ww;
    }
  for (int j = 0; j < m; ++j) c[j] /= wsum[j];
  std::vector<Eigen::Triplet<double>> t;
  for (int v = 0; v < 2 * n; ++v)
    for (auto [j, ww] : w[v % n]) {
      for (int k = 0; k < 3; ++k) t.emplace_back(v, 4 * j + k, ww * (U(v, k) - c[j](k)));
      t.emplace_back(v, 4 * j + 3, ww);
    }
  Eigen::SparseMatrix<double> B(2 * n, 4 * m);
  B.setFromTriplets(t.begin(), t.end());
  return B;
}

int main(int argc, char** argv) {
  std::string pull = argc > 1 ? argv[1] : "pull";
  double ratio = argc > 2 ? std::atof(argv[2]) : 0.02;
  int nk = argc > 3 ? std::atoi(argv[3]) : 20;
  const TriMesh mesh = make_bowl();
  const Shell shell = make_shell(mesh, ratio);
  const HandleSet handles = pull == "pull" ? bowl_handles(shell, pull) : read_handles("examples/" + pull + ".json", shell);
  const int n = shell.num_base_vertices();
  std::printf("%s ratio %.3g: %d shell vertices, handles %zu %zu\n", pull.c_str(), ratio, 2 * n,
              handles.handles[0].vertices.size(), handles.handles[1].vertices.size());
  HierarchyOptions ro;
  ro.levels = 1;
  ro.path_extrapolation = false;
  PoseSolver ref(shell, handles, PoseSolverKind::Hierarchical, ro);
  const std::string cache = "/tmp/hb/probe_" + pull + "_" + std::to_string(ratio) + ".bin";
  Eigen::MatrixXd Xs = ref.rest_vertices();
  {
    std::ifstream in(cache, std::ios::binary);
    if (in) in.read(reinterpret_cast<char*>(Xs.data()), sizeof(double) * Xs.size());
    else {
      SolveOptions so;
      so.max_iterations = 5000;
      so.tolerance = 1e-11;
      auto r = ref.solve(Xs, 1.0, so);
      std::printf("reference: %d its\n", r.iterations);
      std::ofstream out(cache, std::ios::binary);
      out.write(reinterpret_cast<const char*>(Xs.data()), sizeof(double) * Xs.size());
    }
  }
  const double Es = ref.energy(Xs, 1.0);
  std::printf("E* = %.8g\n", Es);

  // Hierarchical default run with counters.
  const Eigen::MatrixXd P = ref.targets(1.0);
  PositionConstraints pc;
  pc.vertices = ref.constrained_vertices();
  const Eigen::MatrixXd U = ref.rest_vertices();
  {
    for (int variant = 0; variant < 2; ++variant) {
      HierarchyOptions o;
      if (variant == 1) { o.levels = 1; }
      HierarchicalSolver hs(ref.rest_tets(), U, shell.F, pc, o);
      Eigen::MatrixXd X = U;
      SolveOptions so;
      so.max_iterations = 300;
      so.tolerance = 0;
      int reached = -1;
      so.progress = [&](int it, double e, double) {
        if (reached < 0 && e <= 1.001 * Es) reached = it;
      };
      auto r = hs.solve(X, P, so);
      std::printf("variant %d: reached at %d; passes %d accepted %d rejected_prop %d; decrease coarse %.4g full %.4g path %.4g (total %.4g)\n",
                  variant, reached, r.counters.coarse_passes, r.counters.coarse_accepted, r.counters.rejected_propagations, r.counters.coarse_decrease,
                  r.counters.full_decrease, r.counters.path_decrease, r.energy.front() - r.energy.back());
    }
  }

  // Subspace potential along the single+AA path: X_k after k iterations.
  const RestTets& rest = ref.rest_tets();
  auto full = make_shell_solver(rest, 2 * n, pc);
  const Eigen::SparseMatrix<double> L = detail::stiffness_matrix(rest, 2 * n);
  const double w_spring = 100 * mean_stiffness(rest, 2 * n);
  std::vector<char> kept(2 * n, 0);
  for (int v : pc.vertices) kept[v] = 1;
  Eigen::SparseMatrix<double> Lp = L;
  for (int k = 0; k < Lp.outerSize(); ++k)
    for (Eigen::SparseMatrix<double>::InnerIterator it(Lp, k); it; ++it)
      if (kept[it.row()] || kept[it.col()]) it.valueRef() = it.row() == it.col() ? w_spring : 0.0;
  ClusterTreeOptions to;
  to.depth = 9;
  const ClusterTree tree = build_cluster_tree(U, shell.F, to);
  Eigen::MatrixXd Xk = U;
  for (int v = 0; v < (int)pc.vertices.size(); ++v) Xk.row(pc.vertices[v]) = P.row(v);
  {
    HierarchicalSolver single(rest, U, shell.F, pc, ro);
    Xk = U;
    SolveOptions so;
    so.max_iterations = nk;
    so.tolerance = 0;
    single.solve(Xk, P, so);
  }
  const double Ek = full->energy(Xk);
  std::printf("\nX_%d: E/E* = %.5f\n", nk, Ek / Es);
  double mean_edge = 0;
  for (int f = 0; f < shell.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) mean_edge += (U.row(shell.F(f, k)) - U.row(shell.F(f, (k + 1) % 3))).norm();
  mean_edge /= 3 * shell.F.rows();
  auto gap = [&](const Eigen::MatrixXd& x) { return (Ek - full->energy(x)) / (Ek - Es); };
  auto smooth = [&](Eigen::MatrixXd x, int k) {
    for (int i = 0; i < k; ++i) {
      LocalStep a;
      full->local_step(x, a);
      full->global_step(x, a);
    }
    return x;
  };
  std::printf("  no correction: +1 %.4f, +2 %.4f, +3 %.4f\n", gap(smooth(Xk, 1)), gap(smooth(Xk, 2)), gap(smooth(Xk, 3)));
  // free-row Laplacian factor
  std::vector<int> free_index(2 * n, -1), free_vertices;
  for (int v = 0; v < 2 * n; ++v) if (!kept[v]) { free_index[v] = free_vertices.size(); free_vertices.push_back(v); }
  const int nf = free_vertices.size();
  std::vector<Eigen::Triplet<double>> lt;
  for (int k = 0; k < L.outerSize(); ++k)
    for (Eigen::SparseMatrix<double>::InnerIterator it(L, k); it; ++it)
      if (!kept[it.row()] && !kept[it.col()]) lt.emplace_back(free_index[it.row()], free_index[it.col()], it.value());
  Eigen::SparseMatrix<double> Lff(nf, nf);
  Lff.setFromTriplets(lt.begin(), lt.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> Lsolve(Lff);
  const int K = rest.size();
  if (std::getenv("MOTION")) {
    // displacement of single+AA between iteration nk and nk+40, and vs X*
    HierarchicalSolver single(rest, U, shell.F, pc, ro);
    Eigen::MatrixXd Xb = U;
    SolveOptions so;
    so.max_iterations = nk + 40;
    so.tolerance = 0;
    single.solve(Xb, P, so);
    for (int which = 0; which < 2; ++which) {
      const Eigen::MatrixXd d = which == 0 ? Eigen::MatrixXd(Xb - Xk) : Eigen::MatrixXd(Xs - Xk);
      std::vector<double> mag(2 * n);
      for (int v = 0; v < 2 * n; ++v) mag[v] = d.row(v).squaredNorm();
      std::vector<double> sorted = mag;
      std::sort(sorted.rbegin(), sorted.rend());
      double total = 0, top5 = 0, top20 = 0;
      for (size_t i = 0; i < sorted.size(); ++i) { total += sorted[i]; if (i < sorted.size() / 20) top5 += sorted[i]; if (i < sorted.size() / 5) top20 += sorted[i]; }
      // where: centroid of the motion (weighted)
      Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
      for (int v = 0; v < 2 * n; ++v) c += mag[v] * U.row(v);
      c /= total;
      std::printf("  %s: rms %.4g max %.4g; share of |d|^2 in top 5%% vertices %.2f, top 20%% %.2f; weighted rest centroid (%.2f %.2f %.2f)\n",
                  which ? "X* - X_k" : "X_{k+40} - X_k", std::sqrt(total / (2 * n)), std::sqrt(sorted[0]), top5 / total, top20 / total, c(0), c(1), c(2));
    }
    return 0;
  }
  if (std::getenv("PROJ")) {
    const Eigen::MatrixXd e = Xs - Xk;
    for (int d : {3, 5, 7, 9}) for (int blend : {0, 1}) {
      const int m = tree.num_clusters(d);
      std::vector<std::vector<std::pair<int, double>>> w;
      if (!blend) { w.resize(n); for (int i = 0; i < n; ++i) w[i] = {{tree.cluster_of[d][i], 1.0}}; }
      else w = blended_weights(U.topRows(n), shell.F, tree.cluster_of[d], m, 1.0);
      const Eigen::SparseMatrix<double> B = basis(U, n, w, m);
      Eigen::SparseMatrix<double> BtB = B.transpose() * B;
      Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> fit(BtB);
      const Eigen::MatrixXd ze = fit.solve(Eigen::MatrixXd(B.transpose() * e));
      Eigen::MatrixXd x = Xk + B * ze;
      for (int v : pc.vertices) x.row(v) = Xk.row(v);
      std::printf("  depth %d %s: projected error %.3f +1 %.3f +3 %.3f +10 %.3f\n", d, blend ? "blend1" : "piecewise", gap(x), gap(smooth(x, 1)), gap(smooth(x, 3)), gap(smooth(x, 10)));
      // multiplicative: Z0 = fit(Xk), Z1 = Z0 + ze; x_v <- sum_j w (dA_j (x_v - t0_j) + t1_j)
      const Eigen::MatrixXd Z0 = fit.solve(Eigen::MatrixXd(B.transpose() * Xk));
      const Eigen::MatrixXd Z1 = Z0 + ze;
      // centroids as in basis()
      std::vector<Eigen::RowVector3d> c(m, Eigen::RowVector3d::Zero());
      std::vector<double> wsum(m, 0);
      for (int v = 0; v < 2 * n; ++v) for (auto [j, ww] : w[v % n]) { c[j] += ww * U.row(v); wsum[j] += ww; }
      for (int j = 0; j < m; ++j) c[j] /= wsum[j];
      for (int rigid : {0, 1}) {
        std::vector<Eigen::Matrix3d> dA(m);
        std::vector<Eigen::Vector3d> t0(m), t1(m);
        for (int j = 0; j < m; ++j) {
          Eigen::Matrix3d M0 = Z0.block(4 * j, 0, 3, 3).transpose(), M1 = Z1.block(4 * j, 0, 3, 3).transpose();
          // frame origin: image of the centroid c_j: x = M (u - c) + t -> at u = c: t
          t0[j] = Z0.row(4 * j + 3).transpose();
          t1[j] = Z1.row(4 * j + 3).transpose();
          dA[j] = rigid ? closest_rotation(M1) * closest_rotation(M0).transpose() : Eigen::Matrix3d(M1 * M0.inverse());
        }
        Eigen::MatrixXd y = Xk;
        for (int v = 0; v < 2 * n; ++v) {
          if (kept[v]) continue;
          Eigen::Vector3d acc = Eigen::Vector3d::Zero();
          for (auto [j, ww] : w[v % n]) acc += ww * (dA[j] * (Xk.row(v).transpose() - t0[j]) + t1[j]);
          y.row(v) = acc.transpose();
        }
        std::printf("      multiplicative %s: %.3f +1 %.3f +3 %.3f +10 %.3f\n", rigid ? "rigid" : "affine", gap(y), gap(smooth(y, 1)), gap(smooth(y, 3)), gap(smooth(y, 10)));
      }
    }
    return 0;
  }
  for (int d : {3, 5, 7}) for (int blend : {0, 1}) {
    const int m = tree.num_clusters(d);
    std::vector<std::vector<std::pair<int, double>>> wv;
    if (!blend) { wv.resize(n); for (int i = 0; i < n; ++i) wv[i] = {{tree.cluster_of[d][i], 1.0}}; }
    else wv = blended_weights(U.topRows(n), shell.F, tree.cluster_of[d], m, 2.0);
    // tet weights: mean of corners (piecewise: owner of corner 0 for blend 0)
    std::vector<std::vector<std::pair<int, double>>> wt(K);
    for (int t = 0; t < K; ++t) {
      if (!blend) { wt[t] = {{tree.cluster_of[d][rest.T(t, 0) % n], 1.0}}; continue; }
      std::map<int, double> acc;
      for (int k = 0; k < 4; ++k) for (auto [j, w] : wv[rest.T(t, k) % n]) acc[j] += 0.25 * w;
      for (auto [j, w] : acc) wt[t].push_back({j, w});
    }
    LocalStep st;
    full->local_step(Xk, st);
    std::vector<Eigen::Matrix3d> R(K), Fg(K);
    for (int t = 0; t < K; ++t) {
      Eigen::Matrix3d Q = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(st.Q.data() + 9 * t);
      R[t] = (rest.Dm_inv[t].inverse() * Q / rest.volume(t)).transpose();
    }
    Eigen::MatrixXd xG = Xk;
    full->global_step(xG, st);
    const double EG = full->energy(xG);
    for (int t = 0; t < K; ++t) {
      Eigen::Matrix3d D;
      for (int k = 0; k < 3; ++k) D.col(k) = (xG.row(rest.T(t, k + 1)) - xG.row(rest.T(t, 0))).transpose();
      Fg[t] = D * rest.Dm_inv[t];
    }
    auto axial = [](const Eigen::Matrix3d& A) { return Eigen::Vector3d(A(2, 1) - A(1, 2), A(0, 2) - A(2, 0), A(1, 0) - A(0, 1)); };
    auto cross = [](const Eigen::Vector3d& v) { Eigen::Matrix3d M; M << 0, -v(2), v(1), v(2), 0, -v(0), -v(1), v(0), 0; return M; };
    Eigen::VectorXd g = Eigen::VectorXd::Zero(3 * m);
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(3 * m, 3 * m);
    for (int t = 0; t < K; ++t) {
      const double vol = rest.volume(t);
      const Eigen::Vector3d a = axial(Fg[t] * R[t].transpose());
      const Eigen::Matrix3d M = R[t] * Fg[t].transpose();
      const Eigen::Matrix3d Hl = 2 * vol * (M.trace() * Eigen::Matrix3d::Identity() - 0.5 * (M + M.transpose()));
      for (auto [j, wj] : wt[t]) {
        g.segment<3>(3 * j) += -2 * vol * wj * a;
        for (auto [i, wi] : wt[t]) H.block<3, 3>(3 * j, 3 * i) += wj * wi * Hl;
      }
    }
    auto coupling = [&](const std::vector<Eigen::Matrix3d>& R) {
      Eigen::MatrixXd Hc = Eigen::MatrixXd::Zero(3 * m, 3 * m);
    // coupling: delta b columns
      std::vector<Eigen::MatrixXd> db(3 * m, Eigen::MatrixXd::Zero(nf, 3));
      for (int t = 0; t < K; ++t) {
        Eigen::Matrix<double, 4, 3> G;
        G.row(0) = -rest.Dm_inv[t].colwise().sum();
        G.bottomRows(3) = rest.Dm_inv[t];
        const Eigen::Matrix<double, 4, 3> GR = rest.volume(t) * G * R[t].transpose();
        for (auto [j, w] : wt[t])
          for (int k = 0; k < 3; ++k) {
            const Eigen::Matrix<double, 4, 3> c = -w * GR * cross(Eigen::Vector3d::Unit(k));
            for (int q = 0; q < 4; ++q) {
              const int fi = free_index[rest.T(t, q)];
              if (fi >= 0) db[3 * j + k].row(fi) += c.row(q);
            }
          }
      }
      std::vector<Eigen::MatrixXd> Y(3 * m);
      for (int c = 0; c < 3 * m; ++c) Y[c] = Lsolve.solve(db[c]);
      for (int a = 0; a < 3 * m; ++a)
        for (int b = 0; b < 3 * m; ++b) Hc(a, b) += -2 * db[a].cwiseProduct(Y[b]).sum();
      return Hc;
    };
    const Eigen::MatrixXd Hexact = H + coupling(R);
    // corotational: rest Hessian (R = I, F = I), rotated per cluster
    std::vector<Eigen::Matrix3d> Irot(K, Eigen::Matrix3d::Identity());
    Eigen::MatrixXd Hrest = coupling(Irot);
    for (int t = 0; t < K; ++t)
      for (auto [j, wj] : wt[t])
        for (auto [i, wi] : wt[t]) Hrest.block<3, 3>(3 * j, 3 * i) += wj * wi * 4 * rest.volume(t) * Eigen::Matrix3d::Identity();
    std::vector<Eigen::Matrix3d> Rbar(m);
    {
      std::vector<Eigen::Matrix3d> acc(m, Eigen::Matrix3d::Zero());
      for (int t = 0; t < K; ++t) for (auto [j, w] : wt[t]) acc[j] += w * rest.volume(t) * R[t];
      for (int j = 0; j < m; ++j) {
        Eigen::JacobiSVD<Eigen::Matrix3d> svd(acc[j], Eigen::ComputeFullU | Eigen::ComputeFullV);
        Eigen::Matrix3d Uu = svd.matrixU();
        if ((Uu * svd.matrixV().transpose()).determinant() < 0) Uu.col(2) *= -1;
        Rbar[j] = Uu * svd.matrixV().transpose();
      }
    }
    Eigen::MatrixXd Hco = Hrest;
    for (int j = 0; j < m; ++j) for (int i = 0; i < m; ++i) Hco.block<3, 3>(3 * j, 3 * i) = Rbar[j] * Hrest.block<3, 3>(3 * j, 3 * i) * Rbar[i].transpose();
    for (int which = 0; which < 2; ++which) {
    H = which == 0 ? Hexact : Hco;
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (H + H.transpose()));
    const Eigen::VectorXd ev = es.eigenvalues();
    // PD projection: clamp eigenvalues to >= 1e-3 * max
    const double floor = 1e-3 * ev.maxCoeff();
    Eigen::VectorXd inv = ev.unaryExpr([&](double l) { return 1.0 / std::max(l, floor); });
    const Eigen::VectorXd theta0 = -es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose() * g;
    int negative = 0;
    for (int i = 0; i < ev.size(); ++i) negative += ev(i) < floor;
    std::printf("  [%s] depth %d (%d clusters) %s: plain global step %.4f; H eig min %.3g max %.3g (%d clamped); |theta| max %.3g\n",
                which ? "corot" : "exact", d, m, blend ? "blended" : "piecewise", gap(xG), ev.minCoeff(), ev.maxCoeff(), negative, theta0.cwiseAbs().maxCoeff());
    for (double alpha : {0.5, 1.0, 1.5}) {
      const Eigen::VectorXd theta = alpha * theta0;
      LocalStep s2 = st;
      for (int t = 0; t < K; ++t) {
        Eigen::Vector3d phi = Eigen::Vector3d::Zero();
        for (auto [j, w] : wt[t]) phi += w * theta.segment<3>(3 * j);
        const double ang = phi.norm();
        const Eigen::Matrix3d E = ang > 0 ? Eigen::Matrix3d(Eigen::AngleAxisd(ang, phi / ang)) : Eigen::Matrix3d::Identity();
        const Eigen::Matrix3d Rn = E * R[t];
        Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(s2.Q.data() + 9 * t) = rest.volume(t) * rest.Dm_inv[t] * Rn.transpose();
      }
      Eigen::MatrixXd x2 = Xk;
      full->global_step(x2, s2);
      std::printf("    alpha %.1f: %.4f, +1 %.4f, +2 %.4f\n", alpha, gap(x2), gap(smooth(x2, 1)), gap(smooth(x2, 2)));
    }
    }
  }
  return 0;
}
