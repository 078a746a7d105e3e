// The curvature method of shell generation (see the header).
#include <gshell/shell/curvature_shell.h>

#include <gshell/shell/prism_tets.h>

#include <chrono>
#include <cstdio>

namespace gshell {

CurvatureShellResult generate_curvature_shell(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                              GenerateOptions options) {
  using Clock = std::chrono::steady_clock;
  options.method = ShellMethod::Curvature;
  check_curvature_clamp(options.s_min, options.s_max);
  CurvatureShellResult c;
  c.s_min = options.s_min;
  c.s_max = options.s_max;
  const auto t0 = Clock::now();
  const PrismCorners ideal = curvature_prisms(V, F, face_curvature(V, F), options.thickness, options.s_min,
                                              options.s_max, &c.prisms);
  c.prism_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  c.result = generate_shell_from_prisms(V, F, ideal, options);
  c.result.seconds.total += c.prism_seconds;
  const RestTets own = prism_rest_tets(F, static_cast<int>(V.rows()), ideal);
  c.own_stretch = stretch_stats(own, c.result.shell.vertices());
  return c;
}

void add_curvature_report(nlohmann::json& report, const CurvatureShellResult& c) {
  report["curvature"] = {
      {"s_min", c.s_min},
      {"s_max", c.s_max},
      {"clamped_prisms", c.prisms.clamped},
      {"limited_prisms", c.prisms.limited},
      {"stretch_own",
       {{"mean", c.own_stretch.mean},
        {"volume_mean", c.own_stretch.volume_mean},
        {"max", c.own_stretch.max},
        {"p99", c.own_stretch.p99},
        {"inverted_tets", c.own_stretch.inverted}}},
      {"seconds", c.prism_seconds},
  };
}

std::string curvature_summary(const CurvatureShellResult& c) {
  char buf[512];
  const int m = static_cast<int>(c.result.shell.F.rows());
  std::snprintf(buf, sizeof buf,
                "curvature    %d of %d prisms clamped to s in [%g, %g], %d anisotropy-limited (%.3f s)\n"
                "own prisms   stretch mean %.4g  volume-weighted %.4g  p99 %.4g  max %.4g, %d inverted\n",
                c.prisms.clamped, m, c.s_min, c.s_max, c.prisms.limited, c.prism_seconds, c.own_stretch.mean,
                c.own_stretch.volume_mean, c.own_stretch.p99, c.own_stretch.max, c.own_stretch.inverted);
  return buf;
}

} // namespace gshell
