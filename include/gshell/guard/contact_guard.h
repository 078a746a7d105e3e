#pragma once
// Contacts between the boundary triangles of a shell (top, base, side walls: shell_boundary()),
// for solvers that must keep the layer free of intersections while they move it:
// - a barrier that grows without bound as two boundary primitives approach each other and is
//   exactly zero beyond a distance dhat (IPC-style), with its gradient and a positive
//   semi-definite Hessian approximation;
// - the largest step along a motion that creates no contact (conservative continuous collision
//   detection), so that a solver started from an intersection-free state stays intersection-free.
//
// Primitive pairs (those of Incremental Potential Contact): a vertex against a boundary triangle
// it is not a corner of, and two boundary edges without a common vertex. Left out: pairs whose
// vertices are all fixed (the base against itself), and pairs touching an excluded triangle (see
// the constructor). These pairs cover every way two triangles of a closed surface can start to
// intersect, neighbours sharing a vertex or an edge included.
//
// Candidate pairs are kept in a list of all pairs closer than dhat + slack (a Verlet list); it is
// rebuilt, with a bounding-volume hierarchy as broad phase, only when some vertex has moved more
// than slack / 2 since the last build, so iterations that move little cost only the pairs near
// contact. Distances, barrier and CCD of single pairs: primitive_distance.h, contact_barrier.h,
// pair_ccd.h; the reasoning behind them: docs/contact.md.
#include <gshell/guard/primitive_distance.h>
#include <gshell/quality/shell_boundary.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <memory>
#include <vector>

namespace gshell {

struct ContactOptions {
  double dhat = 0;  ///< barrier support (model units, > 0): pairs closer than this repel
  double slack = 0; ///< candidate-list slack (model units, >= 0; 0 = dhat)
  /// step_bound keeps every pair at least this fraction of its distance at the start of the
  /// step, or of dhat if that is smaller (in (0, 1)): a step never ends in contact, and the
  /// barrier stays finite.
  double keep_fraction = 0.1;
};

/// A pair of the candidate list: kind and the four vertex ids in PairPoints order (vertex, then
/// the triangle's corners; or the two edges, the one with the smaller edge id first).
struct ContactPair {
  PairKind kind = PairKind::PointTriangle;
  std::array<int, 4> vertices{};
  friend bool operator==(const ContactPair&, const ContactPair&) = default;
};

class ContactGuard {
public:
  /// `boundary` over `num_vertices` shell vertices (2n; rows of every X below). `movable[v]` != 0
  /// for the vertices the solver moves; pairs among fixed vertices only are skipped (fixed
  /// vertices may still be moved by the caller: every X may differ from the last in any row).
  /// `excluded_triangles` (empty, or one flag per boundary triangle): a vertex-triangle pair is
  /// skipped when its triangle is excluded or its vertex is a corner of an excluded triangle; an
  /// edge-edge pair when either edge belongs to an excluded triangle (e.g. the triangles around
  /// the crossings of a base that intersects itself, which no top can keep clean).
  /// \throws InputError on bad options (dhat, slack, keep_fraction), a flag vector of the wrong
  ///         size, a boundary triangle that is not m x 3, has a vertex id outside
  ///         [0, num_vertices) or repeats a vertex, or num_vertices < 0.
  ContactGuard(const ShellBoundary& boundary, int num_vertices, std::vector<char> movable,
               const ContactOptions& options, std::vector<char> excluded_triangles = {});
  ~ContactGuard();
  /// Other options for the following calls (a solver weakening its barrier after a first solve):
  /// the primitives are kept, the candidate list is made afresh. \throws InputError as the
  /// constructor on bad options.
  void set_options(const ContactOptions& options);
  ContactGuard(ContactGuard&&) noexcept;
  ContactGuard& operator=(ContactGuard&&) noexcept;

  // Calls at the same X (exactly equal) share one pass over the candidate list.

  /// Barrier B(X) = sum over pairs of b(d^2), b(s) = -(s - dhat^2)^2 log(s / dhat^2) for
  /// s < dhat^2 and 0 beyond (d: the distance of the pair; after cap_support, each pair's own
  /// support in place of dhat, and its weight); edge-edge pairs of nearly parallel edges are
  /// mollified (contact_barrier.h). +infinity if a pair touches. Deterministic: the
  /// same X gives the same bits whatever the thread count.
  /// \throws InputError when X (D, G) is not num_vertices x 3 or X has a non-finite coordinate at a
  ///         boundary vertex (this, add_gradient, add_hessian, step_bound and min_distance).
  double energy(const Eigen::MatrixXd& X);
  /// G (num_vertices x 3) += scale * dB/dX (rows of fixed vertices included).
  void add_gradient(const Eigen::MatrixXd& X, double scale, Eigen::MatrixXd& G);
  /// Appends scale * H, H a positive semi-definite approximation of d^2B/dX^2 (each pair's block
  /// projected onto its positive eigenvalues), as triplets indexed 3 * vertex + axis (fixed
  /// vertices included: a solver drops the rows it does not solve for), one per entry: the
  /// pairs' terms are summed in list order, so the matrix is bit for bit the one their own
  /// triplets would give.
  /// With `projected` false, each pair's block is pair_barrier_gauss_newton instead (no
  /// eigen-decomposition: the cost of a Hessian falls several-fold).
  /// With `kept_vertices` (one flag per vertex), only the 3 x 3 blocks of two flagged vertices
  /// are appended, in the same order (as VolumeBarrier::add_hessian).
  void add_hessian(const Eigen::MatrixXd& X, double scale, std::vector<Eigen::Triplet<double>>& H,
                   bool projected = true, const std::vector<char>* kept_vertices = nullptr);

