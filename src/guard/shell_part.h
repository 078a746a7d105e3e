#pragma once
// The part of a shell that a guarded solve over a few of its top vertices can touch, renumbered
// compactly. Generation's repair moves a few thousand top vertices of a shell that may have
// millions; a solver over the whole shell's vertex ids pays every iteration for passes over all of
// them (positions, gradients, steps, the contact guard's copy of X), which on bunny00 split four
// times (9.65 M vertices, 1,822 to mend) made each repair iteration 2.7 s. Over the part, an
// iteration costs in proportion to what moves.
#include <gshell/quality/shell_boundary.h>
#include <gshell/solver/rest_tets.h>

#include <Eigen/Core>
#include <vector>

namespace gshell::detail {

struct ShellPart {
  std::vector<int> vertex; ///< part id -> shell id, ascending
  std::vector<int> tet;    ///< part tet -> shell tet: the tets with a moving vertex, ascending
  std::vector<int> row;    ///< part boundary row -> shell boundary row, ascending
  RestTets tets;           ///< those tets (their rest shapes as matrices), in part ids
  ShellBoundary boundary;  ///< those rows, in part ids (part and face as in the shell)
  std::vector<int> held;   ///< part ids of every vertex that does not move
  Eigen::MatrixXd X;       ///< positions of the part's vertices (part ids)

  int size() const { return static_cast<int>(vertex.size()); }
  /// Copies the moving vertices' rows of the part's positions P back into the shell's X.
  void scatter_moving(const Eigen::MatrixXd& P, Eigen::MatrixXd& shell_X) const;
};

/// The part of the shell (rest tets `tets`, boundary surface `boundary`, positions X over all
/// shell vertices) that a solve moving the vertices flagged in `moving` (one flag per shell
/// vertex) can touch while no moving vertex travels farther than `travel` from X and contacts
/// act within `contact_radius` (model units): the tets with a moving vertex; every boundary
/// row whose box at X comes within travel + contact_radius of the box of a row with a moving
/// vertex (a boundary primitive left out stays farther than contact_radius from every moving one
/// however the moving vertices go within `travel`), and every row sharing a vertex with one of
/// those, so that the contact guard derives the same edge and vertex flags from the part as from
/// the whole; and the vertices of all of these.
ShellPart shell_part(const RestTets& tets, const ShellBoundary& boundary, const Eigen::MatrixXd& X,
                     const std::vector<char>& moving, double travel, double contact_radius);

} // namespace gshell::detail
