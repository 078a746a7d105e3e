#pragma once
// valid_start with a checker its caller made, whose first check the caller may have run already:
// guarded generation certifies the wanted top with the base's own pairs first, since the
// triangles it excludes from the checks follow from those pairs (guarded_shell.cpp).
#include <gshell/guard/valid_start.h>

#include "guard/start_check.h"

#include <optional>

namespace gshell::detail {

/// valid_start(V, F, P, directions, skip_tets, excluded_triangles, options), checked by `checker`
/// (a StartChecker over F and V.rows() with those flags). `first`: checker.certify(V, P, ...)
/// when the caller ran it (the first round then makes its violations of it instead of
/// certifying P again), else empty.
/// \throws as valid_start.
ValidStart valid_start_with(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& P,
                            const ExtrusionDirections& directions, const StartChecker& checker,
                            std::optional<ShellCertificate> first, const ValidStartOptions& options);

} // namespace gshell::detail
