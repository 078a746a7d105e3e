#include <gshell/quality/certificate_report.h>

namespace gshell {

nlohmann::ordered_json count_or_null(int count) {
  return count < 0 ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(count);
}

std::optional<bool> certified_validity(const ShellCertificate& c) {
  if (c.intersections_tested()) return c.valid();
  if (c.inverted_tets > 0) return false;
  return std::nullopt;
}

nlohmann::ordered_json certificate_report(const ShellCertificate& c) {
  const std::optional<bool> valid = certified_validity(c);
  return {{"valid", valid ? nlohmann::ordered_json(*valid) : nlohmann::ordered_json(nullptr)},
          {"certificate",
           {{"inverted_tets", c.inverted_tets},
            {"top_self_intersections", count_or_null(c.top_self_intersections)},
            {"top_base_intersections", count_or_null(c.top_base_intersections)},
            {"wall_intersections", count_or_null(c.wall_intersections)},
            {"nested_parts", count_or_null(c.nested_parts)},
            {"exact", c.exact}}},
          {"base_self_intersections", count_or_null(c.base_self_intersections)}};
}

std::string nested_parts_phrase(long long sheets) {
  return std::to_string(sheets) + (sheets == 1 ? " sheet" : " sheets") + " inside another part's layer";
}

std::string certificate_summary(const ShellCertificate& c) {
  const std::optional<bool> valid = certified_validity(c);
  std::string line = "valid        ";
  line += !valid ? "unknown" : *valid ? "yes" : "NO";
  line += " (exact: " + std::to_string(c.inverted_tets) + " inverted tets; ";
  if (c.intersections_tested())
    line += "top/top " + std::to_string(c.top_self_intersections) + ", top/base " +
            std::to_string(c.top_base_intersections) + ", wall " + std::to_string(c.wall_intersections) +
            " intersecting face pairs" +
            (c.nested_parts > 0 ? "; " + nested_parts_phrase(c.nested_parts) : "") +
            ")\n";
  else
    line += "intersections not tested)\n";
  if (c.base_self_intersections > 0)
    line += "base         intersects itself: " + std::to_string(c.base_self_intersections) +
            " face pairs (the input's own; no shell over it is one-to-one)\n";
  return line;
}

std::string first_ids(const std::vector<int>& ids, std::size_t shown) {
  std::string text;
  for (std::size_t i = 0; i < ids.size() && i < shown; ++i) text += (i ? ", " : "") + std::to_string(ids[i]);
  if (ids.size() > shown) text += ", ...";
  return text;
}

std::string unavoidable_faults(int base_self_intersections, const std::vector<int>& unextrudable_vertices) {
  std::string text;
  if (base_self_intersections > 0)
    text = "its base crosses itself at " + std::to_string(base_self_intersections) + " face pairs";
  if (!unextrudable_vertices.empty())
    text += (text.empty() ? "" : ", and ") + std::to_string(unextrudable_vertices.size()) +
            " base vertices cannot be extruded (" + first_ids(unextrudable_vertices) + ")";
  return text;
}

} // namespace gshell
