#pragma once
// The exact certificate of a shell's validity (docs/validity.md). A shell over base faces F (shell
// vertices: base i is i, top i is n + i; tets of build_prism_tets) is valid when
//  1. every tet has the orientation of its ideal-prism tet, which is positive by construction
//     (exact orient3d sign; a flat tet counts as inverted);
//  2. no two top triangles intersect, except at the vertices and edges they share;
//  3. no top triangle intersects a base triangle;
// where on open surfaces the side walls (shell_boundary) count as boundary triangles in 2 and 3:
// no wall triangle may meet any boundary triangle except at the vertices and edges they share.
//  4. no connected part of the shell lies inside another part's layer (a sheet wholly inside
//     another layer meets no boundary triangle, so 2 and 3 cannot see it: an eye's top grown out
//     through the head around it).
// With a base that does not intersect itself, 1-4 make the layer an embedding: a shell map is
// one-to-one. Every count comes from exact predicates (CGAL's filtered orientation tests on the
// input doubles), never from a tolerance; neighbouring triangles are tested too.
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <utility>
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
  /// Sheets found inside another part's layer (condition 4): of each connected part, its lowest
  /// base vertex and the top vertex above it are tested; -1 = not tested (with the pairs).
  int nested_parts = -1;

  std::vector<int> inverted_tet_ids;                ///< rows of build_prism_tets(F, n), ascending
  std::vector<BoundaryIntersection> intersections;  ///< every pair counted above, ascending (a, b)
  /// (shell vertex, tet of another part holding it) for every sheet counted in nested_parts,
  /// ascending by vertex (base i is i, top i is n + i).
  std::vector<std::pair<int, int>> nested;
  double seconds = 0;                               ///< wall-clock time of certify_shell

  /// Whether the pair tests ran.
  bool intersections_tested() const { return top_self_intersections >= 0; }
  /// Conditions 1-4 hold (no inverted tet, pairs tested and none of top/top, top/base or wall, no
  /// part inside another's layer) and, if base/base pairs were tested, the base does not intersect
  /// itself: the layer is an embedding (docs/validity.md). Without the base/base pairs this is
  /// conditions 1-4 alone, for a caller that knows its base is embedded (the shell cannot mend
  /// its input).
  bool valid() const {
    return inverted_tets == 0 && intersections_tested() && top_self_intersections == 0 &&
           top_base_intersections == 0 && wall_intersections == 0 && nested_parts <= 0 &&
           base_self_intersections <= 0;
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

/// The certificate of the shell (base, top) from `previous`, certify_shell's certificate of the
/// shell (previous_base, previous_top) over the same F with the same options, deciding again only
/// what can have changed: the tets, and the boundary triangle pairs with a vertex whose position
/// differs between the two shells (pairs among unmoved vertices keep their exact verdicts). The
/// answer is exactly certify_shell(base, top, F, options)'s, at the cost of a pass over the tets
/// and the boundary triangles plus exact tests near the moved vertices, where certify_shell
/// searches the whole boundary: for a shell changed in a few places (a generated top mended where
/// it was invalid, an edit), several times less on big meshes (docs/validity.md).
/// Precondition (not checked beyond the counts): `previous` is that certificate.
/// \throws InputError for the inputs certify_shell refuses, previous shells of another size, or a
///         `previous` whose tests do not match `options` (pairs or base/base pairs not tested).
ShellCertificate recertify_shell(const ShellCertificate& previous, const Eigen::MatrixXd& previous_base,
                                 const Eigen::MatrixXd& previous_top, const Eigen::MatrixXd& base,
                                 const Eigen::MatrixXd& top, const Eigen::MatrixXi& F,
                                 const CertifyOptions& options = {});

/// Precompute once, certify many: the certificate of many shells over the same faces, e.g. the
/// frames of a deformation. The topology (boundary surface, vertex stars, checked ids) is set up
/// once; the search trees are built for the first shell certified and refit to every later one
/// (kept in shape, boxes recomputed), which stays exact whatever the shells are and is fastest
/// when they are frames of one motion (docs/valid-deformation.md). certify() returns exactly what
/// certify_shell returns for the same shell. Not for concurrent calls on one object.
class ShellCertifier {
public:
  /// Faces F (m x 3, three distinct ids in [0, n) each) over n base vertices.
  /// \throws InputError when F is not m x 3 with three distinct ids in [0, n) per face.
  ShellCertifier(const Eigen::MatrixXi& F, int n);
  ~ShellCertifier();
  ShellCertifier(ShellCertifier&&) noexcept;
  ShellCertifier& operator=(ShellCertifier&&) noexcept;

  /// certify_shell(base, top, F, options) for the F given at construction.
  /// \throws InputError when base or top is not n x 3 or a coordinate is not finite.
  ShellCertificate certify(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top, const CertifyOptions& options = {});

private:
  struct State;
  std::unique_ptr<State> state_;
};

} // namespace gshell
