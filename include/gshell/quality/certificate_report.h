#pragma once
// The one JSON and text form of a ShellCertificate, for every report that certifies a shell.
#include <gshell/quality/shell_certificate.h>

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace gshell {

/// Whether the shell is valid (ShellCertificate::valid: conditions 1-4 of docs/validity.md, and
/// the base does not intersect itself): true or false when the certificate decides it, empty when the pair tests
/// were skipped and no tet is inverted (validity unknown).
std::optional<bool> certified_validity(const ShellCertificate& certificate);

/// A certificate's count for a report: the number, or null where it was not tested (< 0).
nlohmann::ordered_json count_or_null(int count);

/// {"valid": true | false | null (certified_validity), "certificate": {"inverted_tets",
/// "top_self_intersections", "top_base_intersections", "wall_intersections", "nested_parts",
/// "exact": true},
/// "base_self_intersections"}, pair counts null when not tested: the keys go into the report of
/// the shell (`report.update(certificate_report(c))`).
nlohmann::ordered_json certificate_report(const ShellCertificate& certificate);

/// One line for a terminal summary, e.g. "valid        yes (exact: 0 inverted tets; top/top 0,
/// top/base 0, wall 0 intersecting face pairs)", and a second line for the base when it
/// intersects itself.
std::string certificate_summary(const ShellCertificate& certificate);

/// "3 sheets inside another part's layer" (certificate condition 4; "1 sheet ..." for one).
std::string nested_parts_phrase(long long sheets);

/// The first `shown` of `ids` for a message, e.g. "3, 5, 7, ..." (", ..." when some are left out).
std::string first_ids(const std::vector<int>& ids, std::size_t shown = 10);

/// What makes a shell invalid whatever its top, for a terminal line: e.g. "its base crosses itself
/// at 20 face pairs, and 4 base vertices cannot be extruded (3, 5, 7, 17)"; empty when the base
/// neither crosses itself (base_self_intersections <= 0) nor has unextrudable vertices
/// (extrusion_directions).
std::string unavoidable_faults(int base_self_intersections, const std::vector<int>& unextrudable_vertices = {});

} // namespace gshell
