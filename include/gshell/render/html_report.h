#pragma once
// `gshell report`: one self-contained HTML page (no external files: images are inlined as
// base64 data URIs, plots are inline SVG) describing a run folder written by generate / deform / pose.
#include <string>
#include <vector>

namespace gshell {

struct ReportOptions {
  bool renders = true;                      ///< include fresh renders of the shell (needs OSMesa)
  int render_width = 960, render_height = 540;
};

/// The page for DIR (which must hold report.json): every setting and figure of report.json in
/// tables (nested objects flattened as a.b), a plot of every list of numbers (energy per
/// iteration on a log axis), tables and plots of per-frame / per-step records (time per frame,
/// energy, iterations, ...), and renders (iso view colored by stretch and a cut-away; first /
/// middle / last frame for a deformation). The markup is well-formed XML (XHTML syntax).
/// \throws InputError naming the file when report.json is missing or not a JSON object, or a render
///         of DIR fails to load (load_render_subject).
/// `warnings`, when given, receives what the page had to leave out and why (a render that failed,
/// a pose's rest shell that cannot be found); the page says it too.
std::string html_report(const std::string& dir, const ReportOptions& options = {},
                        std::vector<std::string>* warnings = nullptr);

/// Writes html_report(dir) to `path` atomically.
/// \throws InputError as html_report, or naming `path` when it cannot be written.
void write_html_report(const std::string& dir, const std::string& path, const ReportOptions& options = {},
                       std::vector<std::string>* warnings = nullptr);

/// Standard base64 (RFC 4648, with padding).
std::string base64_encode(const std::string& bytes);

} // namespace gshell
