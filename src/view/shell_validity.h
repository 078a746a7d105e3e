#pragma once
// The validity figures the viewer shows (inverted tets, intersecting boundary triangles, valid),
// measured off the interactive path on a snapshot of the shell.
#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace gshell {

struct ShellValidity {
  int inverted_tets = 0;
  int top_self_intersections = 0;
  int top_base_intersections = 0;
  double seconds = 0;

  bool valid() const { return inverted_tets == 0 && top_self_intersections == 0 && top_base_intersections == 0; }
  /// {"inverted_tets", "intersections": {"top_self", "top_base"}, "valid", "seconds"}
  nlohmann::ordered_json to_json() const;
};

/// Measures the shell over base faces F at X (2n x 3, base rows then top rows). Thread-safe.
ShellValidity measure_shell_validity(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F);

} // namespace gshell
