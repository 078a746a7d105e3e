#pragma once
// The one JSON form of StretchStats, shared by every report (generate, metrics, deform, pose).
#include <gshell/quality/stretch.h>

#include <nlohmann/json.hpp>

namespace gshell {

/// {"stretch": {"mean", "volume_mean", "max", "p99"}, "inverted_tets": n}: the two keys go into
/// the object that reports on those tets (`report.update(stretch_report(s))`), so `inverted_tets`
/// sits beside the other counts of a report and `stretch` holds the per-tet statistics only.
nlohmann::ordered_json stretch_report(const StretchStats& stats);

} // namespace gshell
