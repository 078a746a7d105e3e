#include <gshell/guard/contact_guard.h>

#include <gshell/error.h>
#include <gshell/guard/contact_barrier.h>
#include <gshell/guard/pair_ccd.h>

#include "guard/contact_pairs.h"
#include "guard/vertex_block_sum.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>
#include <tuple>

namespace gshell {
namespace {

using Vec3 = Eigen::Vector3d;
using Ids = std::array<int, 4>;

// Pairs per parallel block of a pass over the candidate list. Blocks are fixed, not chosen by
// the scheduler, so per-block results concatenate to the same list whatever the thread count.
constexpr int kBlock = 1024;
// cap_support's smallest support, relative to dhat.
constexpr double kSupportFloor = 1e-2;

void lower_to(std::atomic<double>& bound, double value) {
  double current = bound.load(std::memory_order_relaxed);
  while (value < current && !bound.compare_exchange_weak(current, value, std::memory_order_relaxed)) {
  }
}

// Runs body(begin, end, block) over fixed blocks of [0, n).
template <class Body> void for_blocks(int n, Body&& body) {
  const int blocks = (n + kBlock - 1) / kBlock;
  tbb::parallel_for(0, blocks, [&](int b) { body(b * kBlock, std::min(n, (b + 1) * kBlock), b); });
}

} // namespace

struct ContactGuard::Impl {
  detail::ContactPrimitives primitives;
  ContactOptions options;
  double radius; // the candidate list holds the pairs closer than this when it was built

  // The candidate list per PairKind, sorted by primitive ids: vertex ids, and the distance at the
  // build rounded down to a float. A pair at d_b then is at least d_b - 2 drift apart at x.
  std::vector<Ids> pairs[2];
  std::vector<float> built_distance[2];
  std::vector<Vec3> built_at; // positions at the last build
  int builds = 0;
  // A patch made at its first use after new options and refit at the next ones: a deforming shell
  // keeps neighbouring triangles near each other, so the tree stays compact, and a refit costs a
  // pass over the boxes where a new tree sorts them and takes fresh memory.
  struct KeptPatch {
    detail::ContactPatch patch;
    bool made = false;
  };
  KeptPatch movable_patch; // the candidate search's movable patch
  KeptPatch swept[2];      // step_bound's patches of swept boxes: fixed, movable
  // The fixed patch of the broad phase, kept while its vertices stay where they were.
  detail::ContactPatch fixed_patch;
  std::vector<Vec3> fixed_patch_at; // positions of fixed_patch_vertices() when it was made
  bool have_fixed_patch = false;
  // A solver that moves a small region of a large shell (the repair of a few thin spots) would
  // spend most of a build on the fixed patch's tree over the whole shell. Where the movable
  // triangles are few the fixed patch holds only the fixed triangles within `reach` of them: those
  // whose boxes meet a movable triangle's box grown by `reach` around the corners' positions
  // `reach_at` when it was cut. It serves every search whose movable boxes stay inside those
  // grown boxes, and is cut again (reach doubled) when one would leave them.
  bool cut_to_reach = false;
  double reach = std::numeric_limits<double>::infinity();
  std::vector<Vec3> reach_at; // positions of movable_patch_vertices() at the cut, in that order
  int fixed_patch_cuts = 0;
  // step_bound's per-vertex motions (zero between calls) and swept boxes (read only where written).
  std::vector<Vec3> step_dx;
  std::vector<Eigen::AlignedBox3d> step_box;
  double drift = 0; // largest displacement of a boundary vertex from built_at, at x

  std::vector<Vec3> x; // the last X seen, packed (a pair's point is one cache line)
  bool have_x = false;
  bool stale = true; // the candidate list must be made at the next positions (new options)
  std::vector<char> on_boundary; // per vertex: used by a boundary triangle
  // cap_support's per-vertex caps on the support (model units); empty: every pair's is dhat.
  std::vector<double> support_cap;

