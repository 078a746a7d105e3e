#include <gshell/deform/handles.h>

#include "io/json_input.h"
#include "quality/nested_parts.h"

#include <gshell/error.h>
#include <gshell/format_number.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/shell/generate_shell.h>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace gshell {

using nlohmann::json;

std::vector<int> HandleSet::constrained_vertices() const {
  std::vector<int> out;
  for (const auto& h : handles) out.insert(out.end(), h.vertices.begin(), h.vertices.end());
  return out;
}

Eigen::MatrixXd HandleSet::targets(const Eigen::MatrixXd& rest_vertices, double fraction) const {
  // The ids were checked against a shell (check_handles), not against this matrix.
  for (const auto& h : handles)
    for (int v : h.vertices)
      if (v < 0 || v >= rest_vertices.rows() || rest_vertices.cols() != 3)
        throw InputError("handles: rest_vertices is " + std::to_string(rest_vertices.rows()) + " x " +
                         std::to_string(rest_vertices.cols()) + ", handle vertex " + std::to_string(v) +
                         " needs a row of 3 coordinates");
  Eigen::MatrixXd P(static_cast<Eigen::Index>(constrained_vertices().size()), 3);
  Eigen::Index row = 0;
  for (const auto& h : handles) {
    // Whole turns first: degrees * pi would overflow for |degrees| > 5e307 (any finite number is
    // accepted), and cos/sin are only accurate on moderate arguments anyway.
    const double radians = std::fmod(fraction * h.degrees, 360.0) * M_PI / 180.0;
    // Any non-zero axis, as a file's (AngleAxis needs a unit one; stableNorm, as parse_handles).
    const Eigen::Vector3d axis = h.axis / h.axis.stableNorm();
    const Eigen::Matrix3d R = Eigen::AngleAxisd(radians, axis).toRotationMatrix();
    const Eigen::Vector3d shift = fraction * h.translate;
    for (int v : h.vertices) {
      const Eigen::Vector3d u = rest_vertices.row(v).transpose();
      P.row(row++) = (R * (u - h.center) + h.center + shift).transpose();
    }
  }
  return P;
}

