#pragma once
// What the Python `Shell` class holds: the library's Shell plus what a Python user wants next to
// it (tets, per-tet stretch, the report). Deformer, Poser and embed take it.
#include "initialised_caster.h"

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
};

} // namespace gshell::python

GSHELL_PYTHON_REQUIRE_INITIALISED(gshell::python::ShellObject, "Shell")
