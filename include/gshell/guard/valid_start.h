#pragma once
// A valid start for the guarded solver: each top vertex on a path from its base vertex b_i (s = 0)
// to a wanted position p_i (s = 1, e.g. the paper's unguarded result), at a per-vertex s_i in
// (0, 1] as large as is valid. Starting from s = 1, every round checks the shell exactly (tet
// orientation, boundary triangle intersections) and shrinks s_i by a constant factor at the top
// vertices of every violation. The path is the straight line b_i + s (p_i - b_i) when that line
// sees every face at vertex i from its positive side (with a margin), otherwise it bends towards
// the extrusion direction d_i as s falls: b_i + s |p_i - b_i| unit(s u_i + (1 - s) d_i), u_i the
// unit of p_i - b_i. Either way it leaves the base along a direction that sees every incident face,
// and small enough s along such directions are valid when the base itself is (each prism's tets
// gain volume like s * area * (n_f . d) > 0, and the top stays within a thin neighbourhood of the
// embedded base), so the rounds end, touching only where needed; where nothing is wrong the start
// is the wanted top exactly.
#include <gshell/guard/extrusion_directions.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/quality/shell_certificate.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <optional>
#include <utility>
#include <vector>

namespace gshell {

struct ValidStartOptions {
  /// The path is straight where p_i - b_i keeps at least this cosine margin on every incident face.
  double straight_margin = 0.1;
  /// Length of the path along d_i where p_i = b_i (model units, > 0).
  double fallback_length = 1;
  double thinning = 0.5; ///< factor applied to s_i of a vertex in a violation, per round, in (0, 1)
  /// Largest ratio of s between the ends of an edge (> 1; 0 or less: no limit).
  double spread = 0;
  /// Bisection passes that raise each pulled-in s_i back between its valid value and the last
  /// invalid one (0: keep the halving's result; each pass halves log(hi / lo)).
  int refine_passes = 0;
  /// After the bisection, pulled-in s_i are lowered by this factor where that stays valid (a
  /// margin from the validity boundary the bisection ends next to), in (0, 1]; 1: none.
  double backoff = 1;
  /// A vertex is thinned at most max_rounds - 1 times (a violation that survives 2^-39 of the
  /// target thickness comes from the base itself, e.g. touching input triangles). The start gives
  /// up when every top vertex of what is left has been, or after 10 x max_rounds rounds in all.
  int max_rounds = 40;
};

struct ValidStart {
  Eigen::MatrixXd top;        ///< n x 3
  Eigen::VectorXd scale;      ///< s_i
  int rounds = 0;             ///< checks run
  /// What the last check still found (empty unless the start gave up): tets that are not skipped
  /// and pairs of boundary rows of which neither is excluded (base/base pairs are not reported).
  std::vector<int> inverted_tets;
  std::vector<std::pair<int, int>> intersections;
  /// The exact certificate of the wanted top P (certify_shell, base/base pairs not searched) by
  /// the first check, which certifies it whole (skipped tets and excluded triangles are counted in
  /// it). When that check found nothing to mend, `top` is P bit for bit and this is its
  /// certificate; otherwise recertify_shell makes the certificate of any later top from it.
  std::optional<ShellCertificate> certificate;
  double seconds = 0;
};

/// The start for the base (V, F) towards the wanted top P (n x 3) with extrusion directions
/// `directions` (extrusion_directions(V, F)). `skip_tets` (one flag per tet of build_prism_tets, or empty) and `excluded_triangles` (one flag
/// per row of shell_boundary(F, n), or empty): violations involving those are ignored (they cannot
/// be mended by thinning). The checks are the certificate's (certify_shell), without base/base pairs.
/// \throws InputError when P or directions has not one row per base vertex, options.thinning is
///         outside (0, 1) or options.fallback_length <= 0.
ValidStart valid_start(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& P,
                       const ExtrusionDirections& directions,
                       const std::vector<char>& skip_tets = {}, const std::vector<char>& excluded_triangles = {},
                       const ValidStartOptions& options = {});

/// The base vertices (ids in 0..n-1 of F's mesh) of what `start`'s last check still found: the
/// faces of its inverted tets and of its intersecting boundary rows (walls and tops name their
/// base vertices). Ascending; empty when the start mended everything.
std::vector<int> unmended_vertices(const ValidStart& start, const Eigen::MatrixXi& F, int n);

} // namespace gshell
