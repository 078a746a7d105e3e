#pragma once
// Internal: whether one connected part of a shell lies inside another part's layer. The
// certificate's pair tests cannot see it: an eye inside a head, whose top grows out through the
// head's surface whole (the inner top beyond the outer base everywhere), crosses no boundary
// triangle, yet the two layers overlap. Where no boundary triangles meet, each closed sheet of the
// boundary (a part's base, its top; base, top and walls of an open part) lies wholly inside or
// wholly outside every other part's layer, so one vertex per sheet decides it (docs/validity.md).
#include <gshell/quality/shell_boundary.h>

#include <Eigen/Core>
#include <utility>
#include <vector>

namespace gshell::detail {

/// The connected parts of a shell's faces (edge-connected through the base vertices).
struct ShellParts {
  std::vector<int> of_vertex; ///< part of each base vertex; -1 where no face uses it
  std::vector<int> probe;     ///< per part, its lowest base vertex
  int count() const { return static_cast<int>(probe.size()); }
};

/// Parts of F (m x 3) over n base vertices.
ShellParts shell_parts(const Eigen::MatrixXi& F, int n);

/// Per part: whether a row of `boundary` (over n base vertices) flagged in `rows` belongs to it.
/// Where a part's rows are left out of a guard (around base crossings) its sheets can be partly
/// inside another layer with every guarded test passing: nesting says nothing there.
std::vector<char> parts_with_flagged_rows(const ShellParts& parts, const ShellBoundary& boundary,
                                          const std::vector<char>& rows, int n);

/// The probes (per part its probe base vertex i and the top vertex n + i above it) lying in a
/// closed tet of another part's prisms (rows 3f..3f+2 of build_prism_tets), by exact orientation
/// tests; tets that are not positive are passed over (they are counted as inverted). Returns
/// (shell vertex, tet) pairs, one per probe found inside, ascending by vertex. Nothing to test and
/// an empty result when there is one part. Runs in parallel.
std::vector<std::pair<int, int>> nested_probes(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                                               const Eigen::MatrixXi& F, const ShellParts& parts);

} // namespace gshell::detail