  // The last pass over the list, at x: pairs closer than their support, in list order.
  bool scanned = false;
  struct Active {
    PairKind kind;
    int index;
    double support; // the pair's dhat (support())
    double energy;  // its barrier, weighted
  };
  std::vector<Active> active;
  int last_active = 0; // active.size() at the last pass (kept when x moves on)
  double min_squared = std::numeric_limits<double>::infinity();
  bool touching = false;

  Impl(const ShellBoundary& boundary, int num_vertices, const std::vector<char>& movable, const ContactOptions& o,
       const std::vector<char>& excluded)
      : primitives(boundary, num_vertices, movable, excluded) {
    on_boundary.assign(num_vertices, 0);
    for (int v : primitives.boundary_vertices()) on_boundary[v] = 1;
    // Cutting costs a box test per fixed triangle and pays when it leaves most of them out.
    cut_to_reach = 8 * primitives.movable_triangles().size() <= primitives.fixed_triangles().size();
    set_options(o);
  }

  // Checks and takes the options; the candidate list and the fixed patch are made afresh at the
  // next positions (their reach depends on the radius).
  void set_options(const ContactOptions& o) {
    if (!(o.dhat > 0) || !std::isfinite(o.dhat))
      throw InputError("ContactGuard: dhat must be positive and finite (got " + std::to_string(o.dhat) + ")");
    if (!(o.slack >= 0) || !std::isfinite(o.slack))
      throw InputError("ContactGuard: slack must be >= 0 and finite (got " + std::to_string(o.slack) + ")");
    if (!(o.keep_fraction > 0 && o.keep_fraction < 1))
      throw InputError("ContactGuard: keep_fraction must be in (0, 1) (got " + std::to_string(o.keep_fraction) + ")");
    options = o;
    if (options.slack == 0) options.slack = options.dhat;
    radius = options.dhat + options.slack;
    reach = cut_to_reach ? 4 * radius : std::numeric_limits<double>::infinity();
    have_fixed_patch = false;
    movable_patch.made = swept[0].made = swept[1].made = false;
    stale = true;
  }

  // Every boundary vertex's box at x grown by radius / 2: what the candidate list and the fixed
  // patch are searched with.
  std::vector<Eigen::AlignedBox3d> search_boxes() const {
    const Vec3 grow = Vec3::Constant(radius / 2);
    std::vector<Eigen::AlignedBox3d> box(primitives.num_vertices());
    for (int v : primitives.boundary_vertices()) box[v] = Eigen::AlignedBox3d(x[v] - grow, x[v] + grow);
    return box;
  }

  // Whether the fixed patch holds every fixed triangle a movable triangle can meet when each
  // movable patch vertex k, at x, grows its box by at most extent(k) beyond radius / 2 (0 at a
  // build; a swept step's motion in step_bound).
  template <class Extent> bool fixed_patch_covers(Extent&& extent) const {
    if (!have_fixed_patch) return false;
    if (!cut_to_reach) return true;
    const std::vector<int>& corners = primitives.movable_patch_vertices();
    for (std::size_t k = 0; k < corners.size(); ++k)
      if ((x[corners[k]] - reach_at[k]).lpNorm<Eigen::Infinity>() + extent(k) > reach) return false;
    return true;
  }

