#pragma once
// The fill-reducing ordering of the guarded solver's large local systems, kept between iterations.
//
// A repair that covers most of a large shell factors one local system per iteration over nearly
// the same vertices; the barriers' active sets change its entries and a few of its vertices. On
// the 491,520-row system of a fully repaired 164K-vertex shell, CHOLMOD's analysis (AMD, then
// METIS) took 4.5 s of each factorisation's 9.3 s, and an ordering found for one iteration fills
// the next one's factor about as little. So the ordering is found once, remembered per vertex
// and axis (the x, y and z copies of the ARAP matrix are coupled only by the barriers, and
// METIS orders them apart: one order per vertex filled 1.9x more), and handed to the following
// factorisations; it is found afresh when the region has changed much or when the factor it
// would give (known from the symbolic analysis, before the numeric work) has grown well past
// the fresh one's.
#include <Eigen/SparseCore>
#include <vector>

namespace gshell::detail {

class SpdSolver;

class ReusedOrdering {
public:
  /// Factors A, the local system over `vertices` (rows 3k..3k+2 belong to vertices[k]; ids below
  /// num_ids), with the remembered ordering where it applies and fills at most a little more than
  /// when it was found, else with one found for A (then remembered). True when the remembered
  /// ordering was used. Throws std::runtime_error if A is not positive definite.
  bool factor(SpdSolver& solver, const Eigen::SparseMatrix<double>& A, const std::vector<int>& vertices, int num_ids);
  void clear();

private:
  bool order(const Eigen::SparseMatrix<double>& A, const std::vector<int>& vertices, std::vector<int>& dofs) const;
  std::vector<int> rank_;          // 3 * vertex id + axis -> position in the remembered ordering, -1 if not in it
  std::size_t remembered_ = 0;     // vertices in it
  double fresh_entries_ = 0;       // factor entries with the ordering when it was found
};

} // namespace gshell::detail
