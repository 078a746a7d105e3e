#include <gshell/view/view_input.h>

#include <gshell/error.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/tet_mesh_io.h>
#include <gshell/io/load_mesh.h>
#include <gshell/render/shell_render.h>
#include <gshell/run/frames.h>
#include <gshell/run/shell_folder.h>
#include <gshell/shell/prism_tets.h>

#include <filesystem>
#include <optional>

namespace gshell {

namespace fs = std::filesystem;

namespace {

// One shell folder with the stretch gshell render shows for it.
struct LoadedFolder {
  ShellFolder folder;
  Eigen::VectorXd face_stretch;
};

LoadedFolder load_folder(const std::string& dir) {
  ShellFolderReadOptions read;
  read.read_tets = true;
  LoadedFolder out{read_shell_folder(dir, read), {}};
  const ShellFolder& f = out.folder;
  if (f.tet_stretch.size() > 0 && f.tets.rows() == 3 * f.shell.F.rows())
    out.face_stretch = face_stretch_from_tets(f.shell.vertices(), f.tets, f.tet_stretch);
  else // no stored stretch: render measures it itself (against the normal prisms)
    out.face_stretch = load_render_subject(dir).face_stretch;
  return out;
}

// Throws unless the shell read from `dir` (n vertices, m faces; `same_faces`) is a frame of the
// shell `first` read from `first_dir`.
void check_same_shell(const std::string& dir, Eigen::Index n, Eigen::Index m, bool same_faces, const Shell& first,
                      const std::string& first_dir) {
  if (n == first.base.rows() && m == first.F.rows() && same_faces) return;
  const std::string what = n == first.base.rows() && m == first.F.rows()
                               ? "the same " + std::to_string(n) + " vertices and " + std::to_string(m) +
                                     " faces, but other faces or corners in another order"
                               : std::to_string(n) + " vertices, " + std::to_string(m) + " faces vs " +
                                     std::to_string(first.base.rows()) + ", " + std::to_string(first.F.rows());
  throw InputError(with_file(dir, "not a frame of the same shell as " + first_dir + " (" + what + ")"));
}

// Eigen's == needs equal sizes (it reads past the smaller matrix otherwise).
bool same_ids(const Eigen::MatrixXi& a, const Eigen::MatrixXi& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() && a == b;
}

void check_same_shell(const std::string& dir, const Shell& f, const Shell& first, const std::string& first_dir) {
  check_same_shell(dir, f.base.rows(), f.F.rows(), same_ids(f.F, first.F), first, first_dir);
}

// A frame not held, read when shown: positions and stored stretch from its shell.vtu alone,
// checked against the first frame's tets (which fix its faces). Reading the folder as a whole
// parsed top.obj again for faces every frame has, and that was most of a read. Empty when the
// folder has no shell.vtu with a stretch array (read as a whole then).
std::optional<ViewFrame> read_frame_vtu(const std::string& dir, const ViewInput& input) {
  const fs::path path = fs::path(dir) / "shell.vtu";
  std::error_code ec;
  if (input.tets.size() == 0 || !fs::exists(path, ec)) return std::nullopt;
  TetMesh vtu = read_tet_mesh(path.string());
  const Eigen::MatrixXd* stretch = nullptr;
  for (const auto& [name, values] : vtu.cell_data)
    if (name == "stretch" && values.cols() == 1) stretch = &values;
  if (!stretch) return std::nullopt;
  const bool same = vtu.X.rows() == 2 * input.shell.base.rows() && same_ids(vtu.T, input.tets);
  check_same_shell(dir, vtu.X.rows() / 2, vtu.T.rows() / 3, same, input.shell, input.frames[0].name);
  require_usable_coordinates(vtu.X, path.string());
  Eigen::VectorXd face_stretch = face_stretch_from_tets(vtu.X, vtu.T, stretch->col(0));
  return ViewFrame{dir, std::move(vtu.X), std::move(face_stretch)};
}

ViewInput from_folders(const std::vector<std::string>& dirs, const std::string& name, const ViewInputOptions& options) {
  ViewInput in;
  in.name = name;
  for (size_t k = 0; k < dirs.size(); ++k) {
    LoadedFolder loaded = load_folder(dirs[k]);
    ShellFolder& f = loaded.folder;
    if (k == 0) {
      in.made_by = f.made_by;
      in.shell = f.shell;
      in.surface = std::move(f.surface);
      const std::string rest_warning = invalid_rest_shell_warning(dirs[0], f.report, "pose step");
      if (!rest_warning.empty()) in.warnings.push_back(rest_warning);
      const double frame_bytes = sizeof(double) * static_cast<double>(6 * f.shell.base.rows() + loaded.face_stretch.size());
      in.frames_held =
          dirs.size() == 1 || frame_bytes * static_cast<double>(dirs.size()) <= static_cast<double>(options.held_frame_bytes);
    } else {
      check_same_shell(dirs[k], f.shell, in.shell, dirs[0]);
    }
    in.frames.push_back({dirs[k], f.shell.vertices(), std::move(loaded.face_stretch), f.shell.thickness});
    if (options.frame_progress && dirs.size() > 1) options.frame_progress(static_cast<int>(k) + 1, static_cast<int>(dirs.size()));
    if (!in.frames_held) { // the first frame only (the shell the page opens on); the others are named
      in.tets = std::move(f.tets);
      for (size_t j = k + 1; j < dirs.size(); ++j) in.frames.push_back({dirs[j], {}, {}});
      break;
    }
  }
  return in;
}

ViewInput from_surface(const std::string& spec, const ViewInputOptions& options) {
  GenerateRunOptions generate = options.generate;
  if (!generate.thickness.thickness && !generate.thickness.thickness_ratio)
    generate.thickness.thickness_ratio = kViewDefaultThicknessRatio;
  generate.generate.count_intersections = false; // the viewer checks validity itself, off the interactive path
  generate.check();
  std::vector<std::string> input_warnings;
  TriMesh surface = load_mesh(spec, &input_warnings);
  GenerateRun run = run_generate(std::move(surface), spec, generate, std::move(input_warnings));
  ViewInput in;
  in.name = spec;
  in.made_by = to_string(run.result.method);
  in.shell = run.result.shell;
  in.surface = std::move(run.surface);
  in.warnings = run.warnings();
  const Eigen::MatrixXd X = in.shell.vertices();
  in.frames.push_back({spec, X,
                       face_stretch_from_tets(X, build_prism_tets(in.shell.F, in.shell.num_base_vertices()),
                                              run.result.metrics.tet_stretch)});
  return in;
}

} // namespace

ViewInput load_view_input(const std::vector<std::string>& inputs, const ViewInputOptions& options) {
  if (inputs.empty()) throw InputError("view: no input");
  std::error_code ec;
  if (inputs.size() == 1 && !fs::is_directory(inputs[0], ec)) return from_surface(inputs[0], options);
  for (const std::string& input : inputs)
    if (inputs.size() > 1 && (!fs::is_directory(input, ec) || !is_shell_folder(input)))
      throw InputError(with_file(input, "several inputs play as a sequence of frames: each must be a shell folder"));
  // Shell folders keep the thickness they were made with; one given here would be ignored.
  if (options.generate.thickness.thickness || options.generate.thickness.thickness_ratio)
    throw InputError(with_file(inputs[0], "a thickness applies only to a surface input (a shell folder keeps its own)"));
  if (inputs.size() == 1) {
    const fs::path path(inputs[0]);
    if (is_shell_folder(path)) return from_folders(inputs, inputs[0], options);
    const std::vector<fs::path> frames = list_frames(path);
    if (frames.empty())
      throw InputError(with_file(inputs[0], "neither a shell folder (top.obj, shell.vtu) nor a deform output (frame_NNNN/)"));
    std::vector<std::string> dirs;
    for (const fs::path& f : frames) dirs.push_back(f.string());
    ViewInput in = from_folders(dirs, inputs[0], options);
    if (in.made_by.empty()) in.made_by = "deform";
    return in;
  }
  return from_folders(inputs, inputs[0], options);
}

ViewFrame read_view_frame(const ViewInput& input, int k) {
  if (k < 0 || k >= static_cast<int>(input.frames.size()))
    throw InputError("no frame " + std::to_string(k) + " (there are " + std::to_string(input.frames.size()) + ")");
  const ViewFrame& frame = input.frames[static_cast<size_t>(k)];
  if (input.frames_held || k == 0) return frame;
  if (std::optional<ViewFrame> read = read_frame_vtu(frame.name, input)) return std::move(*read);
  LoadedFolder loaded = load_folder(frame.name);
  check_same_shell(frame.name, loaded.folder.shell, input.shell, input.frames[0].name);
  return {frame.name, loaded.folder.shell.vertices(), std::move(loaded.face_stretch), loaded.folder.shell.thickness};
}

} // namespace gshell
