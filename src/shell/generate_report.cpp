#include <gshell/shell/generate_report.h>

#include <gshell/geometry/mesh_topology.h>
#include <gshell/quality/certificate_report.h>
#include <gshell/quality/stretch_report.h>
#include <gshell/word_list.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace gshell {

namespace {

std::string format(const char* fmt, double a, double b = 0, double c = 0, double d = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, fmt, a, b, c, d);
  return buf;
}

void quality_lines(std::ostringstream& out, const ShellMetrics& m) {
  out << format("stretch      mean %.4g  volume-weighted %.4g  p99 %.4g  max %.4g\n", m.stretch.mean,
                m.stretch.volume_mean, m.stretch.p99, m.stretch.max);
  out << certificate_summary(m.certificate);
  // Four decimals near 1 (0.9768); a top measured against another base can sit 1e40 eta away,
  // which fixed point wrote out in 39 digits.
  auto eta_multiple = [](double x) { return format(std::abs(x) < 1e4 ? "%.4f" : "%.4g", x); };
  out << "thickness    min " << eta_multiple(m.thickness_min) << "  mean " << eta_multiple(m.thickness_mean)
      << "  (x eta), "
      << m.thinned_vertices << format(" top vertices below %.2g eta\n", kThinnedFraction);
}

} // namespace

nlohmann::json metrics_report(const ShellMetrics& m, int vertices, int faces, double eta,
                              std::optional<double> thickness_ratio) {
  nlohmann::json j;
  j["thickness"] = {{"eta", eta},
                    {"ratio", thickness_ratio ? nlohmann::json(*thickness_ratio) : nlohmann::json(nullptr)},
                    {"min", m.thickness_min},
                    {"mean", m.thickness_mean}};
  j["vertices"] = vertices;
  j["faces"] = faces;
  j["tets"] = 3 * faces;
  // The exact inverted-tet count is the certificate's; det F <= 0 in doubles would be a second
  // answer to the same question, so only the statistics of stretch_report are taken.
  j["stretch"] = nlohmann::json(stretch_report(m.stretch)["stretch"]);
  j.update(nlohmann::json(certificate_report(m.certificate)));
  j["thinned_vertices"] = m.thinned_vertices;
  return j;
}

nlohmann::json generate_report(const GenerateResult& r, const std::string& input,
                               std::optional<double> thickness_ratio) {
  nlohmann::json j = metrics_report(r.metrics, r.shell.num_base_vertices(), static_cast<int>(r.shell.F.rows()),
                                    r.shell.thickness, thickness_ratio);
  j["gshell_version"] = GSHELL_VERSION;
  j["input"] = input;
  j["method"] = to_string(r.method);
  j["iterations"] = r.solve.iterations;
  j["converged"] = r.solve.converged;
  j["energy"] = r.solve.energy;
  j["seconds"] = {{"total", r.seconds.total},
                  {"factor", r.seconds.factor},
                  {"solve", r.seconds.solve},
                  {"guard", r.seconds.guard},
                  {"certificate", r.metrics.certificate.seconds},
                  {"metrics", r.seconds.metrics}};
  j["unextrudable_vertices"] = r.unextrudable_vertices;
  j["guarded"] = r.guarded;
  j["warnings"] = generate_warnings(r);
  if (r.guarded) {
    const GuardedShell& g = r.guard;
    j["guard"] = {{"paper_iterations", g.paper.iterations},
                  {"paper_converged", g.paper.converged},
                  {"repair_converged", g.repair_converged()},
                  {"start_smoothing_iterations", g.smoothing.iterations},
                  {"start_rounds", g.start.rounds},
                  {"pulled_in_vertices", (g.start.scale.array() < 1).count()},
                  {"repaired_vertices", g.repaired_vertices},
                  {"repair_iterations", g.solve.iterations},
                  {"relax_iterations", g.relax.iterations},
                  {"relax_rounds_kept", g.relax.kept_rounds},
                  {"lift_candidates", g.lift.candidates},
                  {"lift_moves", g.lift.moves},
                  {"held_vertices", g.held_vertices},
                  {"small_part_vertices", g.small_part_vertices},
                  {"lift_only", g.lift_only},
                  {"start_unmended_tets", g.start.inverted_tets.size()},
                  {"start_unmended_pairs", g.start.intersections.size()},
                  {"unprotected_faces", g.unprotected_faces},
                  {"min_relative_volume", g.solve.iterations > 0 ? nlohmann::json(g.solve.min_relative_volume)
                                                                 : nlohmann::json(nullptr)},
                  // seconds.solve split by stage (their factorisations are in seconds.factor)
                  {"seconds", {{"paper", g.paper.seconds}, {"repair", g.solve.seconds}, {"relax", g.relax.seconds},
                               {"lift", g.lift.seconds}}}};
  }
  if (r.curvature) {
    const CurvatureGeneration& c = *r.curvature;
    j["curvature"] = {{"s_min", c.s_min},
                      {"s_max", c.s_max},
                      {"clamped_prisms", c.prisms.clamped},
                      {"limited_prisms", c.prisms.limited},
                      {"own_prisms", nlohmann::json(stretch_report(c.own_stretch))},
                      {"seconds", c.prism_seconds}};
  }
  return j;
}