  // The fixed patch, grown by radius / 2 around x; cut to the reach vertices' boxes grown by
  // radius / 2 + reach (reach raised to at least twice the largest extent) where cut_to_reach.
  template <class Extent> void make_fixed_patch(const std::vector<Eigen::AlignedBox3d>& box, Extent&& extent) {
    const std::vector<int>& fixed_vertices = primitives.fixed_patch_vertices();
    if (!cut_to_reach) {
      fixed_patch = primitives.patch(false, box);
    } else {
      const std::vector<int>& corners = primitives.movable_patch_vertices();
      double largest = 0;
      for (std::size_t k = 0; k < corners.size(); ++k) largest = std::max(largest, extent(k));
      if (have_fixed_patch) reach *= 2; // the region moved out of it: cut wider, less often
      reach = std::max(reach, 2 * largest);
      reach_at.resize(corners.size());
      for (std::size_t k = 0; k < corners.size(); ++k) reach_at[k] = x[corners[k]];
      // Each movable triangle's corners' boxes grown by reach around x.
      const Vec3 grow = Vec3::Constant(radius / 2 + reach);
      const std::vector<int>& movable = primitives.movable_triangles();
      std::vector<Eigen::AlignedBox3d> reach_box(movable.size());
      for (std::size_t i = 0; i < movable.size(); ++i) {
        const auto& c = primitives.triangle(movable[i]);
        reach_box[i] = Eigen::AlignedBox3d(x[c[0]]);
        reach_box[i].extend(x[c[1]]).extend(x[c[2]]);
        reach_box[i].min() -= grow;
        reach_box[i].max() += grow;
      }
      const detail::FaceBvh reach_tree(reach_box);
      fixed_patch = primitives.patch(false, box, &reach_tree);
    }
    fixed_patch_at.resize(fixed_vertices.size());
    for (std::size_t i = 0; i < fixed_vertices.size(); ++i) fixed_patch_at[i] = x[fixed_vertices[i]];
    have_fixed_patch = true;
    ++fixed_patch_cuts;
  }

  // The movable or fixed patch over `box`, kept in `kept`.
  const detail::ContactPatch& kept_patch(KeptPatch& kept, bool movable, const std::vector<Eigen::AlignedBox3d>& box) {
    if (kept.made) {
      primitives.refit(kept.patch, box);
    } else {
      kept.patch = primitives.patch(movable, box);
      kept.made = true;
    }
    return kept.patch;
  }

  // A pair's support: dhat, or less where cap_support capped one of its vertices.
  double support(const Ids& ids) const {
    double s = options.dhat;
    if (!support_cap.empty())
      for (int v : ids) s = std::min(s, support_cap[v]);
    return s;
  }
  // A pair's barrier weight, (dhat / support)^3: every pair pushes as hard at half its support.
  double weight(double support) const {
    const double r = options.dhat / support;
    return r * r * r;
  }

  PairPoints points(const Ids& ids) const { return {x[ids[0]], x[ids[1]], x[ids[2]], x[ids[3]]}; }

  void check_shape(const Eigen::MatrixXd& M, const char* name) const {
    if (M.rows() != primitives.num_vertices() || M.cols() != 3)
      throw InputError(std::string("ContactGuard: ") + name + " is " + std::to_string(M.rows()) + " x " +
                       std::to_string(M.cols()) + ", expected " + std::to_string(primitives.num_vertices()) + " x 3");
  }

  void check_finite(const std::vector<Vec3>& v, const char* name) const {
    for (int i : primitives.boundary_vertices())
      if (!v[i].allFinite())
        throw InputError(std::string("ContactGuard: ") + name + " has a non-finite coordinate at vertex " +
                         std::to_string(i));
  }

  // Makes X the current positions and the candidate list valid for it.
  void set_positions(const Eigen::MatrixXd& X) {
    check_shape(X, "X");
    const int n = primitives.num_vertices();
    if (!have_x) {
      x.assign(n, Vec3::Zero());
      // The patches' float boxes are measured in the frame of the boundary where the guard starts.
      Eigen::AlignedBox3d extent;
      for (int v : primitives.boundary_vertices()) extent.extend(X.row(v).transpose());
      primitives.set_frame(detail::CoverFrame::of_extent(extent));
    }
    // One pass: copy X, note whether it differs from the last X, and the drift since the build.
    struct Change {
      bool changed = false;
      double drift2 = 0; // NaN sticks (a non-finite X forces the rebuild, which reports it)
    };
    auto larger = [](double a, double b) { return std::isnan(a) || a > b ? a : b; };
    const bool built = builds > 0;
    const Change change = tbb::parallel_reduce(
        tbb::blocked_range<int>(0, n, 4096), Change{},
        [&](const tbb::blocked_range<int>& r, Change c) {
          for (int i = r.begin(); i < r.end(); ++i) {
            const Vec3 p(X(i, 0), X(i, 1), X(i, 2));
            if (p != x[i]) {
              c.changed = true;
              x[i] = p;
            }
            if (built && on_boundary[i]) c.drift2 = larger(c.drift2, (p - built_at[i]).squaredNorm());
          }
          return c;
        },
        [&](Change a, const Change& b) {
          a.changed = a.changed || b.changed;
          a.drift2 = larger(a.drift2, b.drift2);
          return a;
        });
    if (have_x && !change.changed && !stale) return;
    have_x = true;
    scanned = false;
    drift = std::sqrt(change.drift2);
    if (built && !stale && drift <= options.slack / 2) return;
    build();
  }