namespace {

/// Throws "NAME: WHERE: problem".
struct Reporter {
  std::string name;
  [[noreturn]] void fail(const std::string& where, const std::string& problem) const {
    throw InputError(with_file(name, where.empty() ? problem : where + ": " + problem));
  }
};

void check_keys(const json& object, const std::set<std::string>& allowed, const std::string& where,
                const Reporter& r) {
  if (!object.is_object()) r.fail(where, "expected a JSON object");
  for (const auto& [key, value] : object.items())
    if (!allowed.count(key) && key != "comment") {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      r.fail(where, "unknown key \"" + key + "\" (expected " + list + ")");
    }
}

double finite_number(const json& value, const std::string& where, const Reporter& r) {
  if (!value.is_number()) r.fail(where, "expected a number, got " + value.dump());
  const double x = value.get<double>();
  if (!std::isfinite(x)) r.fail(where, "number is not finite");
  return x;
}

Eigen::Vector3d vector3(const json& value, const std::string& where, const Reporter& r) {
  if (!value.is_array() || value.size() != 3) r.fail(where, "expected [x, y, z], got " + value.dump());
  Eigen::Vector3d v;
  for (int k = 0; k < 3; ++k) v(k) = finite_number(value[k], where, r);
  return v;
}

/// A translation or a point: within the coordinates gshell accepts (validate_mesh.h), so that
/// targets (rest position + rotation + translation) stay finite.
Eigen::Vector3d position3(const json& value, const std::string& where, const Reporter& r) {
  const Eigen::Vector3d v = vector3(value, where, r);
  if (const std::string problem = too_large_coordinate(v); !problem.empty()) r.fail(where, problem);
  return v;
}

std::vector<int> explicit_vertices(const json& value, int num_vertices, const std::string& where,
                                   const Reporter& r) {
  if (!value.is_array()) r.fail(where, "\"vertices\" must be an array of vertex ids");
  std::vector<int> ids;
  for (const auto& id : value) {
    // An integer past 64 bits is read as a float (2^64 + 1 as 1.8446744073709552e+19): it is an
    // integer, just far out of range.
    if (id.is_number_float() && std::abs(id.get<double>()) >= 0x1p63 && std::isfinite(id.get<double>()))
      r.fail(where, "unknown vertex id " + id.dump() + " (the shell has vertices 0.." + std::to_string(num_vertices - 1) +
                        ")");
    if (!id.is_number_integer()) r.fail(where, "vertex id " + id.dump() + " is not an integer");
    // Unsigned first: get<long long> of 2^63 and above wraps to a negative id.
    const bool in_range = id.is_number_unsigned()
                              ? id.get<unsigned long long>() < static_cast<unsigned long long>(num_vertices)
                              : id.get<long long>() >= 0 && id.get<long long>() < num_vertices;
    if (!in_range)
      r.fail(where, "unknown vertex id " + id.dump() + " (the shell has vertices 0.." +
                        std::to_string(num_vertices - 1) + ")");
    const auto v = id.get<long long>();
    ids.push_back(static_cast<int>(v));
  }
  if (ids.empty()) r.fail(where, "\"vertices\" is empty");
  return ids;
}

std::vector<int> selected_vertices(const json& select, const Shell& rest, const std::string& where,
                                   const Reporter& r) {
  check_keys(select, {"surface", "box"}, where + ": select", r);
  std::string surface = "both";
  if (select.contains("surface")) {
    if (!select["surface"].is_string()) r.fail(where, "select.surface must be \"base\", \"top\" or \"both\"");
    surface = select["surface"].get<std::string>();
    if (surface != "base" && surface != "top" && surface != "both")
      r.fail(where, "select.surface must be \"base\", \"top\" or \"both\", got \"" + surface + "\"");
  }
  if (!select.contains("box")) r.fail(where, "select needs a \"box\": [xmin, ymin, zmin, xmax, ymax, zmax]");
  const json& box = select["box"];
  if (!box.is_array() || box.size() != 6) r.fail(where, "select.box must be [xmin, ymin, zmin, xmax, ymax, zmax]");
  Eigen::Vector3d lo, hi;
  for (int k = 0; k < 3; ++k) {
    lo(k) = finite_number(box[k], where + ": select.box", r);
    hi(k) = finite_number(box[k + 3], where + ": select.box", r);
    if (lo(k) > hi(k)) r.fail(where, "select.box has min > max along axis " + std::to_string(k));
  }
  const int n = rest.num_base_vertices();
  std::vector<int> ids;
  auto scan = [&](const Eigen::MatrixXd& P, int offset) {
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d p = P.row(i).transpose();
      if ((p.array() >= lo.array()).all() && (p.array() <= hi.array()).all()) ids.push_back(offset + i);
    }
  };
  if (surface != "top") scan(rest.base, 0);
  if (surface != "base") scan(rest.top, n);
  if (ids.empty()) r.fail(where, "select matches no vertex (" + surface + " surface, box " + box.dump() + ")");
  return ids;
}

Handle parse_handle(const json& h, int index, const Shell& rest, const Reporter& r) {
  const std::string where = "handle " + std::to_string(index);
  check_keys(h, {"name", "vertices", "select", "translate", "rotate"}, where, r);
  const int num_vertices = 2 * rest.num_base_vertices();
  const bool has_ids = h.contains("vertices"), has_select = h.contains("select");
  if (has_ids == has_select) r.fail(where, "give exactly one of \"vertices\" and \"select\"");
  Handle out;
  if (h.contains("name")) {
    if (!h["name"].is_string()) r.fail(where, "\"name\" must be a string");
    out.name = h["name"].get<std::string>();
  }
  out.vertices = has_ids ? explicit_vertices(h["vertices"], num_vertices, where, r)
                         : selected_vertices(h["select"], rest, where, r);
  std::sort(out.vertices.begin(), out.vertices.end());
  out.vertices.erase(std::unique(out.vertices.begin(), out.vertices.end()), out.vertices.end());

  const Eigen::MatrixXd X = rest.vertices();
  out.center = Eigen::Vector3d::Zero();
  for (int v : out.vertices) out.center += X.row(v).transpose();
  out.center /= static_cast<double>(out.vertices.size());

  if (h.contains("translate")) out.translate = position3(h["translate"], where + ": translate", r);
  if (h.contains("rotate")) {
    const json& rot = h["rotate"];
    check_keys(rot, {"axis", "degrees", "center"}, where + ": rotate", r);
    if (!rot.contains("axis") || !rot.contains("degrees")) r.fail(where, "rotate needs \"axis\" and \"degrees\"");
    const Eigen::Vector3d axis = vector3(rot["axis"], where + ": rotate.axis", r);
    // stableNorm: norm() squares first, which overflows for [1e200, 0, 0] (and made the axis 0)
    // and underflows for [1e-200, 0, 0].
    const double length = axis.stableNorm();
    if (!(length > 0)) r.fail(where, "rotate.axis is zero");
    out.axis = axis / length;
    out.degrees = finite_number(rot["degrees"], where + ": rotate.degrees", r);
    if (rot.contains("center")) out.center = position3(rot["center"], where + ": rotate.center", r);
  }
  return out;
}

