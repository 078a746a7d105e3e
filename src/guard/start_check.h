#pragma once
// Exact validity checks for the guarded start's rounds, by the certificate's predicates: the first
// round certifies the whole shell (certify_shell); later ones test only the tets and boundary
// triangle pairs that touch the vertices moved since (pairs and tets among unmoved vertices were
// decided already). Such a check finds those tets and rows from the moved vertices' incidences
// and moves only their faces in the trees over all rows, so its cost follows the moved vertices,
// not the shell, apart from a pass over the flags and one comparing positions with the last
// check's (lift_thin_tops checks hundreds of times on large meshes; docs/scale.md). The trees are
// the first check's own (certify_shell_keeping_trees), or, for a checker whose first check is of
// moved vertices, the same two trees built then.
#include <gshell/quality/shell_boundary.h>
#include <gshell/quality/shell_certificate.h>

#include "geometry/item_groups.h"
#include "quality/certificate_trees.h"
#include "quality/nested_parts.h"

#include <Eigen/Core>
#include <algorithm>
#include <optional>
#include <utility>
#include <vector>

namespace gshell::detail {

struct StartViolations {
  std::vector<int> inverted_tets;                 ///< rows of T, not skipped
  std::vector<std::pair<int, int>> intersections; ///< boundary rows a < b, neither excluded, not both base
  /// What to thin where a sheet of one part lies inside another's layer (ShellCertificate::nested),
  /// only when nothing else is found (with no boundary triangles meeting, one vertex per sheet
  /// decides: nested_parts.h), and not for parts with excluded rows (near base crossings).
  /// A top inside another layer is its own part's to pull back: those parts, whole, ascending.
  std::vector<int> nested_parts;
  /// A base inside another layer: the top vertices (ascending) of the prisms of the part whose top
  /// went round it that reach the inner part's bounding box. Only those: scan debris just off a
  /// surface, inside its layer, pulled in the whole of bunny00's top when the holder was thinned
  /// whole (37,718 tops pulled in and repaired, 1.2 -> 6.6 s; 43 s with 200 specks).
  std::vector<int> nested_tops;
  /// The whole shell's certificate (base/base pairs not searched), when the check was of the whole
  /// shell; skipped tets and excluded rows are counted in it.
  std::optional<ShellCertificate> certificate;
};

class StartChecker {
public:
  /// Over base faces F (n base vertices); skip / excluded: one flag per tet of build_prism_tets /
  /// boundary row, or empty.
  StartChecker(const Eigen::MatrixXi& F, int n, std::vector<char> skip_tets, std::vector<char> excluded_triangles);
  ~StartChecker();

  /// Violations of the shell (base, top). With `moved` (one flag per top vertex), only tets and
  /// pairs with a moved top vertex are tested. Not for concurrent calls on one object: the trees
  /// over all boundary rows, of the first check (or built at it, if it had `moved`), are kept
  /// and refit (not rebuilt) afterwards. Without `moved`: violations(certify(base, top)).
  StartViolations check(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                        const std::vector<char>* moved = nullptr) const;

  /// The first check in two parts, for a caller that decides the excluded triangles from what it
  /// finds: certify() certifies the whole shell (certify_shell without the base's own pairs),
  /// keeping its trees for the later checks; with `base_crossings` it also searches those pairs,
  /// over the certificate's tree of the base rows (a pass over that tree rather than a tree of
  /// their own), and hands them over there as face pairs (f, g), f < g, ascending, the
  /// certificate being what it is without them. violations() makes the check's result of it.
  ShellCertificate certify(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                           std::vector<std::pair<int, int>>* base_crossings = nullptr) const;
  StartViolations violations(ShellCertificate certificate) const;
  /// Replaces the excluded triangles given at construction (one flag per boundary row, or empty).
  /// Only between certify() and violations(): the later checks and the parts read them.
  void exclude_triangles(std::vector<char> excluded_triangles);

  /// Calls visit(i) for every top vertex n + i of the tets and boundary rows in `found` (once per
  /// tet or row it belongs to).
  template <class Visit> void for_each_top_vertex(const StartViolations& found, Visit&& visit) const {
    for (int t : found.inverted_tets)
      for (int j = 0; j < 4; ++j)
        if (const int v = tets()(t, j); v >= n_) visit(v - n_);
    for (const auto& [a, b] : found.intersections)
      for (int row : {a, b})
        for (int k = 0; k < 3; ++k)
          if (const int v = boundary_.F(row, k); v >= n_) visit(v - n_);
    if (!found.nested_parts.empty())
      for (int i : parts().vertices.items_of(found.nested_parts)) visit(i);
    for (int i : found.nested_tops) visit(i);
  }

  /// Checks the top vertices flagged in `check` (top = top positions, one row per base vertex),
  /// calls put_back(i) for every top vertex i of a violation found that is flagged in `moved`
  /// (which must restore top.row(i); the flag is cleared) and checks those again, until a check
  /// finds nothing. Clears `check`; `moved` keeps the moves that stand. Returns the checks run.
  /// A move of a vertex that was valid with its neighbours where they stood is thus kept only
  /// where it is valid with the moves kept around it.
  template <class PutBack>
  int settle(const Eigen::MatrixXd& base, Eigen::MatrixXd& top, std::vector<char>& moved, std::vector<char>& check,
             PutBack&& put_back) const {
    int checks = 0;
    while (std::find(check.begin(), check.end(), 1) != check.end()) {
      ++checks;
      const StartViolations found = this->check(base, top, &check);
      std::fill(check.begin(), check.end(), 0);
      for_each_top_vertex(found, [&](int i) {
        if (!moved[i]) return;
        moved[i] = 0;
        check[i] = 1;
        put_back(i);
      });
    }
    return checks;
  }

  const ShellBoundary& boundary() const { return boundary_; }
  /// build_prism_tets(F, n), made at the first call (not concurrently).
  const Eigen::MatrixXi& tets() const;

private:
  // The tets and the incidences are only needed by the checks after the first (which is
  // certify_shell's own): made when first needed, so that a start that finds nothing to mend
  // never holds them beside the certificate, where generation peaks.
  Eigen::MatrixXi F_;
  mutable Eigen::MatrixXi T_;
  int n_;
  ShellBoundary boundary_;
  std::vector<char> skip_, excluded_;
  std::vector<int> rows_;            // boundary rows not excluded
  // The connected parts, made when first needed (a union-find pass over the faces, 0.05-0.1 s at
  // 5 M faces, which a start that finds nothing wrong at its first check never pays here).
  struct Parts {
    ShellParts parts;
    ItemGroups vertices; // group p: the base vertices of part p
    std::vector<char> excluded; // per part: has excluded rows (parts_with_flagged_rows): not thinned for nesting
  };
  mutable std::optional<Parts> parts_;
  const Parts& parts() const;
  // StartViolations::nested_parts and nested_tops for the probes `nested` at positions X (2n x 3).
  void nesting_to_thin(const std::vector<std::pair<int, int>>& nested, const Eigen::MatrixXd& X,
                       StartViolations& v) const;
  // Group i: the rows `ids` of M (tets of T_ not skipped, or rows_) with top vertex n + i.
  ItemGroups top_incidence(const Eigen::MatrixXi& M, const std::vector<int>& ids) const;
  // X_ = (base, top), and the trees at these positions.
  void place(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top) const;

  mutable ItemGroups top_tets_, top_rows_;
  mutable Eigen::MatrixXd X_;            // the positions the trees are at (base rows, then top rows)
  // Over all rows (pairs with excluded rows are passed over).
  mutable std::optional<CertificateTrees> trees_;
};

} // namespace gshell::detail