  /// The largest alpha in [0, max_step] such that along X + s D, 0 <= s <= alpha, no pair comes
  /// closer than keep_fraction * min(d0, dhat), d0 its distance at X (conservative: the true
  /// bound may be larger, never smaller). Every pair counts, also those beyond the candidate
  /// list (a long step sweeps the primitives' boxes along it). A pair touching at X bounds the
  /// step to 0 if it moves relative to itself. D has the shape of X; it may move fixed vertices
  /// too (a prescribed motion of the base, as when a deformed base drags its shell along), but
  /// pairs among fixed vertices only stay out (the caller answers for the base's own motion).
  /// `cutting`, if given, receives every pair whose own bound is below max_step, in (kind,
  /// vertices) order (slower: no pair is culled by a bound found earlier in the pass).
  /// `touching`, if given (one flag per vertex), limits the pass to the pairs with a flagged
  /// vertex: the bound and `cutting` are then those of these pairs alone. A caller that changes D
  /// on a few vertices only and asks again needs only their pairs (the others move as before).
  /// \throws InputError as energy, or when `touching` has not one flag per vertex.
  double step_bound(const Eigen::MatrixXd& X, const Eigen::MatrixXd& D, double max_step = 1,
                    std::vector<ContactPair>* cutting = nullptr, const std::vector<char>* touching = nullptr);
  /// Sets held[v] for every vertex v that D moves of every pair `cutting` would list (own bound
  /// below max_step; `touching` as in step_bound), leaving flags already set as they are. A pair
  /// whose moving vertices are all flagged (by the caller or by an earlier pair of the pass)
  /// could add none and gets no CCD: a solver holding the vertices of the tets and pairs that
  /// would cut a step flags its tets' vertices first and is spared most pairs where the two crowd
  /// together. The flags set are the same whichever pairs the schedule passes over.
  /// \throws InputError as step_bound, or when `held` has not one flag per vertex.
  void flag_cutting_vertices(const Eigen::MatrixXd& X, const Eigen::MatrixXd& D, double max_step,
                             std::vector<char>& held, const std::vector<char>* touching = nullptr);

  /// Caps each pair's support below dhat by the distances at X: a vertex's cap is `fraction` (in
  /// (0, 1]) times the distance at X of the closest candidate pair it belongs to, a pair's support
  /// the smallest cap of its four vertices, at least 1e-2 dhat (pairs farther apart at X than the
  /// candidate radius cap nothing). Each pair's barrier is b with its own support in place of
  /// dhat, times (dhat / support)^3, so that it pushes as hard at half its support as an uncapped
  /// pair at dhat / 2. A solver whose start is a rest state (a deformation's rest shell) then sees
  /// no barrier at rest where parts of the surface lie close together there. The caps stay (in
  /// model units) through set_options; a second call replaces them.
  /// \throws InputError for a fraction outside (0, 1] or as energy for X.
  void cap_support(const Eigen::MatrixXd& X, double fraction);
  /// Pairs closer than their support at the last energy, gradient or Hessian evaluation.
  int active_pairs() const;
  /// Smallest pair distance at X over the candidate list, dhat + slack if no pair there is that
  /// close (always exact when below dhat: pairs off the list are at least dhat apart).
  double min_distance(const Eigen::MatrixXd& X);

  /// The candidate list as last built (diagnostics), sorted by kind, then vertex ids.
  std::vector<ContactPair> candidate_pairs() const;
  /// How often the candidate list was built so far.
  int candidate_builds() const;
  /// How often the search structure of the fixed triangles was made so far: at the first build,
  /// when a fixed vertex has moved, and, where the movable triangles are few and it holds only
  /// the fixed triangles within reach of them, when they move out of that reach.
  int fixed_patch_builds() const;

private:
  // step_bound and flag_cutting_vertices: one of `cutting` and `held` at most.
  double sweep_step(const Eigen::MatrixXd& X, const Eigen::MatrixXd& D, double max_step,
                    std::vector<ContactPair>* cutting, const std::vector<char>* touching, std::vector<char>* held);

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Boundary rows (of `boundary`, over `num_vertices` shell vertices) a ContactGuard given
/// `excluded` cannot protect: the excluded rows and every row sharing a vertex with one (it skips
/// the pairs of a vertex that is a corner of an excluded row, and the edges of excluded rows).
/// Two rows outside this set are kept apart by the guard.
std::vector<char> unprotected_rows(const ShellBoundary& boundary, const std::vector<char>& excluded, int num_vertices);

} // namespace gshell