/// The handle file as JSON, with the checks that need no shell.
json parse_handle_document(const std::string& json_text, const Reporter& r) {
  // Handle files nest 5 levels; deeper ones are refused before anything recursive (the dump of a
  // value in an error message) walks them.
  constexpr int kMaxHandlesDepth = 32;
  if (io_detail::json_nesting_depth(json_text, kMaxHandlesDepth) > kMaxHandlesDepth)
    r.fail("", "nested deeper than " + std::to_string(kMaxHandlesDepth) + " levels");
  json doc;
  std::string repeated_key; // refused after the parse: its errors come first
  try {
    doc = io_detail::parse_json_noting_repeated_keys(json_text, repeated_key);
  } catch (const json::exception& e) { // parse errors, and number overflow such as 1e999
    r.fail("", io_detail::not_valid_json(e));
  }
  if (!repeated_key.empty()) r.fail("", "the key \"" + repeated_key + "\" appears twice in one object");
  return doc;
}

} // namespace

void check_handle_file_syntax(const std::string& json_text, const std::string& name) {
  parse_handle_document(json_text, Reporter{name});
}

HandleSet parse_handles(const std::string& json_text, const std::string& name, const Shell& rest) {
  const Reporter r{name};
  json doc = parse_handle_document(json_text, r);
  check_keys(doc, {"handles", "mode", "weight"}, "", r);
  HandleSet set;
  const bool has_weight = doc.contains("weight");
  if (has_weight) {
    set.weight = finite_number(doc["weight"], "weight", r);
    if (!(set.weight > 0)) r.fail("weight", "must be > 0");
    if (set.weight < kMinSoftWeight) r.fail("weight", "must be >= 1e-12 (weaker springs are lost to rounding)");
    // 1e17 made the hierarchy's reduced matrices indefinite ("internal error"); see kMaxSoftWeight.
    if (set.weight > kMaxSoftWeight) r.fail("weight", "must be <= 1e12 (for handles held exactly use \"mode\": \"hard\")");
  }
  // A weight without a mode asks for soft constraints; otherwise hard is the default.
  set.mode = has_weight ? ConstraintMode::Soft : ConstraintMode::Hard;
  if (doc.contains("mode")) {
    const json& m = doc["mode"];
    if (!m.is_string() || (m != "hard" && m != "soft")) r.fail("mode", "must be \"hard\" or \"soft\", got " + m.dump());
    set.mode = m == "hard" ? ConstraintMode::Hard : ConstraintMode::Soft;
    if (set.mode == ConstraintMode::Hard && has_weight)
      r.fail("weight", "applies only to \"mode\": \"soft\" (hard handles are held exactly)");
  }
  if (!doc.contains("handles")) r.fail("", "missing \"handles\"");
  const json& list = doc["handles"];
  if (!list.is_array()) r.fail("handles", "must be an array");
  if (list.empty()) r.fail("handles", "is empty: at least one handle is needed to pin the shell in space");
  for (size_t k = 0; k < list.size(); ++k) set.handles.push_back(parse_handle(list[k], static_cast<int>(k), rest, r));

  std::map<int, int> owner;
  for (size_t k = 0; k < set.handles.size(); ++k)
    for (int v : set.handles[k].vertices) {
      const auto [it, fresh] = owner.emplace(v, static_cast<int>(k));
      if (!fresh)
        r.fail("", "vertex " + std::to_string(v) + " is in handles " + std::to_string(it->second) + " and " +
                       std::to_string(k) + " (handles must not overlap)");
    }
  // Targets so far out that the layer is below the spacing of doubles there (as generation
  // refuses such bases: kMinThicknessScale): no pose could keep a top apart from its base, and the
  // guarded drag would spend minutes finding that out (a bowl moved by 1e20).
  if (rest.thickness > 0) {
    const Eigen::MatrixXd targets = set.targets(rest.vertices(), 1.0);
    Eigen::Index row = 0;
    for (size_t k = 0; k < set.handles.size(); ++k) {
      const Eigen::Index rows = static_cast<Eigen::Index>(set.handles[k].vertices.size());
      const double reach = targets.middleRows(row, rows).cwiseAbs().maxCoeff();
      row += rows;
      if (rest.thickness < kMinThicknessScale * reach)
        r.fail("handle " + std::to_string(k),
               "moves its vertices to coordinates of " + format_number(reach) + ", where the shell's thickness " +
                   format_number(rest.thickness) + " is below " + format_number(kMinThicknessScale) +
                   " of them: double precision cannot tell a top that close from the base");
    }
  }
  // Checked here as well as by the solver, so a pose names it before its solver's setup.
  try {
    check_handles_hold_every_part(set, rest.F, rest.num_base_vertices());
  } catch (const InputError& e) {
    r.fail("", e.what());
  }
  return set;
}

