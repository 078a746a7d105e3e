// Shell, generate, metrics, load_shell.
#include "bindings.h"
#include "count_arg.h"
#include "numpy_arrays.h"
#include "shell_object.h"
#include "gil_probe.h"
#include "progress_watch.h"

#include <gshell/error.h>
#include <gshell/format_number.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/quality/shell_metrics.h>
#include <gshell/run/generate_run.h>
#include <gshell/run/shell_folder.h>
#include <gshell/shell/generate_report.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/prism_tets.h>

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <filesystem>
#include <optional>

namespace gshell::python {

namespace {

/// A default as the signature shows it (Python's repr of the float).
std::string shown_default(double value) { return py::repr(py::float_(value)).cast<std::string>(); }

/// The report's "input" for arrays handed in from Python (the CLI writes the file or spec there).
constexpr const char* kArrayInput = "<numpy arrays>";

TriMesh checked_mesh(const py::handle& V, const py::handle& F, const char* v_name = "V", const char* f_name = "F") {
  TriMesh mesh;
  mesh.V = to_matrix(V, v_name, 3);
  mesh.F = to_indices(F, f_name, 3, static_cast<int>(mesh.V.rows()));
  return mesh;
}

/// Shell object for a base/top pair that was not generated here: stretch and report measured
/// like `gshell metrics` does, without intersection counts (they dominate the cost on big meshes).
ShellObject measured_shell(Shell shell) {
  ShellObject s;
  const ShellMetrics m = shell_metrics(shell.base, shell.F, shell.top, shell.thickness, false);
  s.tets = build_prism_tets(shell.F, shell.num_base_vertices());
  s.stretch = m.tet_stretch;
  s.report = metrics_report(m, shell.num_base_vertices(), static_cast<int>(shell.F.rows()), shell.thickness);
  s.shell = std::move(shell);
  return s;
}

// Pickling (multiprocessing, joblib, caches): the arrays, the thickness, the per-tet stretch and
// the report as they are, so an unpickled shell is the same shell without measuring it again.
// 2: with the base's texture coordinates; 3: with a Python subclass's attributes (its __dict__).
constexpr int kShellStateVersion = 3;

py::tuple shell_state(const py::object& self) {
  const ShellObject& s = self.cast<const ShellObject&>();
  return py::make_tuple(kShellStateVersion, from_matrix(s.shell.base), from_indices(s.shell.F), from_matrix(s.shell.top),
                        s.shell.thickness, from_vector(s.stretch),
                        s.report.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace),
                        py::bytes(s.folder), // a folder name is bytes: one not UTF-8 failed to pickle
                        s.uv.size() ? py::object(from_matrix(s.uv)) : py::none(),
                        s.fuv.size() ? py::object(from_indices(s.fuv)) : py::none(),
                        py::getattr(self, "__dict__", py::none()));
}

// Returns the subclass's attributes beside the shell: pybind11 sets them as the new object's
// __dict__ (an empty one is skipped, so a plain Shell needs no dynamic attributes).
std::pair<ShellObject, py::dict> shell_from_state(const py::tuple& t) {
  const int version = t.size() && py::isinstance<py::int_>(t[0]) ? t[0].cast<int>() : 0;
  if (!((version == 2 && t.size() == 10) || (version == kShellStateVersion && t.size() == 11)))
    value_error("Shell: not the state of a pickled gshell.Shell of this version");
  py::dict attributes;
  if (version == 3 && !t[10].is_none()) {
    if (!py::isinstance<py::dict>(t[10])) value_error("Shell: the pickled attributes are not a dict");
    attributes = t[10].cast<py::dict>();
  }
  ShellObject s;
  const TriMesh mesh = checked_mesh(t[1], t[2], "base", "faces");
  const int n = static_cast<int>(mesh.V.rows());
  s.shell.base = mesh.V;
  s.shell.F = mesh.F;
  s.shell.top = to_positions(t[3], "top", n);
  s.shell.thickness = t[4].cast<double>();
  if (!(s.shell.thickness > 0) || !std::isfinite(s.shell.thickness)) value_error("Shell: thickness must be positive");
  {
    // What Shell(...) holds a shell to, so that a state made or changed by hand (duplicated faces,
    // a non-manifold edge, no faces) is refused here and not met by a Deformer or Poser later.
    ReleasedGil release;
    require_valid_mesh(mesh, "Shell state: base");
    check_thickness_scale(mesh.V, mesh.F, s.shell.thickness);
  }
  const int tets = 3 * static_cast<int>(s.shell.F.rows());
  s.stretch = to_matrix(t[5].attr("reshape")(-1, 1), "stretch", 1, tets).col(0);
  s.report = nlohmann::json::parse(t[6].cast<std::string>(), nullptr, false);
  if (!s.report.is_object()) value_error("Shell: the pickled report is not a JSON object");
  s.folder = py::isinstance<py::bytes>(t[7]) ? std::string(t[7].cast<py::bytes>()) : t[7].cast<std::string>();
  if (!t[8].is_none() || !t[9].is_none()) {
    s.uv = to_matrix(t[8], "uv", 2);
    s.fuv = to_indices(t[9], "uv faces", 3, static_cast<int>(s.uv.rows()));
    if (s.fuv.rows() != s.shell.F.rows()) value_error("Shell: the pickled uv faces do not match the faces");
  }
  s.tets = build_prism_tets(s.shell.F, n);
  return {std::move(s), attributes};
}

ShellObject make_shell(const ArrayArg& base, const ArrayArg& faces, const ArrayArg& top, double thickness) {
  const TriMesh mesh = checked_mesh(base, faces, "base", "faces");
  Shell shell;
  // The top held to usable coordinates as a shell folder's is (read_shell_folder), the thickness to
  // what generation builds (check_thickness_scale): beyond them the stretch came back None.
  shell.top = to_positions(top, "top", static_cast<int>(mesh.V.rows()));
  if (!(thickness > 0) || !std::isfinite(thickness))
    value_error("thickness must be positive and finite (got " + format_number(thickness) + ")");
  shell.base = mesh.V;
  shell.F = mesh.F;
  shell.thickness = thickness;
  ReleasedGil release;
  require_valid_mesh(mesh, "base");
  check_thickness_scale(mesh.V, mesh.F, thickness);
  return measured_shell(std::move(shell));
}

ShellObject load_shell_py(const std::filesystem::path& dir) {
  ReleasedGil release;
  ShellFolder folder = read_shell_folder(dir.string());
  ShellObject s = measured_shell(std::move(folder.shell));
  s.folder = dir.string(); // Poser.write refuses it, as gshell pose refuses -o equal to --shell
  s.uv = std::move(folder.surface.UV);
  s.fuv = std::move(folder.surface.FUV);
  return s;
}

ShellObject generate_py(const ArrayArg& V, const ArrayArg& F, std::optional<double> thickness,
                        std::optional<double> thickness_ratio, const std::string& method,
                        std::optional<CountArg> iterations, std::optional<double> tolerance,
                        std::optional<CountArg> anderson, std::optional<double> start_smoothing,
                        std::optional<double> s_min, std::optional<double> s_max,
                        bool count_intersections, bool allow_invalid, const py::object& progress) {
  TriMesh mesh = checked_mesh(V, F);
  GenerateRunOptions options;
  options.thickness = {thickness, thickness_ratio};
  options.generate.method = parse_shell_method(method);
  // As the CLI: an option the run would ignore is a mistake to say, given even at its default.
  // The offset is not optimised; the unguarded run is the paper's plain iteration from the offset.
  const auto require_applies = [](const char* name, bool given, bool applies, const char* when) {
    if (given && !applies) throw InputError(std::string(name) + " applies only to " + when);
  };
  require_applies("s_min", s_min.has_value(), options.generate.method == ShellMethod::Curvature, "method='curvature'");
  require_applies("s_max", s_max.has_value(), options.generate.method == ShellMethod::Curvature, "method='curvature'");
  const bool optimised = options.generate.method != ShellMethod::Offset;
  const char* const optimised_methods = "method='rigid' or 'curvature'";
  require_applies("iterations", iterations.has_value(), optimised, optimised_methods);
  require_applies("tolerance", tolerance.has_value(), optimised, optimised_methods);
  require_applies("anderson", anderson.has_value(), optimised, optimised_methods);
  require_applies("start_smoothing", start_smoothing.has_value(), optimised, optimised_methods);
  require_applies("allow_invalid", allow_invalid, optimised, optimised_methods);
  const char* const guarded = "guarded runs (not with allow_invalid=True)";
  require_applies("anderson", anderson.has_value(), !allow_invalid, guarded);
  require_applies("start_smoothing", start_smoothing.has_value(), !allow_invalid, guarded);
  if (iterations) options.generate.solve.max_iterations = iterations->checked("iterations");
  if (tolerance) options.generate.solve.tolerance = *tolerance;
  if (anderson) options.generate.solve.anderson_history = anderson->checked("anderson");
  if (start_smoothing) options.generate.guard.start_smoothing = *start_smoothing;
  if (s_min) options.generate.s_min = *s_min;
  if (s_max) options.generate.s_max = *s_max;
  options.generate.count_intersections = count_intersections;
  options.generate.allow_invalid = allow_invalid;
  options.check();
  ProgressWatch watch(progress, "gshell.generate");
  watch.watch(options.generate.solve, "paper"); // the documented keys, also where the guard is off
  ReleasedGil release;
  // The same checks as the CLI's load_mesh: the library assumes a valid manifold surface.
  std::vector<std::string> input_warnings = require_valid_mesh(mesh, "mesh (V, F)");
  GenerateRun run = run_generate(std::move(mesh), kArrayInput, options, std::move(input_warnings));
  pass_gil_probe();
  ShellObject s;
  s.tets = build_prism_tets(run.surface.F, run.surface.num_vertices());
  s.stretch = run.result.metrics.tet_stretch;
  s.report = run.to_json();
  s.shell = std::move(run.result.shell);
  return s;
}

py::dict metrics_py(const ArrayArg& Vb, const ArrayArg& F, const ArrayArg& Vt, std::optional<double> thickness,
                    std::optional<double> thickness_ratio, bool count_intersections) {
  const TriMesh base = checked_mesh(Vb, F, "Vb", "F");
  const Eigen::MatrixXd top = to_positions(Vt, "Vt", base.num_vertices());
  const ThicknessChoice choice{thickness, thickness_ratio};
  choice.check();
  ShellMetrics m;
  double eta = 0;
  std::vector<std::string> warnings;
  {
    ReleasedGil release;
    warnings = require_valid_mesh(base, "base (Vb, F)");
    eta = choice.eta(base.V, base.F);
    check_thickness_scale(base.V, base.F, eta); // the normal prisms the stretch is measured against
    m = shell_metrics(base.V, base.F, top, eta, count_intersections);
  }
  py::dict d = to_python(metrics_report(m, base.num_vertices(), base.num_faces(), eta, thickness_ratio));
  d["tet_stretch"] = from_vector(m.tet_stretch);
  d["tet_determinant"] = from_vector(m.tet_determinant);
  d["vertex_thickness"] = from_vector(m.vertex_thickness);
  d["warnings"] = warnings; // the base's, as `gshell metrics -o` writes them (a cut, an unused vertex)
  d["gshell_version"] = GSHELL_VERSION; // as generate()'s report; the CLI's file names (base, top) have no array twin
  return d;
}

} // namespace

