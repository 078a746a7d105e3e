#pragma once
// Small pieces of work on rows of a shell's boundary surface (shell_boundary) at positions X (2n x 3,
// base rows then top rows), shared by the certificate, the start's checks and the repair's part.
#include <gshell/quality/shell_boundary.h>

#include <Eigen/Core>
#include <vector>

namespace gshell::detail {

/// The rows `ids` of B, in that order.
Eigen::MatrixXi rows_of(const Eigen::MatrixXi& B, const std::vector<int>& ids);

/// Per row of `boundary`: whether its box at X (the exact min / max of its corners) meets the box
/// of one of the rows `seeds` grown by `reach` along every axis (the seeds themselves included).
/// Found by one parallel pass over the rows against a tree of the seeds' grown boxes, whose float
/// covers are rounded outwards, so no row whose box meets is missed.
std::vector<char> rows_near(const ShellBoundary& boundary, const Eigen::MatrixXd& X, const std::vector<int>& seeds,
                            double reach);

} // namespace gshell::detail