  void build() {
    check_finite(x, "X");
    const std::vector<Eigen::AlignedBox3d> box = search_boxes();
    struct Found {
      std::uint64_t key; // primitive ids a, b
      Ids ids;
      float distance;
    };
    const std::vector<int>& fixed_vertices = primitives.fixed_patch_vertices();
    bool fixed_moved = fixed_patch_at.size() != fixed_vertices.size();
    for (std::size_t i = 0; i < fixed_vertices.size() && !fixed_moved; ++i)
      fixed_moved = x[fixed_vertices[i]] != fixed_patch_at[i];
    auto at_rest = [](std::size_t) { return 0.0; };
    if (fixed_moved) have_fixed_patch = false;
    if (!fixed_patch_covers(at_rest)) make_fixed_patch(box, at_rest);
    tbb::enumerable_thread_specific<std::array<std::vector<Found>, 2>> found;
    const double radius2 = radius * radius;
    primitives.for_each_pair(kept_patch(movable_patch, true, box), fixed_patch, [&](PairKind kind, int a, int b, const Ids& ids) {
      const double d2 = pair_squared_distance(kind, points(ids));
      if (!(d2 < radius2)) return;
      const float d = std::nextafter(static_cast<float>(std::sqrt(d2)), 0.0f); // <= the distance
      found.local()[static_cast<int>(kind)].push_back(
          {static_cast<std::uint64_t>(a) << 32 | static_cast<std::uint32_t>(b), ids, std::max(d, 0.0f)});
    });
    for (int k = 0; k < 2; ++k) {
      std::vector<Found> all;
      for (const auto& local : found) all.insert(all.end(), local[k].begin(), local[k].end());
      tbb::parallel_sort(all.begin(), all.end(), [](const Found& p, const Found& q) { return p.key < q.key; });
      pairs[k].resize(all.size());
      built_distance[k].resize(all.size());
      for (std::size_t i = 0; i < all.size(); ++i) {
        pairs[k][i] = all[i].ids;
        built_distance[k][i] = all[i].distance;
      }
    }
    built_at = x;
    drift = 0;
    ++builds;
    stale = false;
    scanned = false;
  }

  // Distances of every candidate at x: the active pairs, the smallest distance.
  void scan(const Eigen::MatrixXd& X) {
    set_positions(X);
    if (scanned) return;
    const double s_hat = options.dhat * options.dhat;
    active.clear();
    min_squared = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 2; ++k) {
      const PairKind kind = static_cast<PairKind>(k);
      const std::vector<Ids>& list = pairs[k];
      const int blocks = (static_cast<int>(list.size()) + kBlock - 1) / kBlock;
      std::vector<std::vector<Active>> block_active(blocks);
      std::vector<double> block_min(blocks, std::numeric_limits<double>::infinity());
      const std::vector<float>& built = built_distance[k];
      const double cut = options.dhat + 2 * drift; // pairs beyond it at the build are inactive now
      for_blocks(static_cast<int>(list.size()), [&](int begin, int end, int b) {
        double m = std::numeric_limits<double>::infinity();
        for (int i = begin; i < end; ++i) {
          if (built[i] >= cut) continue;
          const double d2 = pair_squared_distance(kind, points(list[i]));
          m = std::min(m, d2);
          if (!(d2 < s_hat)) continue; // beyond every support
          const double support = this->support(list[i]);
          if (d2 < support * support)
            block_active[b].push_back(
                {kind, i, support, weight(support) * pair_barrier_energy(kind, points(list[i]), d2, support)});
        }
        block_min[b] = m;
      });
      for (int b = 0; b < blocks; ++b) {
        active.insert(active.end(), block_active[b].begin(), block_active[b].end());
        min_squared = std::min(min_squared, block_min[b]);
      }
    }
    touching = !(min_squared > 0);
    last_active = static_cast<int>(active.size());
    scanned = true;
  }

