#pragma once
// What the Python `Shell` class holds: the library's Shell plus what a Python user wants next to
// it (tets, per-tet stretch, the report). Deformer, Poser and embed take it.
#include "initialised_caster.h"

#include <gshell/mesh.h>
#include <gshell/shell/shell.h>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <string>

namespace gshell::python {

struct ShellObject {
  Shell shell;                ///< base, top, faces, thickness
  Eigen::MatrixXi tets;       ///< 3m x 4 over the 2n shell vertices (build_prism_tets)
  Eigen::VectorXd stretch;    ///< per tet, against the normal prisms of thickness eta
  nlohmann::json report;      ///< generate_report for generated shells, metrics_report otherwise
  std::string folder;         ///< the folder load_shell read it from; empty for shells made in Python
  /// The base's texture coordinates and their corners (TriMesh::UV, FUV) where the folder's
  /// base.obj had them, so that what Poser.write and deform(output=) save keeps them as the
  /// CLI's folders do (`gshell texture` reads them there); empty otherwise.
  Eigen::MatrixXd uv;
  Eigen::MatrixXi fuv;
  /// The base as a surface: faces, and the texture coordinates above.
  TriMesh surface() const {
    TriMesh m;
    m.V = shell.base;
    m.F = shell.F;
    m.UV = uv;
    m.FUV = fuv;
    return m;
  }
};

} // namespace gshell::python

GSHELL_PYTHON_REQUIRE_INITIALISED(gshell::python::ShellObject, "Shell")
