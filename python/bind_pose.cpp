// Poser: direct shell deformation with handles (paper §4.2 second type, §5 hierarchy), a thin
// layer over the library's DragSession.
#include "bindings.h"
#include "count_arg.h"
#include "gil_probe.h"
#include "numpy_arrays.h"
#include "progress_watch.h"
#include "shell_object.h"

#include <gshell/error.h>
#include <gshell/format_number.h>
#include <gshell/deform/handles.h>
#include <gshell/run/drag_session.h>
#include <gshell/run/pose_run.h>

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <filesystem>
#include <memory>

namespace gshell::python {

namespace {

struct PoserObject {
  explicit PoserObject(DragSession s) : session(std::move(s)) {}
  DragSession session;
  /// The handle set of the last solve (with its motions): the same set again continues the drag.
  std::optional<HandleSet> handles;
  nlohmann::ordered_json last; ///< null before the first solve
  std::string shell_folder;    ///< the rest shell's folder (load_shell), named in the report
  ObjectLock lock{"the Poser"}; ///< solve() runs without the GIL
};

} // namespace
} // namespace gshell::python

GSHELL_PYTHON_REQUIRE_INITIALISED(gshell::python::PoserObject, "Poser")

namespace gshell::python {
namespace {

std::unique_ptr<PoserObject> make_poser(const ShellObject& shell, const std::string& solver, std::optional<CountArg> levels,
                                        bool allow_invalid) {
  PoseOptions options;
  options.allow_invalid = allow_invalid;
  options.solver = parse_pose_solver(solver);
  if (levels && options.solver != PoseSolverKind::Hierarchical) // as the CLI's --levels
    throw InputError("levels applies only to solver='hierarchical'");
  if (levels) options.hierarchy.levels = levels->checked("levels");
  options.check();
  auto p = std::make_unique<PoserObject>(DragSession(shell.shell, options, shell.surface()));
  p->session.set_undo_depth(0); // Poser has no undo: keep no copies of the shell
  // As gshell pose: the report names the rest shell's folder, and write() refuses to replace it.
  p->session.set_names(shell.folder, "");
  p->shell_folder = shell.folder;
  return p;
}

/// The handle set `handles` gives; `file` receives the handle file's name when it is one (the
/// report names it, as the CLI's does), else is left empty (a dict or JSON text).
HandleSet handles_from(const PoserObject& p, const py::object& handles, std::string& file) {
  const Shell& rest = p.session.rest();
  // A handle file's text pasted as a str is JSON, not a file name: no path starts with '{', and
  // treating it as one answered "cannot open handle file" followed by the whole text.
  // Asked in Python first: a file name with bytes that are not UTF-8 (os.fsdecode's surrogates)
  // has no UTF-8 std::string, only a path.
  // A byte order mark (what reading a BOM-marked file with encoding="utf-8" keeps) is not part of the text.
  const py::object text_start = py::isinstance<py::str>(handles) ? handles.attr("lstrip")(py::str("\ufeff \t\r\n"))
                                                                 : py::object(py::none());
  if (!text_start.is_none() && text_start.attr("startswith")("{").cast<bool>()) {
    const std::string text = text_start.cast<std::string>();
    ReleasedGil release;
    return parse_handles(text, "handles argument", rest);
  }
  if (py::isinstance<py::str>(handles) || py::hasattr(handles, "__fspath__")) {
    // os.fspath first: its own error (a NUL byte, an __fspath__ that raises) reaches the caller,
    // where the cast said only "Unable to cast Python instance to C++ type".
    const py::object path = py::module_::import("os").attr("fspath")(handles);
    if (py::isinstance<py::str>(path) && path.attr("__contains__")(py::str(std::string(1, '\0'))).cast<bool>())
      value_error("handles: a file name with a NUL byte");
    file = path.cast<std::filesystem::path>().string();
    ReleasedGil release;
    return read_handles(file, rest);
  }
  if (!py::isinstance<py::dict>(handles))
    value_error("handles must be a dict in the handle-file format or the path of a handle file");
  const std::string text = from_python(handles, "handles").dump();
  ReleasedGil release;
  return parse_handles(text, "handles argument", rest);
}

py::tuple poser_solve(PoserObject& p, const py::object& handles, double fraction, CountArg steps, CountArg iterations,
                      double tolerance, const py::object& progress) {
  if (!(fraction >= 0 && fraction <= 1))
    value_error("fraction must be in [0, 1] (got " + format_number(fraction) + ")");
  PoseOptions options;
  options.steps = steps.checked("steps");
  options.solve.max_iterations = iterations.checked("iterations");
  options.solve.tolerance = tolerance;
  options.check();
  std::string handles_file;
  const HandleSet set = handles_from(p, handles, handles_file);
  ProgressWatch watch(progress, "gshell.Poser.solve");
  options.solve.stage = watch.stage_hook();
  options.step_progress = [&watch, steps = options.steps](int step, int iteration, double energy, double seconds) {
    watch.report({{"step", step},
                  {"steps", steps},
                  {"stage", watch.stage()},
                  {"iteration", iteration},
                  {"energy", energy},
                  {"seconds", seconds}});
  };
  Eigen::MatrixXd X;
  {
    ReleasedGil release;
    const ObjectLock::Held held(p.lock);
    p.session.set_names(p.shell_folder, handles_file);
    if (!p.handles || !(*p.handles == set)) { // other handles: from the rest shell again
      p.session.reset();
      p.session.set_handles(set);
      p.handles = set;
    }
    try {
      p.last = run_pose(p.session, options, fraction).to_json();
    } catch (const PythonErrorPending&) { // interrupted: no half-solved state to continue from
      p.session.reset();
      p.handles.reset();
      p.last = nullptr;
      throw;
    }
    X = p.session.vertices();
    pass_gil_probe();
  }
  const int n = p.session.rest().num_base_vertices();
  return py::make_tuple(from_matrix(X.topRows(n)), from_matrix(X.bottomRows(n)));
}

} // namespace

void bind_pose(py::module_& m) {
  const PoseOptions defaults; // the only source of the defaults, as for the CLI
  py::class_<PoserObject>(m, "Poser", R"(Direct shell deformation with handles (paper section 4.2, second
type): handles move vertices of either surface, both surfaces follow with the least stretch
relative to the rest shell; solved by the hierarchical solver (paper section 5) or the
single-level one, as `gshell pose` does.

Handles are a dict in the handle-file format of `gshell pose --handles` (docs/handles.md), e.g.
    {"handles": [
        {"select": {"surface": "both", "box": [-9, -9, -9, 9, 9, -0.5]}},
        {"vertices": [0, 5, 17], "translate": [0, 0, 0.3],
         "rotate": {"axis": [0, 1, 0], "degrees": 30}}]}
(shell vertex ids: base 0..n-1, top n..2n-1), the same as JSON text, or the path of such a file.)")
      .def(py::init(&make_poser), py::arg("shell"), py::arg("solver") = pose_solver_name(defaults.solver),
           py::arg_v("levels", py::none(), std::to_string(defaults.hierarchy.levels).c_str()), py::kw_only(),
           py::arg("allow_invalid") = defaults.allow_invalid,
           R"(Prepare direct deformation of `shell` (the rest shell).

Every step is valid (certified exactly; its report says valid, method, blocked_by_contact when
the handles force a collision and the step stopped at contact) unless allow_invalid=True, which
gives the unguarded steps, as `gshell pose --allow-invalid`.

Args:
    shell: the rest Shell.
    solver: "hierarchical" (default) or "single" (plain local/global over all vertices).
    levels: levels of the hierarchical solver including the full one (>= 1). The signature shows
        its default; given with solver="single" (even at that value): ValueError.

Raises:
    ValueError: unknown solver, levels < 1 or given with solver="single".)")
      .def("solve", &poser_solve, py::arg("handles"), py::kw_only(), py::arg("fraction") = 1.0,
           py::arg("steps") = defaults.steps, py::arg("iterations") = defaults.solve.max_iterations,
           py::arg("tolerance") = defaults.solve.tolerance, py::arg("progress") = py::none(),
           R"(Move the handles and solve for the deformed shell.

Args:
    handles: dict in the handle-file format (ids and vectors may be NumPy integers and arrays),
        the same as JSON text (a str starting with '{'), or a handle file path (str or os.PathLike).
    fraction: how far along the handles' motion to go (1 = the full translate/rotate).
    steps: reach `fraction` in this many equal steps, solving after each (an interactive drag).
    iterations: maximum iterations per step (>= 1).
    tolerance: stop a step when the relative energy change per iteration is below this.
    progress: None (default), True to print each iteration on sys.stderr, or a callable called
        after every iteration with a dict {"step", "steps", "stage", "iteration", "energy",
        "seconds"} (stage: "paper", the solver's iterations, then, where the guard refuses them,
        "mend" and "drag K/N", the guarded drag's sub-steps, whose energy includes the barriers
        and climbs as the handles move; the iteration count goes on through them).
        Either way Ctrl-C ends the call at its next iteration with KeyboardInterrupt, as does an
        exception the callable raises; the Poser then starts from the rest shell again, as after
        reset(). The callable must not use this Poser (it is busy: RuntimeError).

The first solve for a handle set builds the solver (cluster tree, factorisations) and starts from
the rest shell; later solves with the same handles reuse it and continue from the last state
(e.g. fraction=0.5, then fraction=1.0), each step started from the drag's motion continued.
Different handles start from the rest shell again (the solver is rebuilt only if their vertex
sets differ).

Returns:
    (base, top): float64 arrays (n, 3), the deformed surfaces. Statistics are in .last.

Raises:
    ValueError: malformed handles (unknown keys, bad ids, empty selection, a vertex in two
        handles, a connected part of the shell without a handle) or bad options.

Releases the GIL while it runs.)")
      .def("reset",
           [](PoserObject& p) {
             without_gil_locked(p.lock, [&] {
               p.session.reset();
               p.handles.reset();
               p.last = nullptr;
             });
           },
           "Forget the last handle set: the next solve() starts from the rest shell.")
      .def("write",
           [](PoserObject& p, const std::filesystem::path& path) {
             without_gil_locked(p.lock, [&] { p.session.write(path.string()); });
           },
           py::arg("path"),
           "Write the posed shell folder as `gshell pose -o` does (base.obj, top.obj, shell.vtu, report.json).")
      .def_property_readonly("vertices",
                             [](PoserObject& p) -> py::object {
                               const Eigen::MatrixXd X =
                                   without_gil_locked(p.lock, [&] { return p.session.vertices(); });
                               return read_only(from_matrix(X));
                             },
                             "float64 (2n, 3): all shell vertices after the last solve (the rest shell "
                             "before any); pass it to Embedding.carry().")
      .def_property_readonly("last",
                             [](PoserObject& p) -> py::object {
                               const nlohmann::ordered_json j = without_gil_locked(p.lock, [&] { return p.last; });
                               return j.is_null() ? py::none() : to_python(j);
                             },
                             "dict about the last solve (None before the first): the fields of `gshell pose`'s "
                             "report.json (solver, levels, mode, handle_vertices, setup_seconds, tolerance, "
                             "max_iterations, steps [{fraction, iterations, energy, seconds, converged, valid, "
                             "method, certificate, ...}] of this solve, warnings, stretch {mean, volume_mean, "
                             "max, p99} against the rest shell, inverted_tets, ...).");
}

} // namespace gshell::python