  // Smallest squared distance over the whole list at x.
  double list_min_squared() const {
    double best = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 2; ++k)
      best = std::min(best, tbb::parallel_reduce(
                                tbb::blocked_range<int>(0, static_cast<int>(pairs[k].size()), kBlock),
                                std::numeric_limits<double>::infinity(),
                                [&](const tbb::blocked_range<int>& r, double m) {
                                  for (int i = r.begin(); i < r.end(); ++i)
                                    m = std::min(m, pair_squared_distance(static_cast<PairKind>(k), points(pairs[k][i])));
                                  return m;
                                },
                                [](double a, double b) { return std::min(a, b); }));
    return best;
  }

  const Ids& ids(const Active& a) const { return pairs[static_cast<int>(a.kind)][a.index]; }
};

ContactGuard::ContactGuard(const ShellBoundary& boundary, int num_vertices, std::vector<char> movable,
                           const ContactOptions& options, std::vector<char> excluded_triangles)
    : impl_(std::make_unique<Impl>(boundary, num_vertices, movable, options, excluded_triangles)) {}
ContactGuard::~ContactGuard() = default;
ContactGuard::ContactGuard(ContactGuard&&) noexcept = default;
ContactGuard& ContactGuard::operator=(ContactGuard&&) noexcept = default;

double ContactGuard::energy(const Eigen::MatrixXd& X) {
  Impl& m = *impl_;
  m.scan(X);
  if (m.touching) return std::numeric_limits<double>::infinity();
  double sum = 0;
  for (const Impl::Active& a : m.active) sum += a.energy; // list order: the same bits for the same X
  return sum;
}

void ContactGuard::add_gradient(const Eigen::MatrixXd& X, double scale, Eigen::MatrixXd& G) {
  Impl& m = *impl_;
  m.scan(X);
  m.check_shape(G, "G");
  std::vector<Vector12d> g(m.active.size());
  tbb::parallel_for(0, static_cast<int>(g.size()), [&](int i) {
    g[i].setZero(); // stays zero for a touching pair (no gradient there)
    const Impl::Active& a = m.active[i];
    pair_barrier(a.kind, m.points(m.ids(a)), a.support, &g[i]);
    g[i] *= m.weight(a.support);
  });
  for (std::size_t i = 0; i < g.size(); ++i) {
    const Ids& ids = m.ids(m.active[i]);
    for (int k = 0; k < 4; ++k) G.row(ids[k]) += scale * g[i].segment<3>(3 * k).transpose();
  }
}

void ContactGuard::add_hessian(const Eigen::MatrixXd& X, double scale, std::vector<Eigen::Triplet<double>>& H,
                               bool projected, const std::vector<char>* kept_vertices) {
  Impl& m = *impl_;
  if (kept_vertices && kept_vertices->size() != static_cast<std::size_t>(m.primitives.num_vertices()))
    throw InputError("ContactGuard::add_hessian: expected one flag per vertex in `kept_vertices`");
  auto kept = [&](int vertex) { return !kept_vertices || (*kept_vertices)[vertex]; };
  m.scan(X);
  const int n = static_cast<int>(m.active.size());
  // The pairs' blocks are made in parallel, a chunk at a time, and summed per vertex pair in list
  // order: the matrix a caller builds is the one the pairs' own triplets gave, bit for bit, from a
  // fraction of the triplets where pairs crowd (a thin strand's top vertices have hundreds each;
  // their triplets and the sort that summed them were half of such a repair's time).
  detail::VertexBlockSum sum(4 * static_cast<std::size_t>(n));
  const int chunk = std::min(n, 4 * kBlock);
  std::vector<Matrix12d> h(chunk);
  std::vector<char> writes(chunk);
  for (int first = 0; first < n; first += chunk) {
    const int count = std::min(chunk, n - first);
    for_blocks(count, [&](int begin, int end, int) {
      for (int k = begin; k < end; ++k) {
        const Impl::Active& active = m.active[first + k];
        const Ids& ids = m.ids(active);
        writes[k] = std::any_of(ids.begin(), ids.end(), kept);
        if (!writes[k]) continue;
        if (projected) {
          h[k].setZero(); // stays zero for a touching pair
          pair_barrier(active.kind, m.points(ids), active.support, nullptr, &h[k]);
          project_to_psd(h[k]);
        } else {
          h[k] = pair_barrier_gauss_newton(active.kind, m.points(ids), active.support);
        }
        h[k] *= m.weight(active.support);
      }
    });
    for (int k = 0; k < count; ++k) {
      if (!writes[k]) continue;
      const Ids& ids = m.ids(m.active[first + k]);
      for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b)
          if (kept(ids[a]) && kept(ids[b])) sum.add(ids[a], ids[b], h[k].block<3, 3>(3 * a, 3 * b), scale);
    }
  }
  sum.append_to(H);
}

