#include <gshell/view/view_input.h>

#include <gshell/error.h>
#include <gshell/io/load_mesh.h>
#include <gshell/render/shell_render.h>
#include <gshell/run/frames.h>
#include <gshell/run/shell_folder.h>
#include <gshell/shell/prism_tets.h>

#include <filesystem>

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
    } else if (f.shell.base.rows() != in.shell.base.rows() || f.shell.F != in.shell.F) {
      throw InputError(with_file(dirs[k], "not a frame of the same shell as " + dirs[0] + " (" +
                                              std::to_string(f.shell.base.rows()) + " vertices, " +
                                              std::to_string(f.shell.F.rows()) + " faces vs " +
                                              std::to_string(in.shell.base.rows()) + ", " +
                                              std::to_string(in.shell.F.rows()) + ", or other faces)"));
    }
    in.frames.push_back({dirs[k], f.shell.vertices(), std::move(loaded.face_stretch)});
    if (options.frame_progress && dirs.size() > 1) options.frame_progress(static_cast<int>(k) + 1, static_cast<int>(dirs.size()));
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
  if (inputs.size() == 1) {
    const fs::path path(inputs[0]);
    if (!fs::is_directory(path, ec)) return from_surface(inputs[0], options);
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
  for (const std::string& input : inputs)
    if (!fs::is_directory(input, ec) || !is_shell_folder(input))
      throw InputError(with_file(input, "several inputs play as a sequence of frames: each must be a shell folder"));
  return from_folders(inputs, inputs[0], options);
}

} // namespace gshell
