// Deformer and deform (base-driven deformation), Embedding and embed (detail carried by a shell).
#include "bindings.h"
#include "count_arg.h"
#include "numpy_arrays.h"
#include "shell_object.h"
#include "gil_probe.h"
#include "progress_watch.h"

#include <gshell/deform/base_frames.h>
#include <gshell/deform/embedding.h>
#include <gshell/deform/shell_deformer.h>
#include <gshell/run/deform_run.h>

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <memory>
#include <optional>

namespace gshell::python {

namespace {

struct DeformerObject {
  DeformerObject(const Shell& rest, bool allow_invalid) : deformer(rest), allow_invalid(allow_invalid) {}
  ShellDeformer deformer;
  bool allow_invalid = false;
  FrameResult last;
  bool solved = false;
  /// solve() runs without the GIL and changes the deformer's state: two Python threads calling
  /// it on one object must take turns.
  ObjectLock lock{"the Deformer"};
};

struct EmbeddingObject {
  Embedding embedding;
  int shell_vertices = 0; ///< 2n of the shell it was made in: carry() needs that many rows
};

} // namespace
} // namespace gshell::python

GSHELL_PYTHON_REQUIRE_INITIALISED(gshell::python::DeformerObject, "Deformer")
GSHELL_PYTHON_REQUIRE_INITIALISED(gshell::python::EmbeddingObject, "Embedding")

