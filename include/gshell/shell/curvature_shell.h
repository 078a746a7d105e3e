#pragma once
// The curvature method of shell generation (paper §4.1 "Curvature Sensitive Method"): the rigid
// pipeline run towards curvature-sensitive ideal prisms, plus what its report adds.
#include <gshell/quality/stretch.h>
#include <gshell/shell/curvature_prisms.h>
#include <gshell/shell/generate_shell.h>

#include <nlohmann/json.hpp>
#include <string>

namespace gshell {

struct CurvatureShellResult {
  GenerateResult result;        ///< as generate_shell's; metrics against the normal prisms
  CurvaturePrismStats prisms;   ///< prisms that hit the clamps / had their anisotropy limited
  StretchStats own_stretch;     ///< stretch against the curvature prisms it was optimised towards
  double s_min = 0, s_max = 0;  ///< clamps used
  double prism_seconds = 0;     ///< curvature + ideal prisms (included in result.seconds.total)
};

/// Curvature prisms (options.thickness, options.s_min, options.s_max) and generation towards them
/// (generate_shell_from_prisms). options.method is taken as Curvature whatever it says.
/// Throws InputError on bad options.
CurvatureShellResult generate_curvature_shell(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                              GenerateOptions options);

/// Adds to a generate_report: "curvature": {s_min, s_max, clamped_prisms, limited_prisms,
/// stretch_own {mean, volume_mean, max, p99, inverted_tets}, seconds}. The top-level "stretch"
/// stays against the normal prisms, comparable with the other methods.
void add_curvature_report(nlohmann::json& report, const CurvatureShellResult& curvature);

/// Two lines for the terminal summary: clamp counts and the stretch against the own prisms.
std::string curvature_summary(const CurvatureShellResult& curvature);

} // namespace gshell
