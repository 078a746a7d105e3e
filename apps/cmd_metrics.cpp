// `gshell metrics BASE TOP`: the quality report of any base/top pair (docs/design.md "Quality
// measures").
#include "command_registry.h"
#include "output_file.h"
#include "parameter_flags.h"
#include "surface_input.h"
#include "thickness_flags.h"

#include <gshell/error.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/load_mesh.h>
#include <gshell/shell/generate_report.h>
#include <gshell/shell/generate_shell.h>

#include <cmath>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace {

struct MetricsCliOptions {
  std::string base, top, output;
  gshell::ThicknessChoice thickness;
};

void run_metrics(const CLI::App& cmd, const MetricsCliOptions& o) {
  using namespace gshell;
  cli::check_flags(cmd, [&] { o.thickness.check(); });
  if (!o.output.empty()) cli::check_output_file(o.output, ".json", {o.base, o.top});

  std::vector<std::string> warnings;
  const TriMesh base = cli::load_surface(o.base, "metrics", &warnings);
  // The top is not validated as a surface: a bad shell may well have degenerate top faces.
  const TriMesh top = read_mesh_or_builtin(o.top);
  if (top.V.rows() != base.V.rows() || top.F.rows() != base.F.rows() || top.F != base.F)
    throw InputError(with_file(o.top, "must have the same vertex count and faces as " + o.base));
  require_usable_coordinates(top.V, o.top);
  const double eta = o.thickness.eta(base.V, base.F);
  check_thickness_scale(base.V, base.F, eta); // the normal prisms the stretch is measured against
  const ShellMetrics m = shell_metrics(base.V, base.F, top.V, eta, true);
  if (!o.output.empty()) {
    nlohmann::json report = metrics_report(m, base.num_vertices(), base.num_faces(), eta, o.thickness.thickness_ratio);
    report["gshell_version"] = GSHELL_VERSION;
    report["base"] = o.base;
    report["top"] = o.top;
    report["warnings"] = warnings; // the base's, as printed
    write_report(o.output, nlohmann::ordered_json(report));
  }
  std::cout << metrics_summary(m, base.num_vertices(), base.num_faces(), eta);
}

void add_metrics_command(CLI::App& app) {
  auto o = std::make_shared<MetricsCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "metrics", "Quality of a shell given by its base and top surfaces (same faces and vertex order): stretch "
                 "against the normal prisms, the exact validity certificate (inverted tets, intersections), "
                 "thickness.");
  cmd->add_option("base", o->base, "Base surface (mesh file or builtin:NAME)")->required();
  cmd->add_option("top", o->top, "Top surface with the base's faces and vertex order")->required();
  gshell::cli::add_thickness_flags(*cmd, o->thickness);
  cmd->add_option("-o,--output", o->output, "Write the report as JSON to this file");
  cmd->callback([o, cmd] { run_metrics(*cmd, *o); });
}

const gshell::cli::CommandRegistrar reg{40, add_metrics_command};

} // namespace
