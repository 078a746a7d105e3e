// Poser: direct shell deformation with handles (paper §4.2 second type, §5 hierarchy).
#include "bindings.h"
#include "numpy_arrays.h"
#include "shell_object.h"

#include <gshell/deform/handles.h>
#include <gshell/deform/pose.h>
#include <gshell/quality/stretch.h>

#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <mutex>
#include <sstream>

namespace gshell::python {

namespace {

/// Everything a PoseSolver depends on, as text: two handle specs that resolve to the same key
/// (same vertices, motions, mode, weight) can share one solver and its factorisations.
std::string handle_key(const HandleSet& set) {
  std::ostringstream s;
  s.precision(17);
  s << (set.mode == ConstraintMode::Hard ? "hard" : "soft") << ' ' << set.weight << '\n';
  for (const Handle& h : set.handles) {
    for (int v : h.vertices) s << v << ' ';
    s << "| " << h.translate.transpose() << " | " << h.axis.transpose() << " | " << h.degrees << " | "
      << h.center.transpose() << '\n';
  }
  return s.str();
}

nlohmann::json stretch_json(const StretchStats& s) {
  return {{"mean", s.mean}, {"volume_mean", s.volume_mean}, {"max", s.max}, {"p99", s.p99}, {"inverted", s.inverted}};
}

struct PoserObject {
  Shell rest;
  PoseSolverKind kind = PoseSolverKind::Hierarchical;
  HierarchyOptions hierarchy;

