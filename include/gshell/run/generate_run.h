#pragma once
// The generate job (`gshell generate`, Python `gshell.generate`): options with the only defaults,
// the run's result with its report and its shell folder.
#include <gshell/mesh.h>
#include <gshell/run/shell_folder.h>
#include <gshell/shell/generate_shell.h>

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace gshell {

/// A shell thickness as a caller gives it: exactly one of eta and a ratio.
struct ThicknessChoice {
  std::optional<double> thickness;       ///< eta in model units
  std::optional<double> thickness_ratio; ///< eta as a ratio of the bounding sphere's radius (thickness_from_ratio)

  /// \throws InputError naming the parameter (thickness, thickness_ratio) unless exactly one is
  ///         given, positive and finite.
  void check() const;
  /// eta in model units for the base (V, F) (a ratio: of the vertices F uses). \throws InputError as
  /// check(). Not held to check_thickness_scale here: generation checks it itself, and the metrics
  /// call it (each check is two passes over the mesh, ~25 ms at sphere:9).
  double eta(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) const;
};

struct GenerateRunOptions {
  /// Method, solve limits, curvature clamps, intersection counts. `generate.thickness` is ignored:
  /// it is set from `thickness`.
  GenerateOptions generate;
  ThicknessChoice thickness;

  /// Every parameter, before any input is read.
  /// \throws InputError naming the parameter (thickness, thickness_ratio, iterations, tolerance,
  ///         s_min, s_max) when it is out of range, or when not exactly one thickness is given.
  void check() const;
};

/// One generation, with what its report names.
struct GenerateRun {
  std::string input;                     ///< the input as the report names it (file, builtin spec, ...)
  TriMesh surface;                       ///< the base as used: its faces, vertex order and UVs go to the folder
  std::optional<double> thickness_ratio; ///< as given (null in the report when eta was given)
  GenerateResult result;
  /// What the input's validation warned of (require_valid_mesh's lines, as run_generate got them).
  std::vector<std::string> input_warnings;

  /// report.json: generate_report (shell/generate_report.h lists the fields).
  nlohmann::ordered_json to_json() const;
  /// input_warnings, then generate_warnings: the report's `warnings`.
  std::vector<std::string> warnings() const;
  /// The terminal summary (generate_summary).
  std::string summary() const;
  /// The shell folder DIR: base.obj, top.obj, shell.vtu (cell data stretch, inverted, prism),
  /// report.json. \throws InputError on a bad output path or a failed write (nothing left behind).
  void write(const std::string& dir, const BeforeCommit& before_commit = {}) const;
};

/// Generates the shell of `surface` (already validated, e.g. by load_mesh or require_valid_mesh;
/// `input_warnings`: what that validation warned of, kept for the report).
/// \throws InputError on bad options (GenerateRunOptions::check).
GenerateRun run_generate(TriMesh surface, std::string input, const GenerateRunOptions& options,
                         std::vector<std::string> input_warnings = {});

} // namespace gshell