void bind_generate(py::module_& m) {
  py::class_<ShellObject, std::shared_ptr<ShellObject>>(m, "Shell", R"(A shell: base and top surfaces with the
same faces and vertex order (top vertex i sits over base vertex i), cut into 3 tets per face.

Made by generate(), load_shell(), or directly with Shell(base, faces, top, thickness). Array
properties return read-only copies (use .copy() to modify).)")
      .def(py::init(&make_shell), py::arg("base"), py::arg("faces"), py::arg("top"), py::arg("thickness"),
           R"(Wrap an existing base/top pair (for example a top read from the CLI's top.obj).

Args:
    base: float array (n, 3), the base surface's vertices (a valid manifold surface).
    faces: integer array (m, 3), counter-clockwise faces shared by base and top.
    top: float array (n, 3), top vertex i over base vertex i.
    thickness: eta in model units (> 0): the thickness the shell is measured against.

stretch and report are measured as by metrics() without intersection counts.)")
      .def_property_readonly("base", [](const ShellObject& s) { return read_only(from_matrix(s.shell.base)); },
                             "float64 (n, 3): base surface vertices.")
      .def_property_readonly("top", [](const ShellObject& s) { return read_only(from_matrix(s.shell.top)); },
                             "float64 (n, 3): top surface vertices (top i over base i).")
      .def_property_readonly("faces", [](const ShellObject& s) { return read_only(from_indices(s.shell.F)); },
                             "int64 (m, 3): faces of both surfaces.")
      .def_property_readonly("thickness", [](const ShellObject& s) { return s.shell.thickness; },
                             "eta in model units.")
      .def_property_readonly("vertices", [](const ShellObject& s) { return read_only(from_matrix(s.shell.vertices())); },
                             "float64 (2n, 3): all shell vertices, base rows 0..n-1 then top rows n..2n-1.")
      .def_property_readonly("tets", [](const ShellObject& s) { return read_only(from_indices(s.tets)); },
                             "int64 (3m, 4): tets over vertices (3 per face, rows 3f..3f+2 for face f), "
                             "positively oriented.")
      .def_property_readonly("stretch", [](const ShellObject& s) { return read_only(from_vector(s.stretch)); },
                             "float64 (3m,): per-tet stretch sum_i (sigma_i - 1)^2 against the ideal normal "
                             "prisms of thickness eta.")
      .def_property_readonly("report", [](const ShellObject& s) { return to_python(s.report); },
                             "dict: the report, with the fields of the CLI's report.json (generate() fills "
                             "iterations, energy, seconds; other shells have the metrics part only).")
      .def(py::pickle(&shell_state, &shell_from_state))
      .def("__repr__", [](const ShellObject& s) {
        return "<gshell.Shell: " + std::to_string(s.shell.num_base_vertices()) + " base vertices, " +
               std::to_string(s.shell.F.rows()) + " faces, thickness " + format_number(s.shell.thickness) + ">";
      }, "Sizes and thickness.");

  const GenerateOptions defaults; // the only source of the defaults, as for the CLI
  m.def("generate", &generate_py, py::arg("V"), py::arg("F"), py::arg("thickness") = py::none(), py::kw_only(),
        py::arg("thickness_ratio") = py::none(), py::arg("method") = to_string(defaults.method),
        // None: the library's default, shown in the signature (given where it does not apply: an error).
        py::arg_v("iterations", py::none(), std::to_string(defaults.solve.max_iterations).c_str()),
        py::arg_v("tolerance", py::none(), shown_default(defaults.solve.tolerance).c_str()),
        py::arg_v("anderson", py::none(), std::to_string(defaults.solve.anderson_history).c_str()),
        py::arg_v("start_smoothing", py::none(), shown_default(defaults.guard.start_smoothing).c_str()),
        py::arg_v("s_min", py::none(), shown_default(defaults.s_min).c_str()),
        py::arg_v("s_max", py::none(), shown_default(defaults.s_max).c_str()),
        py::arg("count_intersections") = defaults.count_intersections,
        py::arg("allow_invalid") = defaults.allow_invalid, py::arg("progress") = py::none(),
        R"(Generate the shell of a triangle surface (paper section 4.1), as `gshell generate` does.

Args:
    V: float array (n, 3), base vertices.
    F: integer array (m, 3), counter-clockwise faces; the surface must be a valid manifold
        (open boundaries, several components and any genus are fine).
    thickness: eta in model units. Give exactly one of thickness and thickness_ratio.
    thickness_ratio: eta as a ratio of the bounding sphere's radius (e.g. 0.01).
    method: "rigid" (optimised towards the normal prisms), "offset" (vertex-normal offset, no
        optimisation) or "curvature" (optimised towards prisms scaled by the surface's curvature).
    iterations: maximum local/global iterations (>= 0).
    tolerance: stop when the relative energy change is below this.
    iterations, tolerance, anderson, start_smoothing, allow_invalid: rigid and curvature only;
        anderson and start_smoothing also not with allow_invalid=True. As s_min and s_max, the
        signature shows the defaults; given where they do not apply (even at those values),
        ValueError, as the CLI's flags.
    anderson: Anderson acceleration of the local/global iterations, iterates combined (0 to 100; 0:
        the paper's plain iteration; allow_invalid always runs the plain iteration).
    start_smoothing: start the iterations from the offset along vertex normals smoothed over
        this fraction of the thickness (>= 0; 0: the raw normals, the paper's offset surface;
        allow_invalid always starts there).
    s_min, s_max: curvature method: the clamp of the in-plane scales of the top triangles
        (0 < s_min <= 1 <= s_max). The signature shows the curvature method's defaults; left
        out, they apply to it alone: given with another method (even at those values), ValueError.
    count_intersections: run the certificate's exact pair tests (top/top, top/base, side
        walls, base/base) for the report; when False their counts are None and report["valid"]
        is None, or False if a tet is inverted (the tets are always checked). A guarded result
        (rigid and curvature without allow_invalid) is always certified in full.
    allow_invalid: rigid and curvature: skip the guard and return the paper's unguarded result,
        which may have inverted tets and intersections (report["valid"] says).
    progress: None (default), True to print each iteration on sys.stderr, or a callable called
        after every iteration with a dict {"stage", "iteration", "energy", "seconds"} (stage:
        "paper", then "repair" and "relax" where the guard mends the top; each stage counts its
        iterations from 1 and reports its own energy). Either way Ctrl-C ends the call at its next
        iteration with KeyboardInterrupt, and an exception the callable raises ends it too.

Returns:
    Shell with top, tets, per-tet stretch and report (dict: the CLI's report.json, with the
    `curvature` section for the curvature method).

Raises:
    ValueError: bad arrays, invalid mesh, both or neither thickness, unknown method, bad numbers.

Releases the GIL while it runs.)");

  m.def("metrics", &metrics_py, py::arg("Vb"), py::arg("F"), py::arg("Vt"), py::arg("thickness") = py::none(),
        py::kw_only(), py::arg("thickness_ratio") = py::none(), py::arg("count_intersections") = true,
        R"(Quality of a shell given by its base and top surfaces, as `gshell metrics` reports it.

Args:
    Vb: float array (n, 3), base vertices (a valid manifold surface with faces F).
    F: integer array (m, 3), faces of both surfaces.
    Vt: float array (n, 3), top vertices (top i over base i).
    thickness: eta in model units. Give exactly one of thickness and thickness_ratio.
    thickness_ratio: eta as a ratio of the base's bounding-sphere radius.
    count_intersections: run the certificate's exact pair tests (their counts and "valid" are
        None in the result if False, "valid" False if a tet is inverted).

Returns:
    dict with the fields of the CLI's metrics report (thickness {eta, ratio, min, mean},
    vertices, faces, tets, stretch {mean, volume_mean, max, p99} against the normal prisms,
    valid, certificate {inverted_tets, top_self_intersections, top_base_intersections,
    wall_intersections, nested_parts, exact}, base_self_intersections, thinned_vertices), plus NumPy arrays
    tet_stretch (3m,), tet_determinant (3m,) and vertex_thickness (n,) (distance to the base / eta).

Raises:
    ValueError: bad arrays, invalid base, both or neither thickness.

Releases the GIL while it runs.)");

  m.def("load_shell", &load_shell_py, py::arg("path"),
        R"(Load a shell folder written by `gshell generate` (base.obj, top.obj, report.json).

Returns:
    Shell; its stretch and report are measured again (as metrics() without intersections).

Raises:
    ValueError: missing files or base/top that do not match.)");
}

} // namespace gshell::python
