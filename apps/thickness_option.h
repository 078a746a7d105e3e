#pragma once
// `--thickness T | --thickness-ratio R`, shared by the commands that build or judge a shell.
#include <CLI/CLI.hpp>
#include <Eigen/Core>

#include <optional>

namespace gshell::cli {

struct ThicknessOption {
  std::optional<double> thickness; ///< eta in model units
  std::optional<double> ratio;     ///< eta as a ratio of the base's bounding-sphere radius

  void add_to(CLI::App& cmd);
  /// Throws InputError unless exactly one is given, positive and finite.
  void check() const;
  /// eta in model units for base vertices V (after check()).
  double eta(const Eigen::MatrixXd& V) const;
};

} // namespace gshell::cli
