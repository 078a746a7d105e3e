#pragma once
// report.json of `gshell generate` / `gshell metrics`, and the one-screen text summary.
#include <gshell/shell/generate_shell.h>

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace gshell {

/// The report of a generated shell. Fields (units: model units, seconds):
///   input, method, thickness {eta, ratio (null if given absolutely), min, mean (per-vertex
///   thickness / eta)}, vertices, faces, tets, iterations, converged, energy [E_0 = offset start,
///   one per iteration], stretch {mean, volume_mean, max, p99} (against the normal prisms),
///   valid, certificate {inverted_tets, top_self_intersections, top_base_intersections,
///   wall_intersections, nested_parts, exact}, base_self_intersections (certificate_report; pair counts null
///   and valid null or false when intersections were not counted), thinned_vertices,
///   seconds {total, factor, solve, guard, certificate}, unextrudable_vertices [ids], guarded,
///   warnings [sentences, generate_warnings], guard {paper_iterations, start_rounds,
///   pulled_in_vertices, repaired_vertices, repair_iterations, unprotected_faces,
///   min_relative_volume} (guarded runs), gshell_version; the curvature method adds curvature {s_min,
///   s_max, clamped_prisms, limited_prisms, own_prisms {stretch, inverted_tets} (against the
///   prisms it was optimised towards), seconds (of the curvature prisms)}.
nlohmann::json generate_report(const GenerateResult& result, const std::string& input,
                               std::optional<double> thickness_ratio = std::nullopt);

/// Warnings about a generated shell, one sentence each (empty when there is nothing to say): the
/// base intersects itself, unextrudable vertices (the first ids), the result is not valid (with
/// the certificate's counts). The CLI prints them on stderr; the report lists them ("warnings").
std::vector<std::string> generate_warnings(const GenerateResult& result);

/// The quality part alone (`gshell metrics`): thickness, vertices, faces, tets, stretch, valid,
/// certificate, base_self_intersections, thinned_vertices, as in generate_report.
nlohmann::json metrics_report(const ShellMetrics& metrics, int vertices, int faces, double eta,
                              std::optional<double> thickness_ratio = std::nullopt);

/// A few lines for a terminal: sizes, method, energy, stretch, validity (certificate_summary),
/// thickness, times
/// (and the curvature method's clamp counts).
std::string generate_summary(const GenerateResult& result, const std::string& input);

/// The same for `gshell metrics`.
std::string metrics_summary(const ShellMetrics& metrics, int vertices, int faces, double eta);

} // namespace gshell