double ContactGuard::step_bound(const Eigen::MatrixXd& X, const Eigen::MatrixXd& D, double max_step,
                                std::vector<ContactPair>* cutting, const std::vector<char>* touching) {
  if (cutting) cutting->clear();
  return sweep_step(X, D, max_step, cutting, touching, nullptr);
}

void ContactGuard::flag_cutting_vertices(const Eigen::MatrixXd& X, const Eigen::MatrixXd& D, double max_step,
                                         std::vector<char>& held, const std::vector<char>* touching) {
  if (held.size() != static_cast<std::size_t>(impl_->primitives.num_vertices()))
    throw InputError("ContactGuard::flag_cutting_vertices: expected one flag per vertex in `held`");
  sweep_step(X, D, max_step, nullptr, touching, &held);
}

double ContactGuard::sweep_step(const Eigen::MatrixXd& X, const Eigen::MatrixXd& D, double max_step,
                                std::vector<ContactPair>* cutting, const std::vector<char>* touching,
                                std::vector<char>* held) {
  Impl& m = *impl_;
  m.set_positions(X);
  m.check_shape(D, "D");
  if (touching && touching->size() != static_cast<std::size_t>(m.primitives.num_vertices()))
    throw InputError("ContactGuard::step_bound: expected one flag per vertex in `touching`");
  if (!(max_step > 0)) return 0;
  const std::vector<int>& verts = m.primitives.boundary_vertices();
  // The boundary vertices D moves, ascending, and their motions in dx (zero elsewhere, kept between
  // calls): a guard repairing a small region of a large shell visits that region, not every vertex.
  std::vector<int> moving;
  for (int v : verts)
    if (!D.row(v).isZero(0)) moving.push_back(v);
  std::vector<Vec3>& dx = m.step_dx;
  dx.resize(m.primitives.num_vertices(), Vec3::Zero());
  struct Clear { // back to zero however this returns
    std::vector<Vec3>& dx;
    const std::vector<int>& moving;
    ~Clear() {
      for (int v : moving) dx[v].setZero();
    }
  } clear{dx, moving};
  for (int v : moving) {
    dx[v] = D.row(v).transpose();
    if (!dx[v].allFinite())
      throw InputError("ContactGuard: D has a non-finite coordinate at vertex " + std::to_string(v));
  }
  const bool some_still = moving.size() < verts.size();

  // Distances are invariant under a common translation: measure displacements from the centre c
  // of their bounding box, at most rho from it. A pair's distance then falls at most at 2 rho.
  Eigen::AlignedBox3d range;
  if (some_still) range.extend(Vec3::Zero());
  for (int v : moving) range.extend(dx[v]);
  if (verts.empty()) return max_step;
  const Vec3 c = range.center();
  double rho = some_still ? c.norm() : 0;
  for (int v : moving) rho = std::max(rho, (dx[v] - c).norm());
  if (rho == 0) return max_step;

  const PairCcdOptions ccd{m.options.keep_fraction, m.options.dhat};
  // alpha culls the pairs that cannot cut the step further; collecting every cutting pair (or
  // its vertices), it stays at max_step and `least` keeps the bound.
  const bool collecting = cutting || held;
  // Flags are read and set by both threads: a pair passed over because another thread flagged
  // its vertices first would have set nothing new.
  auto flagged = [&](int v) { return std::atomic_ref<char>((*held)[v]).load(std::memory_order_relaxed) != 0; };
  auto moves = [&](int v) { return !dx[v].isZero(0); };
  std::atomic<double> alpha(max_step), least(max_step);
  std::mutex cutting_mutex;
  // Each pair's bound over a fixed range (max_step, then the listed pairs' bound), not below the
  // running minimum: the CCD's rounding allowance depends on its range and the running minimum on
  // the thread schedule, so the result would not be the same bits run to run.
  double ccd_range = max_step;
  auto bound_pair = [&](PairKind kind, const Ids& ids) {
    if (touching && !std::any_of(ids.begin(), ids.end(), [&](int v) { return (*touching)[v]; })) return;
    if (held && std::all_of(ids.begin(), ids.end(), [&](int v) { return !moves(v) || flagged(v); })) return;
    const PairPoints p = m.points(ids), d = {dx[ids[0]], dx[ids[1]], dx[ids[2]], dx[ids[3]]};
    const double pb = pair_step_bound(kind, p, d, ccd_range, ccd);
    if (!collecting) {
      lower_to(alpha, pb);
    } else if (pb < max_step) {
      lower_to(least, pb);
      if (held) {
        for (int v : ids)
          if (moves(v)) std::atomic_ref<char>((*held)[v]).store(1, std::memory_order_relaxed);
        return;
      }
      const std::lock_guard<std::mutex> lock(cutting_mutex);
      cutting->push_back({kind, ids});
    }
  };
  auto result = [&] {
    if (!cutting) return collecting ? least.load() : alpha.load();
    // A pair can be visited by both passes below.
    auto order = [](const ContactPair& a, const ContactPair& b) {
      return std::tie(a.kind, a.vertices) < std::tie(b.kind, b.vertices);
    };
    std::sort(cutting->begin(), cutting->end(), order);
    cutting->erase(std::unique(cutting->begin(), cutting->end()), cutting->end());
    return least.load();
  };
  // A listed pair at d_b at the build is at least d_b - 2 drift - 2 rho alpha apart along the
  // step, never below its floor while that exceeds keep_fraction * dhat: no CCD needed.
  const double floor_max = m.options.keep_fraction * m.options.dhat;
  for (int k = 0; k < 2; ++k) {
    const std::vector<float>& built = m.built_distance[k];
    for_blocks(static_cast<int>(m.pairs[k].size()), [&](int begin, int end, int) {
      for (int i = begin; i < end; ++i)
        if (built[i] - 2 * m.drift < 2 * rho * alpha.load(std::memory_order_relaxed) + floor_max)
          bound_pair(static_cast<PairKind>(k), m.pairs[k][i]);
    });
  }

  // Pairs off the list are at least radius - 2 drift apart: they cannot reach floor_max before
  // alpha_far.
  const double alpha_far = (m.radius - 2 * m.drift - floor_max) / (2 * rho);
  const double listed = alpha.load();
  if (alpha_far >= listed) return result();
  ccd_range = listed;

  // A longer step: every pair whose boxes, swept over [0, listed] and grown by half the largest
  // floor, meet (only those can come that close) gets its own CCD. When the fixed patch's vertices
  // do not move, its cached tree serves as it is: its boxes, grown by (dhat + slack) / 2 around
  // positions at most slack / 2 away, hold those vertices grown by the floor. Only the movable
  // patch is swept then (at rest); otherwise all is, in the frame moving with c.
  const bool fixed_still =
      std::none_of(moving.begin(), moving.end(), [&](int v) { return m.primitives.in_fixed_patch(v); });
  const Vec3 frame = fixed_still ? Vec3::Zero() : c;
  const Vec3 grow = Vec3::Constant(floor_max / 2);
  auto swept = [&](int v) {
    Eigen::AlignedBox3d b(m.x[v]);
    b.extend(m.x[v] + listed * (dx[v] - frame));
    b.min() -= grow;
    b.max() += grow;
    return b;
  };
  // The fixed patch kept, a cut one at that, reads only the movable triangles' corners' boxes.
  const bool region_only = fixed_still && m.cut_to_reach;
  std::vector<Eigen::AlignedBox3d> all_boxes;
  if (region_only) m.step_box.resize(m.primitives.num_vertices());
  else all_boxes.resize(m.primitives.num_vertices());
  std::vector<Eigen::AlignedBox3d>& box = region_only ? m.step_box : all_boxes;
  for (int v : region_only ? m.primitives.movable_patch_vertices() : verts) box[v] = swept(v);
  auto visit = [&](PairKind kind, int, int, const Ids& ids) { bound_pair(kind, ids); };
  if (fixed_still) {
    // The swept boxes stay within the fixed patch's reach, or it is cut again around them.
    const std::vector<int>& corners = m.primitives.movable_patch_vertices();
    auto sweep = [&](std::size_t k) { return listed * dx[corners[k]].lpNorm<Eigen::Infinity>(); };
    if (!m.fixed_patch_covers(sweep)) m.make_fixed_patch(m.search_boxes(), sweep);
    m.primitives.for_each_pair(m.kept_patch(m.swept[1], true, box), m.fixed_patch, visit, touching);
  } else {
    m.primitives.for_each_pair(m.kept_patch(m.swept[1], true, box), m.kept_patch(m.swept[0], false, box), visit,
                               touching);
  }
  return result();
}

