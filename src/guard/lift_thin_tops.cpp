#include "guard/lift_thin_tops.h"

#include <gshell/solver/polar_decomposition.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace gshell::detail {
namespace {

constexpr double kThinFraction = 0.9; // thinner than this fraction of the wanted offset: a candidate
constexpr int kLevels = 6;            // moves at 1, 1/2, ..., 1/32 of the way
constexpr int kFamilies = 3;          // towards wanted from the top, from the base, along d
// A move is kept only if it could have gone further, by kRoom of the wanted offset (or of the
// move, if longer), and still been valid: a lifted top keeps some room from what stopped it,
// as the repair's barriers keep theirs, instead of ending against it.
constexpr double kRoom = 0.05;

// Compressed rows: items of key k are items[start[k], start[k + 1]).
struct Rows {
  std::vector<int> start, items;
  template <class Each> static Rows build(int keys, Each&& each) { // each(emit(key, item))
    Rows r;
    r.start.assign(keys + 1, 0);
    each([&](int key, int) { ++r.start[key + 1]; });
    for (int k = 0; k < keys; ++k) r.start[k + 1] += r.start[k];
    r.items.resize(r.start[keys]);
    std::vector<int> fill(r.start.begin(), r.start.end() - 1);
    each([&](int key, int item) { r.items[fill[key]++] = item; });
    return r;
  }
};

} // namespace

LiftResult lift_thin_tops(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const RestTets& ideal,
                          const Eigen::MatrixXd& wanted, const Eigen::MatrixXd& directions,
                          const std::vector<char>& movable, const StartChecker& checker, int sweeps,
                          Eigen::MatrixXd& top) {
  const int n = static_cast<int>(V.rows()), m = static_cast<int>(F.rows());
  LiftResult result;
  std::vector<int> candidates;
  std::vector<char> is_candidate(n, 0);
  for (int i = 0; i < n; ++i)
    if (movable[i] && (top.row(i) - V.row(i)).norm() < kThinFraction * (wanted.row(i) - V.row(i)).norm()) {
      candidates.push_back(i);
      is_candidate[i] = 1;
    }
  result.candidates = static_cast<int>(candidates.size());
  if (candidates.empty() || sweeps <= 0) return result;

  const Rows tets_of = Rows::build(n, [&](auto emit) {
    for (int t = 0; t < ideal.size(); ++t)
      for (int j = 0; j < 4; ++j)
        if (const int v = ideal.T(t, j); v >= n && is_candidate[v - n]) emit(v - n, t);
  });
  const Rows faces_of = Rows::build(n, [&](auto emit) {
    for (int f = 0; f < m; ++f)
      for (int k = 0; k < 3; ++k)
        if (is_candidate[F(f, k)]) emit(F(f, k), f);
  });
  // Groups sharing no face (greedy colouring): a member's tets hold no other member's top.
  std::vector<int> colour(n, -1);
  int colours = 0;
  for (int i : candidates) {
    std::vector<char> used(colours + 1, 0);
    for (int k = faces_of.start[i]; k < faces_of.start[i + 1]; ++k)
      for (int l = 0; l < 3; ++l)
        if (const int c = colour[F(faces_of.items[k], l)]; c >= 0) used[c] = 1;
    colour[i] = static_cast<int>(std::find(used.begin(), used.end(), 0) - used.begin());
    colours = std::max(colours, colour[i] + 1);
  }

  // E over the tets of top vertex i with that vertex at p (the others where they are).
  auto local_energy = [&](int i, const Eigen::RowVector3d& p) {
    double e = 0;
    for (int k = tets_of.start[i]; k < tets_of.start[i + 1]; ++k) {
      const int t = tets_of.items[k];
      auto corner = [&](int j) -> Eigen::Vector3d {
        const int v = ideal.T(t, j);
        if (v == n + i) return p.transpose();
        return v < n ? Eigen::Vector3d(V.row(v).transpose()) : Eigen::Vector3d(top.row(v - n).transpose());
      };
      const Eigen::Vector3d x0 = corner(0);
      Eigen::Matrix3d Ds;
      for (int j = 0; j < 3; ++j) Ds.col(j) = corner(j + 1) - x0;
      const Eigen::Matrix3d Fd = Ds * ideal.Dm_inv[t];
      e += ideal.volume[t] * (Fd - closest_rotation(Fd)).squaredNorm();
    }
    return e;
  };
  auto trial = [&](int i, int family, int level) -> Eigen::RowVector3d {
    const double s = std::ldexp(1.0, -level);
    switch (family) {
    case 0: return top.row(i) + s * (wanted.row(i) - top.row(i));
    case 1: return V.row(i) + s * (wanted.row(i) - V.row(i));
    default: return V.row(i) + s * (wanted.row(i) - V.row(i)).norm() * directions.row(i);
    }
  };

  // Per member of the group being lifted: its energy-lowering trials, largest drop first, and
  // the one it tries next.
  struct Trial {
    double drop; // of the energy of the vertex's tets
    Eigen::RowVector3d position;
  };
  std::vector<std::vector<Trial>> trials(n);
  std::vector<std::size_t> next_trial(n, 0);
  std::vector<Eigen::RowVector3d> before(n);
  std::vector<char> moved(n, 0), check(n, 0);
  auto settle = [&] {
    result.checks += checker.settle(V, top, moved, check, [&](int i) { top.row(i) = before[i]; });
  };
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    const int lifted_before = result.lifted;
    for (int c = 0; c < colours; ++c) {
      std::vector<int> pending;
      for (int i : candidates)
        if (colour[i] == c) pending.push_back(i);
      // The group's neighbours stay put while it moves, so its members' trials are fixed.
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pending.size(), 16), [&](const auto& r) {
        for (std::size_t k = r.begin(); k < r.end(); ++k) {
          const int i = pending[k];
          const double current = local_energy(i, top.row(i));
          std::vector<Trial>& list = trials[i];
          list.clear();
          for (int level = 0; level < kLevels; ++level)
            for (int family = 0; family < kFamilies; ++family) {
              const Eigen::RowVector3d p = trial(i, family, level);
              if (const double e = local_energy(i, p); e < current) list.push_back({current - e, p});
            }
          std::sort(list.begin(), list.end(), [](const Trial& x, const Trial& y) { return x.drop > y.drop; });
          next_trial[i] = 0;
        }
      });
      std::erase_if(pending, [&](int i) { return trials[i].empty(); });
      while (!pending.empty()) {
        // First the moves carried further (the room), then the moves themselves; either time,
        // every moved vertex of a violation is put back and what was put back checked again,
        // until the check finds nothing (as the valid start's bisection does).
        for (int i : pending) {
          before[i] = top.row(i);
          const Eigen::RowVector3d step = trials[i][next_trial[i]].position - before[i];
          const double length = step.norm(); // > 0: a trial lowers the energy, so it moves
          top.row(i) = before[i] + step * (1 + std::max(kRoom * (wanted.row(i) - V.row(i)).norm(), length) / length);
          moved[i] = check[i] = 1;
        }
        settle();
        for (int i : pending)
          if (moved[i]) {
            top.row(i) = trials[i][next_trial[i]].position;
            check[i] = 1;
          }
        settle();
        std::vector<int> next;
        for (int i : pending) {
          if (moved[i]) {
            moved[i] = 0;
            ++result.lifted;
            result.energy_drop += trials[i][next_trial[i]].drop;
          } else if (++next_trial[i] < trials[i].size()) {
            next.push_back(i);
          }
        }
        pending.swap(next);
      }
    }
    if (result.lifted == lifted_before) break;
  }
  return result;
}

} // namespace gshell::detail