std::vector<std::string> generate_warnings(const GenerateResult& r) {
  std::vector<std::string> w;
  // Inward shells are a use, but a mirrored export that flipped every face is a common accident.
  const std::string inward = inward_closed_parts_message(inward_closed_parts(r.shell.base, r.shell.F));
  if (!inward.empty()) w.push_back("the base's " + inward);
  const ShellCertificate& c = r.metrics.certificate;
  if (c.base_self_intersections > 0)
    w.push_back("the base intersects itself (" + std::to_string(c.base_self_intersections) +
                " pairs of faces cross): no top can be clean near those crossings" +
                (r.guarded ? std::string(", the shell is guarded everywhere else") : std::string()));
  if (!r.unextrudable_vertices.empty()) {
    w.push_back(std::to_string(r.unextrudable_vertices.size()) +
                " base vertices cannot be extruded (" + first_ids(r.unextrudable_vertices) +
                "; no direction sees all their faces from the positive side, or on the rim their side walls "
                "cut through their own faces): prisms around them may stay inverted");
  }
  if (r.guarded && !r.guard.small_part_vertices.empty()) {
    // Only where it matters: a part's start can keep its whole thickness (one small triangle).
    std::vector<int> thinned;
    const Eigen::VectorXd& t = r.metrics.vertex_thickness;
    for (int v : r.guard.small_part_vertices)
      if (v < t.size() && t[v] < kThinnedFraction) thinned.push_back(v);
    if (!thinned.empty())
      w.push_back(std::to_string(thinned.size()) + " top vertices (" + first_ids(thinned) +
                  ") are thinner than asked on parts of the base smaller than the thickness allows (bounding radius below " +
                  format("%.3g", r.guard.small_part_radius) + "): those parts keep the valid start's layer, as "
                  "prisms many times a part's own size have no valid top near them (report: guard.small_part_vertices)");
  }
  const ValidStart& start = r.guard.start;
  const bool unmended = r.guarded && (!start.inverted_tets.empty() || !start.intersections.empty());
  if (unmended) {
    // The base vertices of what is left, those with the narrowest cone of extrusion directions
    // first: that is where the base folds nearly flat onto itself.
    std::vector<int> vertices = unmended_vertices(start, r.shell.F, static_cast<int>(r.shell.base.rows()));
    const Eigen::VectorXd& margin = r.guard.directions.margin;
    std::stable_sort(vertices.begin(), vertices.end(), [&](int a, int b) { return margin[a] < margin[b]; });
    // Where even the narrowest cone is wide, nothing is folded: the start thinned its tops there
    // as far as it goes (2^-(max_rounds - 1) of the thickness) and parts of the base still lie
    // closer (nearly touching).
    const double least = vertices.empty() ? 0.0 : margin[vertices.front()];
    double thinnest = 1;
    for (int v : vertices) thinnest = std::min(thinnest, start.scale[v]);
    const std::string cause =
        least < generation_guard_options().start_margin
            ? format("smallest extrusion margin %.2g: faces folded nearly flat onto each other", least)
            : format("parts of the base lie closer to each other than the start could thin the layer to (%.2g "
                     "of it, after %.0f rounds), nearly touching; their faces are not folded: smallest extrusion "
                     "margin %.2g",
                     thinnest, start.rounds, least);
    w.push_back("the valid start could not mend " + std::to_string(start.inverted_tets.size()) + " tets and " +
                std::to_string(start.intersections.size()) + " boundary triangle pairs around base vertices " +
                first_ids(vertices) + " (" + cause + "), the shell is guarded everywhere else");
  }
  if (c.intersections_tested() && !c.valid()) {
    std::string where = " (unguarded result)";
    if (r.guarded) {
      std::vector<std::string> causes;
      if (c.base_self_intersections > 0) causes.push_back("the base's crossings");
      if (!r.unextrudable_vertices.empty()) causes.push_back("unextrudable vertices");
      if (unmended) causes.push_back("what the start could not mend");
      where = " (near " + word_list(causes) + ")";
    }
    w.push_back(std::string("the shell is not valid: ") + std::to_string(c.inverted_tets) + " inverted tets, " +
                std::to_string(c.top_self_intersections) + " top/top, " + std::to_string(c.top_base_intersections) +
                " top/base, " + std::to_string(c.wall_intersections) + " wall intersections" +
                (c.nested_parts > 0 ? ", " + nested_parts_phrase(c.nested_parts) : "") +
                where);
  }
  return w;
}