void check_handles_hold_every_part(const HandleSet& handles, const Eigen::MatrixXi& F, int n) {
  const detail::ShellParts parts = detail::shell_parts(F, n);
  std::vector<char> anchored(parts.count(), 0);
  for (int v : handles.constrained_vertices())
    if (const int part = parts.of_vertex[v < n ? v : v - n]; part >= 0) anchored[part] = 1;
  for (int part = 0; part < parts.count(); ++part) // by lowest vertex: the first free one names it
    if (!anchored[part])
      throw InputError("the handles leave a connected part of the shell free (e.g. the part with base vertex " +
                       std::to_string(parts.probe[part]) + "): give every part at least one handle vertex");
}

void check_handles(const HandleSet& set, int shell_vertices) {
  if (set.mode == ConstraintMode::Soft && !(set.weight >= kMinSoftWeight && set.weight <= kMaxSoftWeight))
    throw InputError("handles: weight must be in [1e-12, 1e12]");
  std::vector<int> owner(std::max(shell_vertices, 0), -1);
  // By index (the file's order, from 0) and by name where it has one: the viewer lists groups by
  // name, counting from 1.
  auto label = [&](size_t k) {
    const std::string& name = set.handles[k].name;
    return "handle " + std::to_string(k) + (name.empty() ? "" : " ('" + name + "')");
  };
  for (size_t k = 0; k < set.handles.size(); ++k) {
    const Handle& h = set.handles[k];
    const std::string where = label(k) + ": ";
    if (h.vertices.empty()) throw InputError(where + "no vertices");
    for (int v : h.vertices) {
      if (v < 0 || v >= shell_vertices)
        throw InputError(where + "unknown vertex id " + std::to_string(v) + " (the shell has vertices 0.." +
                         std::to_string(shell_vertices - 1) + ")");
      if (owner[v] >= 0)
        throw InputError(where + "vertex " + std::to_string(v) + " is in " + label(static_cast<size_t>(owner[v])) +
                         " too (handles must not overlap)");
      owner[v] = static_cast<int>(k);
    }
    if (!h.translate.allFinite() || !h.center.allFinite() || !h.axis.allFinite() || !std::isfinite(h.degrees))
      throw InputError(where + "a motion number is not finite");
    if (!(h.axis.stableNorm() > 0)) throw InputError(where + "the rotation axis is zero");
    for (const auto& [key, p] : {std::pair{"translate", &h.translate}, std::pair{"center", &h.center}})
      if (const std::string problem = too_large_coordinate(*p); !problem.empty())
        throw InputError(where + key + ": " + problem);
  }
}

nlohmann::ordered_json handles_to_json(const HandleSet& set) {
  using ojson = nlohmann::ordered_json;
  auto vec = [](const Eigen::Vector3d& v) { return ojson::array({v.x(), v.y(), v.z()}); };
  ojson doc;
  doc["mode"] = set.mode == ConstraintMode::Hard ? "hard" : "soft";
  if (set.mode == ConstraintMode::Soft) doc["weight"] = set.weight;
  ojson list = ojson::array();
  for (const Handle& h : set.handles) {
    ojson j;
    if (!h.name.empty()) j["name"] = h.name;
    j["vertices"] = h.vertices;
    if (!h.translate.isZero(0)) j["translate"] = vec(h.translate);
    // The center is kept even without a rotation: it is part of the handle (a later rotation turns about it).
    j["rotate"] = ojson{{"axis", vec(h.axis)}, {"degrees", h.degrees}, {"center", vec(h.center)}};
    list.push_back(std::move(j));
  }
  doc["handles"] = std::move(list);
  return doc;
}

std::string read_handle_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw InputError(with_file(path, "is a directory, expected a handle file (JSON)"));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(with_file(path, "cannot open handle file"));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

HandleSet read_handles(const std::string& path, const Shell& rest) {
  return parse_handles(read_handle_file(path), path, rest);
}

} // namespace gshell
