#pragma once
// The certificate's two face trees, handed over after a certification to a caller that goes on
// testing the pairs of moved triangles exactly (the guarded start's later checks), so that it
// does not build a tree of its own over the same triangles.
#include <gshell/quality/shell_certificate.h>

#include "quality/face_pair_search.h"

#include <Eigen/Core>
#include <optional>

namespace gshell::detail {

/// Over the shell's vertex ids (base i is i, top i is n + i), at the positions certified, without
/// star flags (FaceSet::forget_stars): `base` over the base rows of shell_boundary(F, n) (its face
/// f is row f), `upper` over the top and wall rows (its face f is row m + f). Both in one frame.
struct CertificateTrees {
  FaceSet base, upper;
};

/// certify_shell(base, top, F, options), handing its trees over in `trees`.
/// \throws as certify_shell, and InputError when options.test_intersections is false (no trees).
ShellCertificate certify_shell_keeping_trees(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top,
                                             const Eigen::MatrixXi& F, const CertifyOptions& options,
                                             std::optional<CertificateTrees>& trees);

} // namespace gshell::detail
