#include <gshell/run/generate_run.h>

#include <gshell/error.h>
#include <gshell/format_number.h>
#include <gshell/shell/generate_report.h>

#include <cmath>
#include <utility>

namespace gshell {

void ThicknessChoice::check() const {
  if (thickness.has_value() == thickness_ratio.has_value())
    throw InputError("give exactly one of thickness and thickness_ratio");
  if (thickness && (!(*thickness > 0) || !std::isfinite(*thickness)))
    throw InputError("thickness must be positive and finite (got " + format_number(*thickness) + ")");
  if (thickness_ratio && (!(*thickness_ratio > 0) || !std::isfinite(*thickness_ratio)))
    throw InputError("thickness_ratio must be positive and finite (got " + format_number(*thickness_ratio) + ")");
}

double ThicknessChoice::eta(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) const {
  check();
  return thickness ? *thickness : thickness_from_ratio(V, F, *thickness_ratio);
}

void GenerateRunOptions::check() const {
  thickness.check();
  GenerateOptions g = generate;
  g.thickness = thickness.thickness.value_or(1.0); // a ratio is checked above; eta follows from the mesh
  g.check();
}

GenerateRun run_generate(TriMesh surface, std::string input, const GenerateRunOptions& options,
                         std::vector<std::string> input_warnings) {
  GenerateOptions generate = options.generate;
  options.check();
  generate.thickness = options.thickness.eta(surface.V, surface.F);
  GenerateRun run;
  run.result = generate_shell(surface.V, surface.F, generate);
  run.input = std::move(input);
  run.surface = std::move(surface);
  run.thickness_ratio = options.thickness.thickness_ratio;
  run.input_warnings = std::move(input_warnings);
  return run;
}

std::vector<std::string> GenerateRun::warnings() const {
  std::vector<std::string> w = input_warnings;
  for (std::string& line : generate_warnings(result)) w.push_back(std::move(line));
  return w;
}

nlohmann::ordered_json GenerateRun::to_json() const {
  nlohmann::ordered_json j(generate_report(result, input, thickness_ratio));
  j["warnings"] = warnings();
  return j;
}

std::string GenerateRun::summary() const { return generate_summary(result, input); }

void GenerateRun::write(const std::string& dir, const BeforeCommit& before_commit) const {
  ShellFolderContents c;
  c.surface = surface;
  c.X = result.shell.vertices();
  const ShellMetrics& m = result.metrics;
  Eigen::MatrixXd inverted = Eigen::MatrixXd::Zero(m.tet_stretch.rows(), 1); // the certificate's exact ids
  for (int t : m.certificate.inverted_tet_ids) inverted(t, 0) = 1;
  Eigen::MatrixXd prism(m.tet_stretch.rows(), 1);
  for (Eigen::Index t = 0; t < prism.rows(); ++t) prism(t, 0) = static_cast<double>(t / 3);
  c.cell_data = {{"stretch", m.tet_stretch}, {"inverted", inverted}, {"prism", prism}};
  c.report = to_json();
  write_shell_folder(dir, c, before_commit);
}

} // namespace gshell
