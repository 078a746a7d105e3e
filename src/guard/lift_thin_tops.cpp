#include "guard/lift_thin_tops.h"

#include <gshell/solver/polar_decomposition.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace gshell::detail {
namespace {

constexpr double kThinFraction = 0.9; // thinner than this fraction of the wanted offset: a candidate
constexpr int kLevels = 6;            // moves at 1, 1/2, ..., 1/32 of the way
constexpr int kFamilies = 3;          // towards wanted from the top, from the base, along d
// A move is kept only if it could have gone further, by kRoom of the wanted offset (or of the
// move, if longer), and still been valid: a lifted top keeps some room from what stopped it,
// as the repair's barriers keep theirs, instead of ending against it.
constexpr double kRoom = 0.05;

} // namespace

LiftResult lift_thin_tops(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const RestTets& ideal,
                          const Eigen::MatrixXd& wanted, const Eigen::MatrixXd& directions,
                          const std::vector<char>& movable, const StartChecker& checker, int sweeps,
                          Eigen::MatrixXd& top) {
  const int n = static_cast<int>(V.rows());
  LiftResult result;
  // Candidates by position c; per-candidate data is indexed by c, not by vertex, so that a few
  // candidates on a large mesh cost little.
  std::vector<int> candidates, slot(n, -1);
  for (int i = 0; i < n; ++i)
    if (movable[i] && (top.row(i) - V.row(i)).norm() < kThinFraction * (wanted.row(i) - V.row(i)).norm()) {
      slot[i] = static_cast<int>(candidates.size());
      candidates.push_back(i);
    }
  const int count = static_cast<int>(candidates.size());
  result.candidates = count;
  if (count == 0 || sweeps <= 0) return result;

  // The tets holding each candidate's top (compressed rows: those of c are tets[start[c], start[c + 1])).
  std::vector<int> start(count + 1, 0), tets;
  auto for_each_candidate_tet = [&](auto&& visit) {
    for (int t = 0; t < ideal.size(); ++t)
      for (int j = 0; j < 4; ++j)
        if (const int v = ideal.T(t, j); v >= n && slot[v - n] >= 0) visit(slot[v - n], t);
  };
  for_each_candidate_tet([&](int c, int) { ++start[c + 1]; });
  std::partial_sum(start.begin(), start.end(), start.begin());
  tets.resize(start[count]);
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for_each_candidate_tet([&](int c, int t) { tets[fill[c]++] = t; });
  }
  // Groups sharing no face (greedy colouring): a member's tets hold no other member's top. Tet t
  // is one of the three of face t / 3, and every face around a top has a tet holding it.
  std::vector<int> colour(count, -1);
  int colours = 0;
  for (int c = 0; c < count; ++c) {
    std::vector<char> used(colours + 1, 0);
    for (int k = start[c]; k < start[c + 1]; ++k)
      for (int l = 0; l < 3; ++l)
        if (const int d = slot[F(tets[k] / 3, l)]; d >= 0 && colour[d] >= 0) used[colour[d]] = 1;
    colour[c] = static_cast<int>(std::find(used.begin(), used.end(), 0) - used.begin());
    colours = std::max(colours, colour[c] + 1);
  }

  // E over the tets of candidate c's top with that top at p (the others where they are).
  auto local_energy = [&](int c, const Eigen::RowVector3d& p) {
    const int i = candidates[c];
    double e = 0;
    for (int k = start[c]; k < start[c + 1]; ++k) {
      const int t = tets[k];
      auto corner = [&](int j) -> Eigen::Vector3d {
        const int v = ideal.T(t, j);
        if (v == n + i) return p.transpose();
        return v < n ? Eigen::Vector3d(V.row(v).transpose()) : Eigen::Vector3d(top.row(v - n).transpose());
      };
      const Eigen::Vector3d x0 = corner(0);
      Eigen::Matrix3d Ds;
      for (int j = 0; j < 3; ++j) Ds.col(j) = corner(j + 1) - x0;
      const Eigen::Matrix3d Fd = Ds * ideal.dm_inv(t);
      e += ideal.volume[t] * (Fd - closest_rotation(Fd)).squaredNorm();
    }
    return e;
  };
  auto trial = [&](int c, int family, int level) -> Eigen::RowVector3d {
    const int i = candidates[c];
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
  std::vector<std::vector<Trial>> trials(count);
  std::vector<std::size_t> next_trial(count, 0);
  std::vector<Eigen::RowVector3d> before(count);
  std::vector<char> moved(n, 0), check(n, 0); // per vertex, as the checker reads them
  auto settle = [&] {
    result.checks += checker.settle(V, top, moved, check, [&](int i) { top.row(i) = before[slot[i]]; });
  };
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    const int lifted_before = result.lifted;
    for (int group = 0; group < colours; ++group) {
      std::vector<int> pending;
      for (int c = 0; c < count; ++c)
        if (colour[c] == group) pending.push_back(c);
      // The group's neighbours stay put while it moves, so its members' trials are fixed.
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pending.size(), 16), [&](const auto& r) {
        for (std::size_t k = r.begin(); k < r.end(); ++k) {
          const int c = pending[k];
          const double current = local_energy(c, top.row(candidates[c]));
          std::vector<Trial>& list = trials[c];
          list.clear();
          for (int level = 0; level < kLevels; ++level)
            for (int family = 0; family < kFamilies; ++family) {
              const Eigen::RowVector3d p = trial(c, family, level);
              if (const double e = local_energy(c, p); e < current) list.push_back({current - e, p});
            }
          std::sort(list.begin(), list.end(), [](const Trial& x, const Trial& y) { return x.drop > y.drop; });
          next_trial[c] = 0;
        }
      });
      std::erase_if(pending, [&](int c) { return trials[c].empty(); });
      while (!pending.empty()) {
        // First the moves carried further (the room), then the moves themselves; either time,
        // every moved vertex of a violation is put back and what was put back checked again,
        // until the check finds nothing (StartChecker::settle).
        for (int c : pending) {
          const int i = candidates[c];
          before[c] = top.row(i);
          const Eigen::RowVector3d step = trials[c][next_trial[c]].position - before[c];
          const double length = step.norm(); // > 0: a trial lowers the energy, so it moves
          top.row(i) = before[c] + step * (1 + std::max(kRoom * (wanted.row(i) - V.row(i)).norm(), length) / length);
          moved[i] = check[i] = 1;
        }
        settle();
        for (int c : pending)
          if (const int i = candidates[c]; moved[i]) {
            top.row(i) = trials[c][next_trial[c]].position;
            check[i] = 1;
          }
        settle();
        std::vector<int> next;
        for (int c : pending) {
          if (const int i = candidates[c]; moved[i]) {
            moved[i] = 0;
            ++result.lifted;
            result.energy_drop += trials[c][next_trial[c]].drop;
          } else if (++next_trial[c] < trials[c].size()) {
            next.push_back(c);
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
