#pragma once
// The quality measures without their certificate, for callers that certify the shell their own
// way (generation certifies a guarded result from the guard's first check): the tets-only
// certificate shell_metrics makes would be thrown away, and at millions of faces its input checks
// alone take most of a second.
#include <gshell/quality/shell_metrics.h>
#include <gshell/shell/prism_tets.h>

namespace gshell::detail {

/// shell_metrics(base, F, top, eta, false) with `certificate` left default-constructed.
/// \throws InputError as shell_metrics.
ShellMetrics uncertified_shell_metrics(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F,
                                       const Eigen::MatrixXd& top, double eta);

/// The same against the normal prisms' rest tets already built.
ShellMetrics uncertified_shell_metrics(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F,
                                       const Eigen::MatrixXd& top, double eta, const RestTets& normal_rest);

} // namespace gshell::detail
