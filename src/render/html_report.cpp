#include <gshell/render/html_report.h>

#include <gshell/error.h>
#include <gshell/io/atomic_file.h>
#include <gshell/render/color_map.h>
#include <gshell/render/image.h>
#include <gshell/render/shell_render.h>
#include <gshell/render/svg_plot.h>
#include <gshell/run/shell_folder.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#ifndef GSHELL_VERSION
#define GSHELL_VERSION "unknown"
#endif

namespace gshell {
namespace fs = std::filesystem;
using json = nlohmann::ordered_json; // keeps the order report.json was written in

std::string base64_encode(const std::string& bytes) {
  static const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = (static_cast<unsigned char>(bytes[i]) << 16) | (static_cast<unsigned char>(bytes[i + 1]) << 8) |
                       static_cast<unsigned char>(bytes[i + 2]);
    out += alphabet[(v >> 18) & 63];
    out += alphabet[(v >> 12) & 63];
    out += alphabet[(v >> 6) & 63];
    out += alphabet[v & 63];
  }
  if (i < bytes.size()) {
    unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    out += alphabet[(v >> 18) & 63];
    out += alphabet[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? alphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

namespace {

// Integers exactly, other numbers to 6 significant digits.
std::string format_json_number(const json& v) {
  if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
  const double d = v.get<double>();
  if (std::isfinite(d) && d == std::round(d) && std::abs(d) < 1e15) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.0f", d);
    return buf;
  }
  return format_number(d, 6);
}

bool is_number_list(const json& v) {
  if (!v.is_array() || v.empty()) return false;
  for (const auto& x : v)
    if (!x.is_number()) return false;
  return true;
}

bool is_object_list(const json& v) {
  if (!v.is_array() || v.empty()) return false;
  for (const auto& x : v)
    if (!x.is_object()) return false;
  return true;
}

std::string format_value(const json& v) {
  if (v.is_number()) return format_json_number(v);
  if (v.is_string()) return xml_escape(v.get<std::string>());
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_null()) return "null";
  if (v.is_array()) {
    std::string out;
    for (const auto& x : v) out += (out.empty() ? "" : " ") + format_value(x);
    return "[" + out + "]";
  }
  return xml_escape(v.dump(-1, ' ', false, json::error_handler_t::replace)); // objects inside lists: rare, verbatim
}

// Leaves of a nested object as ("a.b", value); lists are leaves.
void flatten(const json& v, const std::string& prefix, std::vector<std::pair<std::string, json>>& out) {
  if (v.is_object()) {
    for (auto it = v.begin(); it != v.end(); ++it) flatten(it.value(), prefix.empty() ? it.key() : prefix + "." + it.key(), out);
  } else {
    out.emplace_back(prefix, v);
  }
}

std::vector<double> numbers_of(const json& list) {
  std::vector<double> values;
  for (const auto& x : list) values.push_back(x.get<double>());
  return values;
}

bool spans_decades(const std::vector<double>& y) {
  double lo = INFINITY, hi = 0;
  for (double v : y) {
    if (!(v > 0)) return false;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  return hi > 20 * lo;
}

/// A plot of several lines in the report's per-record size, log scale when they span decades.
void write_series_plot(std::ostream& html, const std::vector<PlotSeries>& series, PlotOptions plot) {
  std::vector<double> all;
  for (const auto& s : series) all.insert(all.end(), s.y.begin(), s.y.end());
  plot.log_y = spans_decades(all);
  plot.width = 460;
  plot.height = 240;
  html << "<div class=\"plot\">" << svg_line_plot(series, plot) << "</div>\n";
}

std::string singular(const std::string& key) {
  if (key == "frames") return "frame";
  if (key == "steps") return "step";
  if (key == "energy") return "iteration";
  if (key.size() > 1 && key.back() == 's') return key.substr(0, key.size() - 1);
  return "item";
}

void key_value_table(std::ostringstream& html, const std::string& caption,
                     const std::vector<std::pair<std::string, json>>& rows) {
  if (rows.empty()) return;
  html << "<table class=\"kv\">\n<caption>" << xml_escape(caption) << "</caption>\n";
  for (const auto& [key, value] : rows)
    html << "<tr><th>" << xml_escape(key) << "</th><td>" << format_value(value) << "</td></tr>\n";
  html << "</table>\n";
}

void number_list_section(std::ostringstream& html, const std::string& key, const json& list) {
  const std::vector<double> y = numbers_of(list);
  const bool energy = key == "energy" || key.find("energy") != std::string::npos;
  html << "<h3>" << xml_escape(key) << (energy ? " per iteration" : "") << "</h3>\n";
  PlotOptions plot;
  plot.title = energy ? key + " per iteration (0 = start state)" : key;
  plot.x_label = energy ? "iteration" : "index";
  plot.y_label = key;
  plot.log_y = spans_decades(y);
  html << "<div class=\"plots\"><div class=\"plot\">" << svg_line_plot(y, plot) << "</div>\n";
  // The convergence rate reads best as the distance to the final value on a log axis.
  if (energy && y.size() >= 3 && y.back() > 0) {
    std::vector<double> gap;
    for (size_t i = 0; i + 1 < y.size(); ++i) gap.push_back((y[i] - y.back()) / y.back());
    if (std::all_of(gap.begin(), gap.end(), [](double g) { return g > 0; })) {
      PlotOptions rate;
      rate.title = "convergence: (E_k - E_last) / E_last";
      rate.x_label = "iteration";
      rate.y_label = "relative gap";
      rate.log_y = true;
      html << "<div class=\"plot\">" << svg_line_plot(gap, rate) << "</div>\n";
    }
  }
  html << "</div>\n<details><summary>" << y.size() << " values</summary>\n<table class=\"list\">\n<tr><th>"
       << xml_escape(plot.x_label) << "</th><th>" << xml_escape(key) << "</th></tr>\n";
  for (size_t i = 0; i < list.size(); ++i) html << "<tr><td>" << i << "</td><td>" << format_json_number(list[i]) << "</td></tr>\n";
  html << "</table>\n</details>\n";
}

void record_list_section(std::ostringstream& html, const std::string& key, const json& list) {
  const std::string unit = singular(key);
  // Columns: the union of the flattened keys, in order of first appearance.
  std::vector<std::string> columns;
  std::vector<std::vector<std::pair<std::string, json>>> rows;
  for (const auto& record : list) {
    rows.emplace_back();
    flatten(record, "", rows.back());
    for (const auto& [name, value] : rows.back())
      if (std::find(columns.begin(), columns.end(), name) == columns.end()) columns.push_back(name);
  }
  html << "<h3>" << xml_escape(key) << " (" << list.size() << ")</h3>\n";
  // Time first: the figure people look for in a deformation run.
  std::stable_sort(columns.begin(), columns.end(), [](const std::string& a, const std::string& b) {
    auto rank = [](const std::string& c) { return c.find("seconds") != std::string::npos || c.find("time") != std::string::npos ? 0 : 1; };
    return rank(a) < rank(b);
  });
  // One plot per numeric column; a column X with a twin "offset.X" (deform --compare-offset)
  // shares its plot, so the benefit over the plain offset is one glance.
  auto column_values = [&](const std::string& column, bool& last_of_list) -> std::optional<std::vector<double>> {
    std::vector<double> y;
    for (const auto& row : rows) {
      auto it = std::find_if(row.begin(), row.end(), [&](const auto& kv) { return kv.first == column; });
      if (it == row.end()) {
        y.push_back(NAN);
      } else if (it->second.is_number()) {
        y.push_back(it->second.template get<double>());
      } else if (is_number_list(it->second)) {
        y.push_back(it->second.back().template get<double>());
        last_of_list = true;
      } else {
        return std::nullopt;
      }
    }
    return y;
  };
  const std::string twin_prefix = "offset.";
  html << "<div class=\"plots\">\n";
  for (const auto& column : columns) {
    if (list.size() < 2 || column == unit || column == "index") continue; // the x axis itself
    const bool has_twin = std::find(columns.begin(), columns.end(), twin_prefix + column) != columns.end();
    if (column.rfind(twin_prefix, 0) == 0 &&
        std::find(columns.begin(), columns.end(), column.substr(twin_prefix.size())) != columns.end())
      continue; // drawn with its twin
    bool last_of_list = false;
    const auto y = column_values(column, last_of_list);
    if (!y) continue;
    std::vector<PlotSeries> series{{key == "frames" && has_twin ? "shell" : column, *y}};
    if (has_twin) {
      bool twin_last = false;
      if (auto twin = column_values(twin_prefix + column, twin_last)) series.push_back({"offset", *twin});
    }
    PlotOptions plot;
    const bool is_time = column.find("seconds") != std::string::npos || column.find("time") != std::string::npos;
    plot.title = (is_time ? "time (" + column + ")" : column) + (last_of_list ? " (last value)" : "") + " per " + unit +
                 (series.size() > 1 ? " vs offset" : "");
    plot.x_label = unit;
    plot.x_start = 1; // frames and steps count from 1, as the CLI prints them
    plot.y_label = column;
    write_series_plot(html, series, plot);
  }
  // A column holding a list per record (deform's energy per iteration of each frame): one line
  // per record, for the first, middle and last record (all when there are few).
  for (const auto& column : columns) {
    std::vector<size_t> picks;
    if (rows.size() <= 4) {
      for (size_t i = 0; i < rows.size(); ++i) picks.push_back(i);
    } else {
      picks = {0, rows.size() / 2, rows.size() - 1};
    }
    std::vector<PlotSeries> series;
    for (size_t i : picks) {
      auto it = std::find_if(rows[i].begin(), rows[i].end(), [&](const auto& kv) { return kv.first == column; });
      if (it == rows[i].end() || !is_number_list(it->second) || it->second.size() < 2) continue;
      series.push_back({unit + " " + std::to_string(i + 1), numbers_of(it->second)});
    }
    if (series.empty()) continue;
    PlotOptions plot;
    plot.title = column + " per iteration (0 = start state)";
    plot.x_label = "iteration";
    plot.y_label = column;
    write_series_plot(html, series, plot);
    // Energies of different records can lie decades apart; the convergence of each reads best as
    // its distance to its own final value.
    std::vector<PlotSeries> gaps;
    for (const auto& line : series) {
      PlotSeries gap{line.name, {}};
      for (size_t k = 0; k + 1 < line.y.size(); ++k)
        gap.y.push_back(line.y.back() > 0 ? (line.y[k] - line.y.back()) / line.y.back() : NAN);
      if (std::any_of(gap.y.begin(), gap.y.end(), [](double g) { return g > 0; })) gaps.push_back(std::move(gap));
    }
    if (!gaps.empty()) {
      for (auto& gap : gaps)
        for (double& g : gap.y)
          if (!(g > 0)) g = NAN; // a log axis has no place for 0 (converged) or a rise
      PlotOptions rate = plot;
      rate.title = "convergence: (E_k - E_last) / E_last";
      rate.y_label = "relative gap";
      rate.log_y = true;
      html << "<div class=\"plot\">" << svg_line_plot(gaps, rate) << "</div>\n";
    }
  }
  // The record number column, unless the records number themselves (deform's "frame").
  const bool numbered = std::find(columns.begin(), columns.end(), unit) != columns.end();
  html << "</div>\n<div class=\"scroll\"><table class=\"records\">\n<tr>";
  if (!numbered) html << "<th>" << xml_escape(unit) << "</th>";
  for (const auto& column : columns) html << "<th>" << xml_escape(column) << "</th>";
  html << "</tr>\n";
  for (size_t i = 0; i < rows.size(); ++i) {
    html << "<tr>";
    if (!numbered) html << "<td>" << i + 1 << "</td>";
    for (const auto& column : columns) {
      auto it = std::find_if(rows[i].begin(), rows[i].end(), [&](const auto& kv) { return kv.first == column; });
      html << "<td>" << (it == rows[i].end() ? std::string() : format_value(it->second)) << "</td>";
    }
    html << "</tr>\n";
  }
  html << "</table></div>\n";
}

void image_figure(std::ostringstream& html, const Image& image, const std::string& caption) {
  html << "<figure><img alt=\"" << xml_escape(caption) << "\" width=\"" << image.width << "\" height=\"" << image.height
       << "\" src=\"data:image/png;base64," << base64_encode(encode_png(image)) << "\"/><figcaption>" << xml_escape(caption)
       << "</figcaption></figure>\n";
}

void renders_section(std::ostringstream& html, const fs::path& dir, const ReportOptions& options,
                     std::vector<std::string>& left_out) {
  html << "<h2>Renders</h2>\n";
  try {
    ShellRenderOptions ro;
    ro.figure.width = options.render_width;
    ro.figure.height = options.render_height;
    // The panels of the folder's preview: first, middle and last frame of a deformation, the rest
    // shell beside a pose, or the shell alone.
    PreviewPanels preview = preview_panels(dir.string());
    if (!preview.note.empty()) {
      html << "<p class=\"note\">" << xml_escape(preview.note) << "</p>\n";
      left_out.push_back(preview.note);
    }
    if (!is_shell_folder(dir)) {
      ro.figure.width = options.render_width * 3 / 2;
      std::string names;
      for (const auto& c : preview.captions) names += (names.empty() ? "" : ", ") + c;
      image_figure(html, render_subjects(preview.subjects, preview.captions, ro),
                   names + " (first, middle and last frame), colored by stretch against the rest shell (iso view)");
    } else {
      if (preview.subjects.size() > 1) {
        ro.figure.width = options.render_width * 3 / 2;
        image_figure(html, render_subjects(preview.subjects, preview.captions, ro),
                     "rest and posed shell, opaque base under a translucent top, colored by stretch against the rest "
                     "shell (iso view)");
        ro.figure.width = options.render_width;
      }
      const std::vector<RenderSubject> subject{preview.subjects.back()};
      if (preview.subjects.size() == 1)
        image_figure(html, render_subjects(subject, {default_caption(subject[0])}, ro),
                     "opaque base under a translucent top, colored by per-prism stretch (iso view)");
      ro.style = ShellStyle::Cut;
      image_figure(html, render_subjects(subject, {"cut-away"}, ro),
                   "cut-away: the half nearer the eye removed, so the layer between base and top shows at the cut");
    }
  } catch (const std::exception& e) {
    html << "<p class=\"note\">No render: " << xml_escape(e.what()) << "</p>\n";
    left_out.push_back(std::string("no render: ") + e.what());
  }
}

// A shell's validity in one line (reports with a certificate: generate, metrics).
void validity_paragraph(std::ostringstream& html, const json& report) {
  if (!report.contains("valid")) return;
  const json& valid = report["valid"];
  const char* verdict = valid.is_boolean() ? (valid.get<bool>() ? "yes" : "no") : "unknown";
  const char* style = valid.is_boolean() ? (valid.get<bool>() ? "ok" : "note") : "";
  html << "<p class=\"validity " << style << "\"><strong>Valid shell: " << verdict << "</strong>";
  if (report.contains("certificate") && report["certificate"].is_object()) {
    const json& c = report["certificate"];
    auto count = [&](const char* key) { return c.contains(key) ? format_value(c[key]) : std::string("?"); };
    html << " (exact certificate: " << count("inverted_tets") << " inverted tets; intersecting face pairs: top/top "
         << count("top_self_intersections") << ", top/base " << count("top_base_intersections") << ", side walls "
         << count("wall_intersections") << "; sheets inside another part's layer " << count("nested_parts") << ")";
  }
  if (!valid.is_boolean()) html << "; the intersection tests were not run";
  if (report.contains("base_self_intersections") && report["base_self_intersections"].is_number() &&
      report["base_self_intersections"].get<int>() > 0)
    html << ". The base intersects itself (" << format_value(report["base_self_intersections"])
         << " face pairs): no shell over it is an embedding";
  html << ".</p>\n";
  // Generation: whether the guard made it, and what it could not mend (generate_warnings).
  if (report.contains("guarded") && report["guarded"].is_boolean())
    html << "<p>" << (report["guarded"].get<bool>() ? "Guarded generation (valid by construction where the base allows)"
                                                   : "Unguarded result (no validity guard)")
         << (report.contains("thinned_vertices") ? "; thinned top vertices (below 0.9 eta): " +
                                                       format_value(report["thinned_vertices"])
                                                 : std::string())
         << ".</p>\n";
  if (report.contains("warnings") && report["warnings"].is_array())
    for (const json& w : report["warnings"]) html << "<p class=\"note\">Warning: " << format_value(w) << "</p>\n";
}

const char* kStyle = R"(body{font-family:sans-serif;margin:2em auto;max-width:1200px;color:#222;padding:0 1em}
h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}
table{border-collapse:collapse;margin:.5em 1.5em .8em 0;font-size:.92em}
th,td{border:1px solid #ddd;padding:.25em .6em;text-align:left;vertical-align:top}
th{background:#f3f3f3;font-weight:600}td{font-variant-numeric:tabular-nums}
caption{text-align:left;font-weight:bold;padding:.3em 0}
table.kv{display:inline-table}
.scroll{overflow-x:auto}.plots{display:flex;flex-wrap:wrap;gap:.5em}
figure{margin:1em 0}img{max-width:100%;height:auto;border:1px solid #ddd}
figcaption{color:#555;font-size:.9em}.note{color:#a33}.ok{color:#276b2a})";

} // namespace

std::string html_report(const std::string& dir_text, const ReportOptions& options, std::vector<std::string>* warnings) {
  const fs::path dir(dir_text);
  const json report = read_report(dir);
  // The page shows whatever figures a report has, so one of another program (or `{}`) would make
  // a page of nothing with no word of why. Every gshell report has one of these keys.
  if (!report.contains("command") && !report.contains("method") && !report.contains("gshell_version"))
    throw InputError(with_file((dir / "report.json").string(),
                               "not a report of gshell (none of \"command\", \"method\", \"gshell_version\")"));

  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html xmlns=\"http://www.w3.org/1999/xhtml\" lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n"
       << "<title>gshell report: " << xml_escape(dir_text) << "</title>\n<style>" << kStyle << "</style>\n</head>\n<body>\n";
  html << "<h1>gshell report</h1>\n<p>Folder <code>" << xml_escape(fs::absolute(dir).lexically_normal().string())
       << "</code>, written by gshell " << GSHELL_VERSION << ".</p>\n";
  validity_paragraph(html, report);

  // Settings and scalar figures: the top-level scalars, then one table per nested object.
  html << "<h2>Settings and figures</h2>\n";
  std::vector<std::pair<std::string, json>> scalars;
  for (auto it = report.begin(); it != report.end(); ++it)
    if (!it->is_object() && !it->is_array()) scalars.emplace_back(it.key(), it.value());
  key_value_table(html, "run", scalars);
  for (auto it = report.begin(); it != report.end(); ++it)
    if (it->is_object()) {
      std::vector<std::pair<std::string, json>> rows;
      flatten(it.value(), "", rows);
      key_value_table(html, it.key(), rows);
    }
  // Short lists that are neither numbers nor records (e.g. input names).
  for (auto it = report.begin(); it != report.end(); ++it)
    if (it->is_array() && !is_number_list(it.value()) && !is_object_list(it.value()))
      key_value_table(html, it.key(), {{it.key(), it.value()}});

  bool any_series = false;
  for (auto it = report.begin(); it != report.end(); ++it)
    if (is_number_list(it.value()) || is_object_list(it.value())) any_series = true;
  if (any_series) {
    html << "<h2>Convergence and timings</h2>\n";
    for (auto it = report.begin(); it != report.end(); ++it)
      if (is_number_list(it.value())) number_list_section(html, it.key(), it.value());
    for (auto it = report.begin(); it != report.end(); ++it)
      if (is_object_list(it.value())) record_list_section(html, it.key(), it.value());
  }
  std::vector<std::string> left_out;
  if (options.renders) renders_section(html, dir, options, left_out);
  if (warnings) *warnings = std::move(left_out);
  html << "</body>\n</html>\n";
  return html.str();
}

void write_html_report(const std::string& dir, const std::string& path, const ReportOptions& options,
                       std::vector<std::string>* warnings) {
  const std::string page = html_report(dir, options, warnings);
  write_file_atomically(path, [&](std::ostream& out) { out << page; });
}

} // namespace gshell
