// `gshell info MESH`: size, topology and validation problems of a surface mesh.
#include "command_registry.h"

#include <gshell/error.h>
#include <gshell/geometry/mesh_topology.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/load_mesh.h>
#include <gshell/quality/triangle_intersections.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

namespace gshell::cli {
namespace {

struct InfoArgs {
  std::string mesh;
  bool json = false;
};

std::string vec_text(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s << std::setprecision(6) << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return s.str();
}

std::string genus_text(double genus, int errors) {
  std::ostringstream s;
  s << genus;
  if (genus != std::floor(genus) || genus < 0) s << " (not a whole number: the surface is not a manifold)";
  else if (errors > 0) s << " (unreliable: the mesh has errors)";
  return s.str();
}

void print_text(const std::string& name, const TriMesh& mesh, const MeshStats& s,
                const std::vector<MeshProblem>& problems, int errors, int warnings, int infos) {
  std::ostream& out = std::cout;
  const auto line = [&](const std::string& key, const auto& value) {
    out << std::left << std::setw(22) << (key + ":") << value << "\n";
  };
  out << std::setprecision(6);
  line("mesh", name);
  line("vertices", s.vertices);
  line("faces", s.faces);
  line("edges", s.edges);
  line("boundary loops", s.boundary_loops);
  line("boundary edges", s.boundary_edges);
  line("components", s.components);
  line("euler characteristic", s.euler_characteristic);
  line("genus", genus_text(s.genus, errors));
  line("bounding box", vec_text(s.bbox_min) + " to " + vec_text(s.bbox_max));
  const Eigen::Vector3d size = s.bbox_max - s.bbox_min;
  std::ostringstream size_text;
  size_text << std::setprecision(6) << size.x() << " x " << size.y() << " x " << size.z() << " (diagonal "
            << size.stableNorm() << ")"; // 1e300 or 1e-300 apart: no overflow or underflow
  line("size", size_text.str());
  line("mean edge length", s.mean_edge_length);
  line("texture coordinates", mesh.has_uv() ? std::to_string(mesh.UV.rows()) : std::string("none"));
  line("problems", problems.empty() ? std::string("none")
                                    : std::to_string(errors) + " errors, " + std::to_string(warnings) +
                                          " warnings, " + std::to_string(infos) + " info");
  for (const auto& p : problems) out << "  " << severity_name(p.severity) << ": " << p.message << "\n";
}

void print_json(const std::string& name, const TriMesh& mesh, const MeshStats& s,
                const std::vector<MeshProblem>& problems) {
  nlohmann::json j;
  j["mesh"] = name;
  j["vertices"] = s.vertices;
  j["faces"] = s.faces;
  j["edges"] = s.edges;
  j["boundary_loops"] = s.boundary_loops;
  j["boundary_edges"] = s.boundary_edges;
  j["components"] = s.components;
  j["euler_characteristic"] = s.euler_characteristic;
  // A whole genus is an integer for JSON readers too (genus 0, not 0.0); a half one (a surface
  // that is not a manifold) stays a number with its fraction.
  if (s.genus == std::floor(s.genus) && std::abs(s.genus) < 1e15) j["genus"] = static_cast<long long>(s.genus);
  else j["genus"] = s.genus;
  j["bbox_min"] = {s.bbox_min.x(), s.bbox_min.y(), s.bbox_min.z()};
  j["bbox_max"] = {s.bbox_max.x(), s.bbox_max.y(), s.bbox_max.z()};
  j["mean_edge_length"] = s.mean_edge_length;
  j["unreferenced_vertices"] = s.unreferenced_vertices;
  j["texture_coordinates"] = mesh.has_uv() ? static_cast<int>(mesh.UV.rows()) : 0;
  j["problems"] = nlohmann::json::array();
  for (const auto& p : problems)
    j["problems"].push_back({{"severity", severity_name(p.severity)}, {"message", p.message}, {"count", p.count}});
  std::cout << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n"; // a non-UTF-8 file name
}

void run_info(const InfoArgs& args) {
  std::vector<std::string> read_warnings;
  const TriMesh mesh = read_mesh_or_builtin(args.mesh, &read_warnings);
  const MeshStats stats = mesh_stats(mesh);
  auto problems = validate_mesh(mesh);
  // What reading warned of (texture coordinates dropped) is listed with the warnings, after the
  // errors, in the list's own form: without the file name, which heads the report.
  auto first_non_error = std::find_if(problems.begin(), problems.end(),
                                      [](const MeshProblem& p) { return p.severity != MeshProblem::Severity::Error; });
  for (std::string& w : read_warnings) {
    const std::string prefix = args.mesh + ": ";
    if (w.rfind(prefix, 0) == 0) w.erase(0, prefix.size());
    first_non_error = problems.insert(first_non_error, {MeshProblem::Severity::Warning, w, 1, "reader warnings"}) + 1;
  }
  // A surface that crosses itself (a fan-split polygon folded over itself, a scan's overlaps) can
  // carry a shell, but not a clean one near the crossings: generate would report it only after
  // the run. The exact test of generation's certificate, on meshes valid enough to take it.
  const bool any_error = std::any_of(problems.begin(), problems.end(),
                                     [](const MeshProblem& p) { return p.severity == MeshProblem::Severity::Error; });
  if (!any_error) {
    const auto crossings = surface_self_intersections(mesh.V, mesh.F);
    if (!crossings.empty()) {
      const auto [f, g] = crossings.front();
      const int count = static_cast<int>(crossings.size());
      first_non_error =
          problems.insert(first_non_error,
                          {MeshProblem::Severity::Warning,
                           "the surface intersects itself (" + std::to_string(count) + " pair" + (count == 1 ? "" : "s") +
                               " of faces cross, e.g. faces " + std::to_string(f) + " and " + std::to_string(g) +
                               "): a shell cannot be clean near the crossings",
                           count, "self-intersections"}) +
          1;
    }
    // Not a problem (inward shells are a use), but a mirrored export is a common accident.
    const std::vector<int> inward = inward_closed_parts(mesh.V, mesh.F);
    if (!inward.empty())
      problems.push_back({MeshProblem::Severity::Info, inward_closed_parts_message(inward),
                          static_cast<int>(inward.size()), "inward closed parts"});
  }
  // Occurrences, not entries: a summary entry ("... and 3058 more") stands for many.
  int errors = 0, warnings = 0, infos = 0;
  for (const auto& p : problems)
    (p.severity == MeshProblem::Severity::Error ? errors : p.severity == MeshProblem::Severity::Warning ? warnings : infos) +=
        p.count;
  if (args.json)
    print_json(args.mesh, mesh, stats, problems);
  else
    print_text(args.mesh, mesh, stats, problems, errors, warnings, infos);
  std::cout.flush();
  if (errors > 0)
    throw InputError(with_file(args.mesh, std::to_string(errors) + " validation error" + (errors == 1 ? "" : "s") +
                                              ": no shell can be built on this mesh (problems listed on stdout)"));
}

void add_info_command(CLI::App& parent) {
  auto args = std::make_shared<InfoArgs>();
  CLI::App* cmd = parent.add_subcommand(
      "info",
      "Print a mesh's size and topology (vertices, faces, edges, boundary loops, components, Euler "
      "characteristic, genus, bounding box, mean edge length) and every validation problem found.\n"
      "Exit code: 0 if the mesh can carry a shell (warnings and info allowed), 1 if it has validation "
      "errors (they are listed) or cannot be read.\n"
      "Example: gshell info models/bunny00.off");
  cmd->add_option("MESH", args->mesh,
                  "Mesh file (.obj .off .ply .stl) or builtin:NAME[:RES] with NAME one of sphere, torus, plane, "
                  "cylinder, bowl")
      ->required();
  cmd->add_flag("--json", args->json, "Print the figures and problems as JSON instead of text");
  cmd->callback([args] { run_info(*args); });
}

const CommandRegistrar reg{10, add_info_command};

} // namespace
} // namespace gshell::cli
