#include <gshell/quality/shell_metrics.h>

#include <gshell/error.h>
#include <gshell/quality/thickness.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/prism_tets.h>

#include <cmath>

namespace gshell {

namespace {

void check_sizes(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top, double eta) {
  if (!(eta > 0) || !std::isfinite(eta)) throw InputError("shell_metrics: thickness must be positive and finite");
  if (base.rows() != top.rows() || base.cols() != 3 || top.cols() != 3)
    throw InputError("shell_metrics: base and top must have the same number of vertices");
}

} // namespace

ShellMetrics shell_metrics(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top,
                           double eta, bool count_intersections) {
  check_sizes(base, top, eta);
  const RestTets rest = prism_rest_tets(F, static_cast<int>(base.rows()), normal_prisms(base, F, eta));
  return shell_metrics(base, F, top, eta, count_intersections, rest);
}

ShellMetrics shell_metrics(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top,
                           double eta, bool count_intersections, const RestTets& rest) {
  check_sizes(base, top, eta);
  if (rest.size() != 3 * F.rows()) throw InputError("shell_metrics: rest tets do not match the faces");
  const int n = static_cast<int>(base.rows());
  ShellMetrics m;
  Eigen::MatrixXd X(2 * n, 3);
  X << base, top;
  m.tet_stretch = tet_stretch(rest, X);
  m.tet_determinant = tet_deformation_determinants(rest, X);
  m.stretch = stretch_stats(m.tet_stretch, m.tet_determinant, rest.volume);
  CertifyOptions certify;
  certify.test_intersections = count_intersections;
  m.certificate = certify_shell(base, top, F, certify);
  m.vertex_thickness = vertex_thickness(base, F, top) / eta;
  if (n > 0) {
    m.thickness_min = m.vertex_thickness.minCoeff();
    m.thickness_mean = m.vertex_thickness.mean();
    m.thinned_vertices = static_cast<int>((m.vertex_thickness.array() < kThinnedFraction).count());
  }
  return m;
}

} // namespace gshell