namespace gshell::python {
namespace {

// Pickling (multiprocessing workers carrying detail, caches): the located points as they are, so
// an unpickled embedding carries exactly as the original without locating again.
constexpr int kEmbeddingStateVersion = 1;

py::array_t<std::int64_t> outside_ids(const Embedding& m) {
  return from_index_vector(
      Eigen::Map<const Eigen::VectorXi>(m.outside.data(), static_cast<Eigen::Index>(m.outside.size())));
}

py::tuple embedding_state(const EmbeddingObject& e) {
  const Embedding& m = e.embedding;
  return py::make_tuple(kEmbeddingStateVersion, e.shell_vertices, from_index_vector(m.tet), from_indices(m.vertices),
                        from_matrix(m.bary), outside_ids(m), m.max_outside_distance);
}

// Held to what embed() makes, so that a state changed by hand is refused here and not met in
// carry() as an out-of-range row: ids in range, finite coordinates whose rows sum to 1.
EmbeddingObject embedding_from_state(const py::tuple& t) {
  if (t.size() != 7 || !py::isinstance<py::int_>(t[0]) || t[0].cast<int>() != kEmbeddingStateVersion)
    value_error("Embedding: not the state of a pickled gshell.Embedding of this version");
  EmbeddingObject e;
  e.shell_vertices = t[1].cast<int>();
  if (e.shell_vertices < 2 || e.shell_vertices % 2)
    value_error("Embedding state: the shell vertex count must be even and positive");
  Embedding& m = e.embedding;
  m.tet = to_indices(t[2].attr("reshape")(-1, 1), "Embedding state: tet", 1, -1).col(0);
  const int points = static_cast<int>(m.tet.size());
  m.vertices = to_indices(t[3], "Embedding state: tet vertices", 4, e.shell_vertices, points);
  m.bary = to_matrix(t[4], "Embedding state: bary", 4, points);
  if (((m.bary.rowwise().sum().array() - 1).abs() > 1e-6 * (1 + m.bary.cwiseAbs().rowwise().sum().array())).any())
    value_error("Embedding state: the affine coordinates of a point do not sum to 1");
  const Eigen::VectorXi outside = to_indices(t[5].attr("reshape")(-1, 1), "Embedding state: outside", 1, points).col(0);
  m.outside.assign(outside.data(), outside.data() + outside.size());
  m.max_outside_distance = t[6].cast<double>();
  if (!(m.max_outside_distance >= 0) || !std::isfinite(m.max_outside_distance))
    value_error("Embedding state: the largest outside distance must be finite and at least 0");
  return e;
}

std::unique_ptr<DeformerObject> make_deformer(const ShellObject& shell, bool allow_invalid) {
  ReleasedGil release;
  return std::make_unique<DeformerObject>(shell.shell, allow_invalid);
}

py::array deformer_solve(DeformerObject& d, const ArrayArg& new_base, CountArg iterations, double tolerance,
                         const std::string& warm_start, const py::object& progress) {
  const int n = d.deformer.rest_shell().num_base_vertices();
  const Eigen::MatrixXd base = to_matrix(new_base, "new_base", 3, n);
  // Here, to name the argument: solve would say "the new base".
  require_frame_for_shell(base, d.deformer.rest_shell(), "new_base");
  DeformOptions options;
  options.max_iterations = iterations.checked("iterations");
  options.tolerance = tolerance;
  options.warm_start = parse_warm_start(warm_start);
  options.allow_invalid = d.allow_invalid;
  options.check();
  ProgressWatch watch(progress, "gshell.Deformer.solve");
  options.stage = watch.stage_hook();
  options.progress = [&watch](int iteration, double energy, double seconds) {
    watch.report({{"stage", watch.stage()}, {"iteration", iteration}, {"energy", energy}, {"seconds", seconds}});
  };
  Eigen::MatrixXd top;
  {
    ReleasedGil release;
    const ObjectLock::Held held(d.lock); // released before the GIL is taken back
    try {
      d.last = d.deformer.solve(base, options);
    } catch (const PythonErrorPending&) { // interrupted inside the frame: no half-made frame to continue from
      d.deformer.reset();
      d.solved = false;
      throw;
    }
    pass_gil_probe();
    d.solved = true;
    top = d.last.top;
  }
  return from_matrix(top);
}

py::object deform_py(const ShellObject& shell, const py::sequence& frames,
                     const std::optional<std::filesystem::path>& output, CountArg iterations, double tolerance, const std::string& warm_start, bool compare_offset,
                     bool allow_invalid, const py::object& progress) {
  DeformRunOptions options;
  options.frame.allow_invalid = allow_invalid;
  options.frame.max_iterations = iterations.checked("iterations");
  options.frame.tolerance = tolerance;
  options.frame.warm_start = parse_warm_start(warm_start);
  options.compare_offset = compare_offset;
  options.check();
  DeformInput input;
  input.shell_name = "<gshell.Shell>";
  input.shell = shell.shell;
  input.surface = shell.surface();
  const int n = shell.shell.num_base_vertices();
  if (py::len(frames) == 0) value_error("frames is empty: give at least one new base");
  std::vector<Eigen::MatrixXd> bases;
  for (std::size_t k = 0; k < py::len(frames); ++k) {
    const std::string name = "frames[" + std::to_string(k) + "]";
    bases.push_back(to_matrix(frames[k], name.c_str(), 3, n));
    require_frame_for_shell(bases.back(), shell.shell, name);
    input.frame_names.push_back(name);
  }
  input.frames = BaseFrames(std::move(bases));
  ProgressWatch watch(progress, "gshell.deform");
  options.frame.progress = [&watch](int, double, double) { watch.check_signals(); }; // Ctrl-C inside a frame
  const DeformProgress frame_done = [&watch](const DeformRun& run, int count) {
    nlohmann::ordered_json update{{"frame", run.frames.size()}, {"frames", count}};
    if (run.frames.empty()) {
      update["seconds"] = run.setup_seconds;
    } else {
      const FrameResult& r = run.frames.back().result;
      update["iterations"] = r.iterations;
      update["seconds"] = r.seconds;
      update["valid"] = r.valid;
    }
    watch.report(update);
  };
  nlohmann::ordered_json report;
  {
    ReleasedGil release;
    report = run_deform(input, options, output ? output->string() : std::string(), frame_done).to_json();
    pass_gil_probe();
  }
  return to_python(report);
}

Eigen::MatrixXd shell_vertices_of(const py::handle& object, int rows) {
  if (py::isinstance<ShellObject>(object)) {
    const Eigen::MatrixXd X = object.cast<const ShellObject&>().shell.vertices();
    if (X.rows() != rows)
      value_error("the shell has " + std::to_string(X.rows()) + " vertices; the embedding needs " + std::to_string(rows));
    return X;
  }
  return to_positions(object, "shell vertices", rows);
}

} // namespace

void bind_deform(py::module_& m) {
  const DeformOptions defaults; // the only source of the defaults, as for the CLI
  py::class_<DeformerObject>(m, "Deformer", R"(Base-driven shell deformation (paper section 4.2): someone
else moves the base (same connectivity), the top follows with the least stretch relative to the
rest shell. Built once per rest shell (the system matrix is factored once); each solve() only
back-substitutes and is warm-started from the previous frame, as `gshell deform` does.)")
      .def(py::init(&make_deformer), py::arg("shell"), py::kw_only(), py::arg("allow_invalid") = defaults.allow_invalid,
           R"(Prepare the deformation of `shell` (a Shell, e.g. from generate()).

Every frame is valid by construction (no inverted tet, no intersection of the layer's boundary,
certified exactly in .last) unless allow_invalid=True, which gives the unguarded frames, as
`gshell deform --allow-invalid`.

A rest shell's flat or inverted tets (below 1e-3 of their normal prism's volume) take that prism's
shape as their rest shape, so the frames push them back to a proper prism (replaced_rest_tets
counts them; gshell.deform and `gshell deform` warn of them). A rest top lying on the wrong side
of its base comes out on the other side in the first frame.)")
      .def("solve", &deformer_solve, py::arg("new_base"), py::kw_only(), py::arg("iterations") = defaults.max_iterations,
           py::arg("tolerance") = defaults.tolerance, py::arg("warm_start") = warm_start_name(defaults.warm_start),
           py::arg("progress") = py::none(),
           R"(Solve the top for a new base.

Args:
    new_base: float array (n, 3), the rest base's vertex order.
    iterations: maximum local/global iterations (>= 0).
    tolerance: stop when the relative energy change is below this.
    warm_start: "extrapolated" (default: "rotated" plus the previous frame's correction,
        continued), "rotated" (previous offsets rotated with the base's 1-rings), "translated"
        (previous top moved with the base) or "previous" (previous top as is), as
        `gshell deform --warm-start`.
    progress: None (default), True to print each iteration on sys.stderr, or a callable called
        after every iteration with a dict {"stage", "iteration", "energy", "seconds"} (stage:
        "paper", the frame's solve, then, where the guard works, "mend", "drag K/N" for each
        guarded sub-step, "regenerate paper|repair|relax" and "polish" for a fresh top; each
        counts from 1 again). Either way Ctrl-C ends the call at its next iteration with KeyboardInterrupt, as
        does an exception the callable raises; the Deformer then starts from the rest shell
        again, as after reset(). The callable must not use this Deformer (it is busy: RuntimeError).

Returns:
    float64 array (n, 3): the deformed top. Statistics are in .last.

Raises:
    ValueError: wrong shape, NaN, bad options.

Releases the GIL while it runs.)")
      .def("reset", [](DeformerObject& d) {
             without_gil_locked(d.lock, [&] {
               d.deformer.reset();
               d.solved = false;
             });
           },
           "Start the next solve() from the rest shell again.")
      .def_property_readonly("vertices", [](DeformerObject& d) {
             const Eigen::MatrixXd X = without_gil_locked(d.lock, [&] { return d.deformer.current(); });
             return read_only(from_matrix(X));
           },
           "float64 (2n, 3): all shell vertices after the last solve (base rows, then top rows); "
           "pass it to Embedding.carry().")
      .def_property_readonly("last", [](DeformerObject& d) -> py::object {
             const nlohmann::ordered_json j = without_gil_locked(d.lock, [&] { // null before the first solve
               return d.solved ? frame_json(d.last) : nlohmann::ordered_json();
             });
             return j.is_null() ? py::none() : to_python(j);
           },
           "dict about the last solve (None before the first): iterations, converged, energy (list, "
           "energy[0] at the warm start), stretch {mean, volume_mean, max, p99} against the rest shell, "
           "inverted_tets, seconds, valid, method, resumed, fresh_top, substeps, guarded_iterations, thinned_vertices, zero_area_faces, "
           "certificate {...}, base_self_intersections, unextrudable_vertices. The fields of a frame in `gshell deform`'s report.json.")
      .def_property_readonly(
          "replaced_rest_tets", [](const DeformerObject& d) { return d.deformer.replaced_rest_tets(); },
          "Flat or inverted rest tets deformed with their normal prism's shape as rest shape.")
      .def_property_readonly("factor_seconds", [](const DeformerObject& d) { return d.deformer.factor_seconds(); },
                             "Seconds spent assembling and factoring the system matrix.")
;

  m.def("deform", &deform_py, py::arg("shell"), py::arg("frames"), py::kw_only(), py::arg("output") = py::none(),
        py::arg("iterations") = defaults.max_iterations, py::arg("tolerance") = defaults.tolerance,
        py::arg("warm_start") = warm_start_name(defaults.warm_start), py::arg("compare_offset") = false,
        py::arg("allow_invalid") = defaults.allow_invalid, py::arg("progress") = py::none(),
        R"(Deform `shell` by a sequence of new bases, as `gshell deform` does: one factorisation, each
frame warm-started from the previous one.

Args:
    shell: the rest Shell.
    frames: a sequence of float arrays (n, 3), the new bases in the rest base's vertex order.
    output: a folder to write as `gshell deform -o` does (frame_NNNN/top.obj and shell.vtu,
        report.json), or None.
    iterations, tolerance, warm_start: per frame, as Deformer.solve().
    compare_offset: also measure re-extruding each frame by the vertex-normal offset.
    allow_invalid: the unguarded frames, as `gshell deform --allow-invalid` (default: every
        frame valid by construction).
    progress: None (default), True to print each frame on sys.stderr, or a callable called with
        a dict {"frame": 0, "frames", "seconds"} once the setup (factorisation) is done and
        {"frame", "frames", "iterations", "seconds", "valid"} after every frame. Either way Ctrl-C
        ends the call with KeyboardInterrupt (inside a frame, at its next iteration), as does an
        exception the callable raises; nothing is written to `output` then.

Returns:
    dict: the CLI's report.json (summary and one record per frame).

Raises:
    ValueError: bad arrays or options, or an output folder that holds other files.

Releases the GIL while it runs.)");

  py::class_<EmbeddingObject>(m, "Embedding", R"(Points embedded in a rest shell as (tet, barycentric
coordinates), carried along by every deformation of that shell (paper Fig. 5, 8). Made by embed();
embeddings pickle (the located points as they are).)")
      .def("carry",
           [](const EmbeddingObject& e, const py::object& deformed) {
             const Eigen::MatrixXd X = shell_vertices_of(deformed, e.shell_vertices);
             Eigen::MatrixXd P;
             {
               ReleasedGil release;
               P = carry(e.embedding, X);
             }
             return from_matrix(P);
           },
           py::arg("deformed"),
           R"(Positions of the embedded points in a deformed shell.

Args:
    deformed: a Shell with the rest shell's connectivity, or a float array (2n, 3) of all shell
        vertices (base rows, then top rows), e.g. Deformer.vertices or
        numpy.vstack([new_base, new_top]); every |x| < 1e50.

Returns:
    float64 array (P, 3). The rest shell gives back the embedded points.)")
      .def_property_readonly("tet", [](const EmbeddingObject& e) { return read_only(from_index_vector(e.embedding.tet)); },
                             "int64 (P,): the tet holding each point (the nearest tet for points outside).")
      .def_property_readonly("tet_vertices",
                             [](const EmbeddingObject& e) { return read_only(from_indices(e.embedding.vertices)); },
                             "int64 (P, 4): that tet's shell vertex ids.")
      .def_property_readonly("bary", [](const EmbeddingObject& e) { return read_only(from_matrix(e.embedding.bary)); },
                             "float64 (P, 4): affine coordinates in that tet (rows sum to 1; some negative "
                             "for points outside the shell).")
      .def_property_readonly("outside",
                             [](const EmbeddingObject& e) { return read_only(outside_ids(e.embedding)); },
                             "int64: indices of the points no tet contains (bound to the nearest tet, "
                             "extrapolated).")
      .def_property_readonly("max_outside_distance", [](const EmbeddingObject& e) { return e.embedding.max_outside_distance; },
                             "Largest distance from an outside point to its tet (model units).")
      .def("__len__", [](const EmbeddingObject& e) { return e.embedding.size(); }, "Number of embedded points.")
      .def(py::pickle(&embedding_state, &embedding_from_state));