int ContactGuard::active_pairs() const { return impl_->last_active; }

void ContactGuard::cap_support(const Eigen::MatrixXd& X, double fraction) {
  Impl& m = *impl_;
  if (!(fraction > 0 && fraction <= 1))
    throw InputError("ContactGuard::cap_support: fraction must be in (0, 1] (got " + std::to_string(fraction) + ")");
  m.support_cap.clear();
  m.set_positions(X);
  std::vector<double> cap(m.primitives.num_vertices(), std::numeric_limits<double>::infinity());
  for (int k = 0; k < 2; ++k)
    for (const Ids& ids : m.pairs[k]) {
      const double d = std::sqrt(pair_squared_distance(static_cast<PairKind>(k), m.points(ids)));
      for (int v : ids) cap[v] = std::min(cap[v], fraction * d);
    }
  // A pair (nearly) touching at X would get (nearly) no support; the floor bounds its weight.
  for (double& c : cap) c = std::max(c, kSupportFloor * m.options.dhat);
  m.support_cap = std::move(cap);
  m.scanned = false;
}

double ContactGuard::min_distance(const Eigen::MatrixXd& X) {
  impl_->set_positions(X);
  return std::min(std::sqrt(impl_->list_min_squared()), impl_->radius);
}

std::vector<ContactPair> ContactGuard::candidate_pairs() const {
  std::vector<ContactPair> out;
  for (int k = 0; k < 2; ++k)
    for (const Ids& ids : impl_->pairs[k]) out.push_back({static_cast<PairKind>(k), ids});
  return out;
}

void ContactGuard::set_options(const ContactOptions& options) { impl_->set_options(options); }

int ContactGuard::candidate_builds() const { return impl_->builds; }

int ContactGuard::fixed_patch_builds() const { return impl_->fixed_patch_cuts; }

std::vector<char> unprotected_rows(const ShellBoundary& boundary, const std::vector<char>& excluded, int num_vertices) {
  std::vector<char> corner(num_vertices, 0), out(boundary.size(), 0);
  for (int r = 0; r < boundary.size(); ++r)
    if (excluded[r])
      for (int k = 0; k < 3; ++k) corner[boundary.F(r, k)] = 1;
  for (int r = 0; r < boundary.size(); ++r)
    out[r] = corner[boundary.F(r, 0)] || corner[boundary.F(r, 1)] || corner[boundary.F(r, 2)];
  return out;
}

} // namespace gshell