  // The solver of the last handle set, its state and how far along the handles' motion it is:
  // calling solve() again with the same handles continues from there (a drag) without
  // rebuilding the hierarchy or refactoring.
  std::unique_ptr<PoseSolver> solver;
  std::string key;
  Eigen::MatrixXd X;
  double fraction = 0;
  Eigen::MatrixXd X_before; ///< the state before X (empty after a rebuild), to extrapolate a drag
  double fraction_before = 0;
  nlohmann::json last; ///< null before the first solve
  std::mutex mutex;    ///< solve() runs without the GIL
};

std::unique_ptr<PoserObject> make_poser(const ShellObject& shell, const std::string& solver, int levels) {
  auto p = std::make_unique<PoserObject>();
  if (solver == "hierarchical")
    p->kind = PoseSolverKind::Hierarchical;
  else if (solver == "single")
    p->kind = PoseSolverKind::Single;
  else
    value_error("unknown solver '" + solver + "' (expected hierarchical or single)");
  if (levels < 1) value_error("levels must be >= 1 (got " + std::to_string(levels) + ")");
  p->hierarchy.levels = levels;
  p->rest = shell.shell;
  return p;
}

HandleSet handles_from(const PoserObject& p, const py::object& handles) {
  if (py::isinstance<py::str>(handles) || py::hasattr(handles, "__fspath__")) {
    const auto path = handles.cast<std::filesystem::path>();
    py::gil_scoped_release release;
    return read_handles(path.string(), p.rest);
  }
  if (!py::isinstance<py::dict>(handles))
    value_error("handles must be a dict in the handle-file format or the path of a handle file");
  const std::string text = from_python(handles, "handles").dump();
  py::gil_scoped_release release;
  return parse_handles(text, "handles", p.rest);
}

py::tuple poser_solve(PoserObject& p, const py::object& handles, double fraction, int steps, int iterations,
                      double tolerance) {
  if (!(fraction >= 0 && fraction <= 1)) value_error("fraction must be in [0, 1] (got " + std::to_string(fraction) + ")");
  if (steps < 1) value_error("steps must be >= 1 (got " + std::to_string(steps) + ")");
  if (iterations < 1) value_error("iterations must be >= 1 (got " + std::to_string(iterations) + ")");
  if (!(tolerance >= 0) || !std::isfinite(tolerance))
    value_error("tolerance must be a non-negative number (got " + std::to_string(tolerance) + ")");
  const HandleSet set = handles_from(p, handles);
  SolveOptions options;
  options.max_iterations = iterations;
  options.tolerance = tolerance;
  const int n = p.rest.num_base_vertices();
  Eigen::MatrixXd X;
  {
    py::gil_scoped_release release;
    const std::lock_guard<std::mutex> lock(p.mutex);
    const std::string key = handle_key(set);
    if (!p.solver || key != p.key) {
      p.solver.reset(); // free the old factorisations before building new ones
      p.solver = std::make_unique<PoseSolver>(p.rest, set, p.kind, p.hierarchy);
      p.key = key;
      p.X = p.solver->rest_vertices();
      p.fraction = 0;
      p.X_before.resize(0, 0);
    }
    // Steps as in `gshell pose --steps K`: equal parts of the way from the current fraction.
    const double from = p.fraction;
    nlohmann::json step_reports = nlohmann::json::array();
    for (int k = 1; k <= steps; ++k) {
      const double f = from + (fraction - from) * (static_cast<double>(k) / steps);
      // Like run_pose: continue the previous step's motion for the start state.
      Eigen::MatrixXd start =
          p.X_before.size() > 0 ? p.solver->predict_start(p.X_before, p.fraction_before, p.X, p.fraction, f) : p.X;
      p.X_before = std::move(p.X);
      p.fraction_before = p.fraction;
      p.X = std::move(start);
      const SolveResult r = p.solver->solve(p.X, f, options);
      p.fraction = f;
      step_reports.push_back({{"fraction", f},
                              {"iterations", r.iterations},
                              {"energy", r.energy.empty() ? 0.0 : r.energy.back()},
                              {"seconds", r.seconds},
                              {"converged", r.converged}});
    }
    p.last = {{"solver", p.kind == PoseSolverKind::Hierarchical ? "hierarchical" : "single"},
              {"levels", p.kind == PoseSolverKind::Hierarchical ? p.hierarchy.levels : 1},
              {"mode", set.mode == ConstraintMode::Hard ? "hard" : "soft"},
              {"handle_vertices", set.constrained_vertices().size()},
              {"setup_seconds", p.solver->setup_seconds()},
              {"steps", step_reports},
              {"stretch", stretch_json(stretch_stats(p.solver->rest_tets(), p.X))}};
    X = p.X;
  }
  return py::make_tuple(from_matrix(X.topRows(n)), from_matrix(X.bottomRows(n)));
}

} // namespace

void bind_pose(py::module_& m) {
  py::class_<PoserObject>(m, "Poser", R"(Direct shell deformation with handles (paper section 4.2, second
type): handles move vertices of either surface, both surfaces follow with the least stretch
relative to the rest shell; solved by the hierarchical solver (paper section 5) or the
single-level one, as `gshell pose` does.

Handles are a dict in the handle-file format of `gshell pose --handles` (docs/handles.md), e.g.
    {"handles": [
        {"select": {"surface": "both", "box": [-9, -9, -9, 9, 9, -0.5]}},
        {"vertices": [0, 5, 17], "translate": [0, 0, 0.3],
         "rotate": {"axis": [0, 1, 0], "degrees": 30}}]}
(shell vertex ids: base 0..n-1, top n..2n-1), or the path of such a file.)")
      .def(py::init(&make_poser), py::arg("shell"), py::arg("solver") = "hierarchical", py::arg("levels") = 5,
           R"(Prepare direct deformation of `shell` (the rest shell).

Args:
    shell: the rest Shell.
    solver: "hierarchical" (default) or "single" (plain local/global over all vertices).
    levels: levels of the hierarchical solver including the full one (>= 1).

Raises:
    ValueError: unknown solver, levels < 1.)")
      .def("solve", &poser_solve, py::arg("handles"), py::kw_only(), py::arg("fraction") = 1.0,
           py::arg("steps") = 1, py::arg("iterations") = 500, py::arg("tolerance") = 1e-6,
           R"(Move the handles and solve for the deformed shell.

Args:
    handles: dict in the handle-file format, or a handle file path (str or os.PathLike).
    fraction: how far along the handles' motion to go (1 = the full translate/rotate).
    steps: reach `fraction` in this many equal steps, solving after each (an interactive drag).
    iterations: maximum iterations per step (>= 1).
    tolerance: stop a step when the relative energy change per iteration is below this.

The first solve for a handle set builds the solver (cluster tree, factorisations) and starts from
the rest shell; later solves with the same handles reuse it and continue from the last state
(e.g. fraction=0.5, then fraction=1.0). Different handles start from the rest shell again.

Returns:
    (base, top): float64 arrays (n, 3), the deformed surfaces. Statistics are in .last.

Raises:
    ValueError: malformed handles (unknown keys, bad ids, empty selection, a vertex in two
        handles, a connected part of the shell without a handle) or bad options.

Releases the GIL while it runs.)")
      .def("reset",
           [](PoserObject& p) {
             py::gil_scoped_release release;
             const std::lock_guard<std::mutex> lock(p.mutex);
             p.solver.reset();
             p.key.clear();
             p.fraction = 0;
             p.last = nullptr;
           },
           "Forget the last handle set: the next solve() starts from the rest shell.")
      .def_property_readonly("vertices",
                             [](PoserObject& p) -> py::object {
                               Eigen::MatrixXd X;
                               {
                                 py::gil_scoped_release release;
                                 const std::lock_guard<std::mutex> lock(p.mutex);
                                 X = p.solver ? p.X : p.rest.vertices();
                               }
                               return read_only(from_matrix(X));
                             },
                             "float64 (2n, 3): all shell vertices after the last solve (the rest shell "
                             "before any); pass it to Embedding.carry().")
      .def_property_readonly("last",
                             [](PoserObject& p) -> py::object {
                               nlohmann::json j;
                               {
                                 py::gil_scoped_release release;
                                 const std::lock_guard<std::mutex> lock(p.mutex);
                                 j = p.last;
                               }
                               return j.is_null() ? py::none() : to_python(j);
                             },
                             "dict about the last solve (None before the first): solver, levels, mode, "
                             "handle_vertices, setup_seconds, steps (list of {fraction, iterations, energy, "
                             "seconds, converged}) and stretch {mean, volume_mean, max, p99, inverted} against "
                             "the rest shell, as in `gshell pose`'s report.json.");
}

} // namespace gshell::python
