#include "thickness_option.h"

#include <gshell/error.h>
#include <gshell/shell/generate_shell.h>

#include <cmath>

namespace gshell::cli {

void ThicknessOption::add_to(CLI::App& cmd) {
  cmd.add_option("--thickness", thickness, "Shell thickness eta in model units");
  cmd.add_option("--thickness-ratio", ratio,
                 "Shell thickness as a ratio of the bounding sphere's radius (centre = bounding-box centre, "
                 "radius = farthest vertex; e.g. 0.01)");
}

void ThicknessOption::check() const {
  if (thickness.has_value() == ratio.has_value())
    throw InputError("give exactly one of --thickness and --thickness-ratio");
  if (thickness && (!(*thickness > 0) || !std::isfinite(*thickness)))
    throw InputError("--thickness must be positive and finite");
  if (ratio && (!(*ratio > 0) || !std::isfinite(*ratio)))
    throw InputError("--thickness-ratio must be positive and finite");
}

double ThicknessOption::eta(const Eigen::MatrixXd& V) const {
  return thickness ? *thickness : thickness_from_ratio(V, *ratio);
}

} // namespace gshell::cli
