#include <gshell/quality/shell_metrics.h>

#include <gshell/error.h>
#include <gshell/geometry/mesh_topology.h>
#include <gshell/quality/thickness.h>
#include <gshell/shell/prism_tets.h>

#include "check_mesh_input.h"
#include "uncertified_metrics.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace gshell {

namespace {

void check_sizes(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top, double eta) {
  if (!(eta > 0) || !std::isfinite(eta)) throw InputError("shell_metrics: thickness must be positive and finite");
  if (base.rows() != top.rows() || base.cols() != 3 || top.cols() != 3)
    throw InputError("shell_metrics: base and top must have the same number of vertices");
}

// Which certificate the metrics carry: none (uncertified_shell_metrics), the tets', or with the
// boundary pairs tested too (shell_metrics' count_intersections).
enum class CertificateKind { none, tets, with_pairs };

CertificateKind certificate_for(bool count_intersections) {
  return count_intersections ? CertificateKind::with_pairs : CertificateKind::tets;
}

// Everything but the stretch, which the callers measure against rest tets made in one piece or
// in blocks.
ShellMetrics metrics_from_stretch(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top,
                                  double eta, CertificateKind certificate, Eigen::VectorXd tet_stretch,
                                  Eigen::VectorXd tet_determinant, const Eigen::VectorXd& volume) {
  const int n = static_cast<int>(base.rows());
  ShellMetrics m;
  m.stretch = stretch_stats(tet_stretch, tet_determinant, volume);
  m.tet_stretch = std::move(tet_stretch);
  m.tet_determinant = std::move(tet_determinant);
  if (certificate != CertificateKind::none) {
    CertifyOptions certify;
    certify.test_intersections = certificate == CertificateKind::with_pairs;
    m.certificate = certify_shell(base, top, F, certify);
  }
  m.vertex_thickness = vertex_thickness(base, F, top) / eta;
  // Over the vertices faces use: a stray vertex's "top" is wherever it was left, no layer.
  const std::vector<char> used = used_vertices(F, n);
  double sum = 0, least = INFINITY;
  int count = 0;
  for (int i = 0; i < n; ++i) {
    if (!used[i]) continue;
    const double t = m.vertex_thickness[i];
    sum += t;
    least = std::min(least, t);
    ++count;
    m.thinned_vertices += t < kThinnedFraction;
  }
  if (count > 0) {
    m.thickness_min = least;
    m.thickness_mean = sum / count;
  }
  return m;
}

ShellMetrics metrics_in_blocks(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top,
                               double eta, CertificateKind certificate) {
  check_sizes(base, top, eta);
  detail::check_face_indices(F, base.rows(), "shell_metrics");
  // The normal prisms' rest tets are made a block of faces at a time (a face's three tets depend
  // on that face alone): at millions of faces the whole set, 50 bytes per tet even in the
  // affine-prism form, would be the largest allocation of the metrics. Per tet the figures are
  // those of the whole set, bit for bit.
  constexpr Eigen::Index kBlockFaces = 1 << 15;
  const int n = static_cast<int>(base.rows());
  const Eigen::Index m = F.rows();
  Eigen::MatrixXd X(2 * n, 3);
  X << base, top;
  Eigen::VectorXd stretch(3 * m), determinant(3 * m), volume(3 * m);
  for (Eigen::Index f0 = 0; f0 < m; f0 += kBlockFaces) {
    const Eigen::Index faces = std::min(kBlockFaces, m - f0);
    const Eigen::MatrixXi block = F.middleRows(f0, faces);
    const RestTets rest = normal_prism_rest_tets(base, block, eta);
    stretch.segment(3 * f0, 3 * faces) = tet_stretch(rest, X);
    determinant.segment(3 * f0, 3 * faces) = tet_deformation_determinants(rest, X);
    volume.segment(3 * f0, 3 * faces) = rest.volume;
  }
  return metrics_from_stretch(base, F, top, eta, certificate, std::move(stretch), std::move(determinant),
                              volume);
}

ShellMetrics metrics_against(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top,
                             double eta, CertificateKind certificate, const RestTets& rest) {
  check_sizes(base, top, eta);
  if (rest.size() != 3 * F.rows()) throw InputError("shell_metrics: rest tets do not match the faces");
  const int n = static_cast<int>(base.rows());
  Eigen::MatrixXd X(2 * n, 3);
  X << base, top;
  return metrics_from_stretch(base, F, top, eta, certificate, tet_stretch(rest, X),
                              tet_deformation_determinants(rest, X), rest.volume);
}

} // namespace

ShellMetrics shell_metrics(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top,
                           double eta, bool count_intersections) {
  return metrics_in_blocks(base, F, top, eta, certificate_for(count_intersections));
}

ShellMetrics shell_metrics(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top,
                           double eta, bool count_intersections, const RestTets& normal_rest) {
  return metrics_against(base, F, top, eta, certificate_for(count_intersections), normal_rest);
}

ShellMetrics detail::uncertified_shell_metrics(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F,
                                               const Eigen::MatrixXd& top, double eta) {
  return metrics_in_blocks(base, F, top, eta, CertificateKind::none);
}

ShellMetrics detail::uncertified_shell_metrics(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F,
                                               const Eigen::MatrixXd& top, double eta, const RestTets& normal_rest) {
  return metrics_against(base, F, top, eta, CertificateKind::none, normal_rest);
}

} // namespace gshell
