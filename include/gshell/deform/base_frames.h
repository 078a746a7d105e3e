#pragma once
// The base frames that drive a deformation, read and checked up front.
#include <Eigen/Core>
#include <string>
#include <vector>

namespace gshell {

/// Reads every frame file (any mesh format read_mesh knows) and checks each against the shell's
/// base faces F (n vertices): same vertex count, identical faces, finite coordinates. All files
/// are read and checked before returning, so a bad frame fails before any work is done.
/// \throws InputError "FRAME: problem" for the first bad frame (unreadable, unknown format,
///         other vertex count or faces, non-finite), or when `paths` is empty.
std::vector<Eigen::MatrixXd> load_base_frames(const std::vector<std::string>& paths, const Eigen::MatrixXi& F, int n);

} // namespace gshell
