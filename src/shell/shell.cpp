#include <gshell/shell/shell.h>

#include <gshell/error.h>
#include <gshell/format_number.h>

#include <cmath>

namespace gshell {

void check_shell(const Shell& shell, const std::string& name, bool need_thickness) {
  auto fail = [&](const std::string& problem) { throw InputError(name + ": " + problem); };
  const Eigen::Index n = shell.base.rows();
  if (shell.base.cols() != 3 || shell.top.cols() != 3 || shell.top.rows() != n)
    fail("base and top must both be n x 3 (got " + std::to_string(n) + " x " + std::to_string(shell.base.cols()) +
         " and " + std::to_string(shell.top.rows()) + " x " + std::to_string(shell.top.cols()) + ")");
  for (Eigen::Index v = 0; v < n; ++v) {
    if (!shell.base.row(v).allFinite()) fail("base vertex " + std::to_string(v) + " is not finite");
    if (!shell.top.row(v).allFinite()) fail("top vertex " + std::to_string(v) + " is not finite");
  }
  if (shell.F.cols() != 3) fail("faces must be m x 3 (got " + std::to_string(shell.F.cols()) + " columns)");
  for (Eigen::Index f = 0; f < shell.F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (shell.F(f, k) < 0 || shell.F(f, k) >= n)
        fail("face " + std::to_string(f) + " has vertex id " + std::to_string(shell.F(f, k)) + " (the base has " +
             std::to_string(n) + " vertices)");
  if (need_thickness && !(shell.thickness > 0 && std::isfinite(shell.thickness)))
    fail("thickness must be positive and finite (got " + format_number(shell.thickness) + ")");
}

} // namespace gshell