std::string metrics_summary(const ShellMetrics& m, int vertices, int faces, double eta) {
  std::ostringstream out;
  out << "shell        " << vertices << " vertices, " << faces << " faces, " << 3 * faces << " tets, eta "
      << format("%.6g", eta) << "\n";
  quality_lines(out, m);
  return out.str();
}

std::string generate_summary(const GenerateResult& r, const std::string& input) {
  std::ostringstream out;
  const int n = r.shell.num_base_vertices(), m = static_cast<int>(r.shell.F.rows());
  out << "input        " << input << "\n";
  out << "shell        " << n << " vertices, " << m << " faces, " << 3 * m << " tets, eta "
      << format("%.6g", r.shell.thickness) << ", method " << to_string(r.method) << "\n";
  if (!r.solve.energy.empty()) {
    out << format("energy       %.6g", r.solve.energy.front());
    // Guarded, these are the paper's iterations; whether the repair converged is on the guard line.
    const bool converged = r.guarded ? r.guard.paper.converged : r.solve.converged;
    if (r.solve.iterations > 0)
      out << format(" -> %.6g after ", r.solve.energy.back()) << r.solve.iterations
          << (r.guarded ? " paper iterations" : " iterations") << (converged ? " (converged)" : " (iteration limit)");
    out << "\n";
  }
  quality_lines(out, r.metrics);
  if (r.curvature) {
    const CurvatureGeneration& c = *r.curvature;
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "curvature    %d of %d prisms clamped to s in [%g, %g], %d anisotropy-limited (%.3f s)\n"
                  "own prisms   stretch mean %.4g  volume-weighted %.4g  p99 %.4g  max %.4g, %d inverted\n",
                  c.prisms.clamped, m, c.s_min, c.s_max, c.prisms.limited, c.prism_seconds, c.own_stretch.mean,
                  c.own_stretch.volume_mean, c.own_stretch.p99, c.own_stretch.max, c.own_stretch.inverted);
    out << buf;
  }
  if (r.guarded)
    out << "guard        " << r.unextrudable_vertices.size() << " unextrudable vertices, " << (r.guard.start.scale.array() < 1).count()
        << " pulled in, " << r.guard.repaired_vertices << " repaired in " << r.guard.solve.iterations
        << " iterations (" << (r.guard.repair_converged() ? "" : "not converged; ")
        << "+" << r.guard.relax.iterations << " relaxing, " << r.guard.relax.kept_rounds << " kept), "
        << r.guard.lift.moves << " lifting moves" << (r.guard.lift_only ? " (lifting alone kept, no repair)" : "") << "\n";
  char time[256];
  std::snprintf(time, sizeof time,
                "time         %.3f s (factor %.3f s, solve %.3f s, guard %.3f s, certificate %.3f s, metrics %.3f s)\n",
                r.seconds.total, r.seconds.factor, r.seconds.solve, r.seconds.guard, r.metrics.certificate.seconds,
                r.seconds.metrics);
  out << time;
  if (r.guarded && r.guard.repaired_vertices > 0) { // where a slow guarded run spends its solve time
    std::snprintf(time, sizeof time, "             solve: paper %.3f s, repair %.3f s, relax %.3f s; lifting %.3f s\n",
                  r.guard.paper.seconds, r.guard.solve.seconds, r.guard.relax.seconds, r.guard.lift.seconds);
    out << time;
  }
  return out.str();
}

} // namespace gshell