  m.def("embed",
        [](const ShellObject& shell, const ArrayArg& points, const py::object& progress) {
          const Eigen::MatrixXd P = to_positions(points, "points");
          EmbeddingObject e;
          ProgressWatch watch(progress, "gshell.embed");
          {
            ReleasedGil release;
            e.embedding = embed_points(shell.shell.vertices(), shell.tets, P, [&watch](int located, int total) {
              nlohmann::ordered_json update;
              update["located"] = located;
              update["points"] = total;
              watch.report(update);
            });
          }
          e.shell_vertices = 2 * shell.shell.num_base_vertices();
          return e;
        },
        py::arg("shell"), py::arg("points"), py::arg("progress") = py::none(),
        R"(Embed points in a rest shell: each is stored as (tet, barycentric coordinates).

Args:
    shell: the rest Shell.
    points: float array (P, 3), every |x| < 1e50. Points outside the shell are bound to the
        nearest tet (see Embedding.outside).
    progress: None (default), True to print a line on sys.stderr after each block of 65,536
        points, or a callable called then with {"located", "points"} (points located so far, all
        points). Ctrl-C (KeyboardInterrupt) ends the call after the block under way, as does an
        exception the callable raises.

Returns:
    Embedding; .carry(deformed shell) gives the points' new positions.

Raises:
    ValueError: bad array, NaN or a coordinate of 1e50 or more, or a shell whose tets are all
        flat (none can carry affine coordinates).

Releases the GIL while it runs.)");
}

} // namespace gshell::python
