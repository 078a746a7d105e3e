#pragma once
// The exact certificate of a shell's validity (docs/validity.md). A shell over base faces F (shell
// vertices: base i is i, top i is n + i; tets of build_prism_tets) is valid when
//  1. every tet has the orientation of its ideal-prism tet, which is positive by construction
//     (exact orient3d sign; a flat tet counts as inverted);
//  2. no two top triangles intersect, except at the vertices and edges they share;
//  3. no top triangle intersects a base triangle;
// where on open surfaces the side walls (shell_boundary) count as boundary triangles in 2 and 3:
// no wall triangle may meet any boundary triangle except at the vertices and edges they share.
// With a base that does not intersect itself, 1-3 make the layer an embedding: a shell map is
// one-to-one. Every count comes from exact predicates (CGAL's filtered orientation tests on the
// input doubles), never from a tolerance; neighbouring triangles are tested too.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace gshell {

/// What a pair of intersecting boundary triangles is made of.
enum class IntersectionKind : std::uint8_t {
  TopTop,   ///< two top triangles (breaks condition 2)
  TopBase,  ///< a top and a base triangle (breaks condition 3)
  Wall,     ///< a side-wall triangle and any other boundary triangle (open surfaces)
  BaseBase, ///< two base triangles: the input's own self-intersection, not the shell's doing
};

/// "top/top", "top/base", "wall", "base/base".
const char* to_string(IntersectionKind kind);

/// Two boundary triangles that meet anywhere but at the vertices and edges they share.
struct BoundaryIntersection {
  int a = 0, b = 0; ///< rows of shell_boundary(F, n), a < b
  IntersectionKind kind = IntersectionKind::TopTop;

  friend bool operator==(const BoundaryIntersection&, const BoundaryIntersection&) = default;
};

struct CertifyOptions {
  /// Test boundary triangle pairs (conditions 2, 3). Off: only the tets are checked and the pair
  /// counts stay -1 ("not tested"); the tets alone cost a few milliseconds even on big meshes.
  bool test_intersections = true;
  /// Also test base triangles against each other (base_self_intersections). Off: base/base pairs
  /// are skipped (e.g. when the caller knows the base's count already).
  bool base_self_intersections = true;
};

struct ShellCertificate {
  static constexpr bool exact = true; ///< every count is decided by exact predicates

  int inverted_tets = 0;           ///< tets whose orient3d is not positive (condition 1)
  int top_self_intersections = -1; ///< top/top pairs (condition 2); -1 = not tested
  int top_base_intersections = -1; ///< top/base pairs (condition 3); -1 = not tested
  int wall_intersections = -1;     ///< pairs with a side-wall triangle; -1 = not tested
  int base_self_intersections = -1; ///< base/base pairs (the input's own); -1 = not tested

  std::vector<int> inverted_tet_ids;                ///< rows of build_prism_tets(F, n), ascending
  std::vector<BoundaryIntersection> intersections;  ///< every pair counted above, ascending (a, b)
  double seconds = 0;                               ///< wall-clock time of certify_shell

  /// Whether the pair tests ran.
  bool intersections_tested() const { return top_self_intersections >= 0; }
  /// Conditions 1-3 hold (no inverted tet, pairs tested and none of top/top, top/base or wall)
  /// and, if base/base pairs were tested, the base does not intersect itself: the layer is an
  /// embedding (docs/validity.md). Without the base/base pairs this is conditions 1-3 alone, for a
  /// caller that knows its base is embedded (the shell cannot mend its input).
  bool valid() const {
    return inverted_tets == 0 && intersections_tested() && top_self_intersections == 0 &&
           top_base_intersections == 0 && wall_intersections == 0 && base_self_intersections <= 0;
  }
};

/// Certifies the shell between `base` and `top` (n x 3 each, top vertex i over base vertex i) over
/// the faces F (m x 3, counter-clockwise, three distinct ids each) exactly; see the conditions
/// above. Any base/top pair can be certified: a generated shell, a deformed or posed frame, a
/// shell made by another tool. Runs in parallel.
/// \throws InputError when base and top are not n x 3 with the same n, a coordinate is not finite,
///         or F is not m x 3 with three distinct ids in [0, n) per face.
ShellCertificate certify_shell(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top, const Eigen::MatrixXi& F,
                               const CertifyOptions& options = {});

} // namespace gshell
