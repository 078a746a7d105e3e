#pragma once
// Exact validity checks for the guarded start's rounds, by the certificate's predicates: the first
// round certifies the whole shell (certify_shell); later ones test only the tets and boundary
// triangle pairs that touch the vertices moved since (pairs and tets among unmoved vertices were
// decided already), so a round costs little more than its moved vertices.
#include <gshell/quality/shell_boundary.h>
#include <gshell/quality/shell_certificate.h>

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

namespace gshell::detail {

class FaceSet;

struct StartViolations {
  std::vector<int> inverted_tets;                 ///< rows of T, not skipped
  std::vector<std::pair<int, int>> intersections; ///< boundary rows a < b, neither excluded, not both base
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
  /// pairs with a moved top vertex are tested. Not for concurrent calls on one object: the tree
  /// over the checked rows is built at the first such call and refit (not rebuilt) afterwards.
  StartViolations check(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                        const std::vector<char>* moved = nullptr) const;

  const ShellBoundary& boundary() const { return boundary_; }
  /// build_prism_tets(F, n), made at the first call (not concurrently).
  const Eigen::MatrixXi& tets() const;

private:
  // The tets and the checked rows' faces are only needed by the checks after the first (which
  // is certify_shell's own): made when first needed, so that a start that finds nothing to mend
  // never holds them beside the certificate, where generation peaks.
  Eigen::MatrixXi F_;
  mutable Eigen::MatrixXi T_;
  int n_;
  ShellBoundary boundary_;
  std::vector<char> skip_, excluded_;
  std::vector<int> rows_;            // boundary rows not excluded
  mutable Eigen::MatrixXi rows_F_;   // their faces
  mutable std::unique_ptr<FaceSet> all_; // over rows_F_, at the last checked positions
};

} // namespace gshell::detail
