#include <gshell/render/shell_render.h>

#include <gshell/error.h>
#include <gshell/io/load_mesh.h>
#include <gshell/io/read_mesh.h>
#include <gshell/io/tet_mesh_io.h>
#include <gshell/quality/stretch.h>
#include <gshell/quality/thickness.h>
#include <gshell/render/color_map.h>
#include <gshell/run/frames.h>
#include <gshell/run/shell_folder.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/rest_tets.h>

#include "run/output_folder_files.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>

namespace gshell {
namespace fs = std::filesystem;

namespace {

double median_distance(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top) {
  const Eigen::VectorXd d = (top - base).rowwise().norm();
  return quantile(std::vector<double>(d.data(), d.data() + d.size()), 0.5);
}

// Stretch of a base/top pair measured as `generate` does: against the ideal normal prisms.
Eigen::VectorXd stretch_against_normal_prisms(const Shell& shell) {
  const int n = shell.num_base_vertices();
  const RestTets rest = prism_rest_tets(shell.F, n, normal_prisms(shell.base, shell.F, shell.thickness));
  const Eigen::MatrixXd X = shell.vertices();
  return face_stretch_from_tets(X, rest.T, tet_stretch(rest, X));
}

RenderSubject load_shell_folder(const fs::path& dir, const std::string& name) {
  ShellFolderReadOptions read;
  read.require_thickness = false; // a render can do without: eta falls back to the median distance
  read.read_tets = true;
  ShellFolder folder = read_shell_folder(dir.string(), read);
  RenderSubject subject;
  subject.name = name;
  subject.method = folder.made_by;
  subject.shell = std::move(folder.shell);
  if (!(subject.shell.thickness > 0)) subject.shell.thickness = median_distance(subject.shell.base, subject.shell.top);
  if (folder.tet_stretch.size() > 0)
    subject.face_stretch = face_stretch_from_tets(subject.shell.vertices(), folder.tets, folder.tet_stretch);
  else if (subject.shell.thickness > 0)
    subject.face_stretch = stretch_against_normal_prisms(subject.shell);
  subject.detail = std::move(folder.detail);
  return subject;
}

} // namespace

Eigen::VectorXd face_stretch_from_tets(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T, const Eigen::VectorXd& tet_stretch) {
  if (T.rows() % 3 || tet_stretch.size() != T.rows())
    throw InputError("face stretch: need 3 tets per face and one stretch value per tet");
  if (X.cols() != 3 || (T.size() > 0 && (T.cols() != 4 || T.minCoeff() < 0 || T.maxCoeff() >= X.rows())))
    throw InputError("face stretch: tets must be m x 4 with vertex ids in [0, " + std::to_string(X.rows()) +
                     ") of an n x 3 vertex matrix");
  const Eigen::Index m = T.rows() / 3;
  Eigen::VectorXd faces(m);
  for (Eigen::Index f = 0; f < m; ++f) {
    double weighted = 0, volume = 0, plain = 0;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Index t = 3 * f + k;
      const Eigen::Vector3d x0 = X.row(T(t, 0));
      Eigen::Matrix3d D;
      D << X.row(T(t, 1)).transpose() - x0, X.row(T(t, 2)).transpose() - x0, X.row(T(t, 3)).transpose() - x0;
      const double v = std::abs(D.determinant()) / 6;
      weighted += v * tet_stretch[t];
      volume += v;
      plain += tet_stretch[t];
    }
    faces[f] = volume > 0 ? weighted / volume : plain / 3; // fully collapsed prism: plain mean
  }
  return faces;
}

Eigen::VectorXd vertex_thickness_ratio(const Shell& shell) {
  if (!(shell.thickness > 0)) throw InputError("thickness colors need the shell's thickness eta");
  // The report's measure (distance to the base surface on the top's side), not the offset
  // length |top_i - base_i|: at a squeezed corner that length stayed near 0.7 eta while the top
  // lay 0.06 eta from the base, so the picture hid the thinning the report counts.
  return vertex_thickness(shell.base, shell.F, shell.top) / shell.thickness;
}

RenderSubject load_render_subject(const std::string& input) {
  const fs::path path(input);
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    const std::vector<fs::path> frames = is_shell_folder(path) ? std::vector<fs::path>{} : list_frames(path);
    if (!frames.empty()) {
      RenderSubject subject = load_shell_folder(frames.back(), input);
      subject.name = input + "/" + frames.back().filename().string();
      return subject;
    }
    return load_shell_folder(path, input);
  }
  RenderSubject subject;
  subject.name = input;
  TriMesh mesh = load_mesh(input, &subject.warnings);
  subject.shell.base = std::move(mesh.V);
  subject.shell.F = std::move(mesh.F);
  return subject;
}

std::string default_caption(const RenderSubject& subject) {
  // The folder or file name, not the whole path: captions are short, panels narrow.
  fs::path path = fs::path(subject.name).lexically_normal();
  if (path.filename().empty()) path = path.parent_path();
  std::string name = path.filename().string();
  if (frame_number(name) && !path.parent_path().filename().empty())
    name = path.parent_path().filename().string() + "/" + name; // which run the frame belongs to
  if (name.empty()) name = subject.name;
  return subject.method.empty() ? name : name + " (" + subject.method + ")";
}

Image render_subjects(const std::vector<RenderSubject>& subjects, const std::vector<std::string>& captions,
                      const ShellRenderOptions& options, FigureLayout* layout) {
  if (subjects.empty()) throw InputError("render: no input");
  if (!captions.empty() && captions.size() != subjects.size())
    throw InputError("render: " + std::to_string(captions.size()) + " captions for " + std::to_string(subjects.size()) +
                     " inputs (give one per input, or none)");

  ColorBy color_by = options.color_by;
  const bool any_stretch = std::any_of(subjects.begin(), subjects.end(), [](const RenderSubject& s) { return s.face_stretch.size() > 0; });
  const bool any_shell = std::any_of(subjects.begin(), subjects.end(), [](const RenderSubject& s) { return s.is_shell(); });
  if (color_by == ColorBy::Auto) color_by = any_stretch ? ColorBy::Stretch : ColorBy::None;
  if (color_by == ColorBy::Stretch && !any_stretch) throw InputError("render: color by stretch needs a shell folder input");
  if (color_by == ColorBy::Thickness && !any_shell) throw InputError("render: color by thickness needs a shell folder input");

  // Values per subject (faces for stretch, vertices for thickness) and one shared scale.
  std::vector<Eigen::VectorXd> values(subjects.size());
  double automatic = INFINITY;
  for (size_t i = 0; i < subjects.size(); ++i) {
    const RenderSubject& s = subjects[i];
    if (color_by == ColorBy::Stretch) values[i] = s.face_stretch;
    if (color_by == ColorBy::Thickness && s.is_shell()) values[i] = vertex_thickness_ratio(s.shell);
    if (values[i].size() == 0) continue;
    std::vector<double> magnitude(values[i].data(), values[i].data() + values[i].size());
    if (color_by == ColorBy::Thickness) {
      // Thickness: the widest spread, so no panel saturates.
      for (double& v : magnitude) v = std::abs(v - 1);
      automatic = std::isfinite(automatic) ? std::max(automatic, quantile(magnitude, 0.99)) : quantile(magnitude, 0.99);
    } else {
      automatic = std::min(automatic, quantile(magnitude, 0.99));
    }
  }
  std::optional<ColorScale> scale;
  if (color_by == ColorBy::Stretch) {
    scale.emplace();
    scale->max = options.auto_max      ? std::max(round_up_nice(automatic), 1e-4)
                 : options.color_max > 0 ? options.color_max
                                         : kDefaultStretchMax;
    scale->label = "stretch";
  } else if (color_by == ColorBy::Thickness) {
    const double half = options.auto_max      ? std::max(round_up_nice(automatic), 0.01)
                        : options.color_max > 0 ? options.color_max
                                                : kDefaultThicknessSpread;
    scale.emplace();
    scale->ramp = ColorScale::Ramp::BlueGreenRed;
    scale->min = 1 - half;
    scale->max = 1 + half;
    scale->label = "thickness / \u03b7";
  }

  const Eigen::Vector3f base_grey(0.72f, 0.76f, 0.84f), top_grey(0.88f, 0.88f, 0.90f);
  std::vector<Panel> panels;
  for (size_t i = 0; i < subjects.size(); ++i) {
    const RenderSubject& s = subjects[i];
    Panel panel;
    panel.caption = captions.empty() ? default_caption(s) : captions[i];
    SurfaceLayer base, top;
    base.V = s.shell.base;
    base.F = s.shell.F;
    base.color = base_grey;
    if (!scale) base.back_color = Eigen::Vector3f(0.85f, 0.72f, 0.55f); // tells the inside of an open surface apart
    if (scale && values[i].size() == s.shell.F.rows() && color_by == ColorBy::Stretch) base.face_colors = map_colors(*scale, values[i]);
    if (scale && color_by == ColorBy::Thickness && values[i].size() > 0) base.vertex_colors = map_colors(*scale, values[i]);
    if (s.is_shell()) {
      top.V = s.shell.top;
      top.F = s.shell.F;
      top.face_colors = base.face_colors;
      top.vertex_colors = base.vertex_colors;
      top.color = top_grey;
    }
    if (s.detail.num_faces() > 0) {
      SurfaceLayer detail;
      detail.V = s.detail.V;
      detail.F = s.detail.F;
      detail.color = Eigen::Vector3f(0.93f, 0.90f, 0.82f); // ivory: apart from every ramp color
      panel.scene.layers.push_back(detail);
    }
    switch (options.style) {
    case ShellStyle::Translucent:
      panel.scene.layers.push_back(base);
      if (s.is_shell()) {
        top.opacity = options.top_opacity;
        if (!scale) top.color = top_grey;
        panel.scene.layers.push_back(top);
      }
      break;
    case ShellStyle::Cut: {
      // The inside of the top gets a flat blue, visible between the two rims where the layer is;
      // the base keeps its colors on both sides (a prism's value belongs to both).
      top.back_color = Eigen::Vector3f(0.55f, 0.68f, 0.92f);
      panel.scene.layers.push_back(base);
      if (s.is_shell()) {
        // The top stays neutral so the layer between the two cut rims reads at a glance.
        top.face_colors.resize(0, 3);
        top.vertex_colors.resize(0, 3);
        panel.scene.layers.push_back(top);
      }
      const Eigen::MatrixXd points = scene_points(panel.scene);
      const Eigen::Vector3d centre = 0.5 * (points.colwise().minCoeff() + points.colwise().maxCoeff()).transpose();
      const Eigen::Vector3d towards_eye = eye_direction(options.figure.view);
      panel.scene.clip_plane = Eigen::Vector4d(-towards_eye.x(), -towards_eye.y(), -towards_eye.z(), towards_eye.dot(centre));
      break;
    }
    case ShellStyle::Base: panel.scene.layers.push_back(base); break;
    case ShellStyle::Top: panel.scene.layers.push_back(s.is_shell() ? top : base); break;
    }
    panels.push_back(std::move(panel));
  }
  FigureOptions figure = options.figure;
  figure.color_bar = scale;
  if (color_by == ColorBy::Stretch && figure.footnote.empty())
    figure.footnote = "stretch = \u03a3\u1d62 (\u03c3\u1d62 \u2212 1)\u00b2 per tet; faces show their prism's volume-weighted mean";
  if (color_by == ColorBy::Thickness && figure.footnote.empty())
    figure.footnote = "thickness = distance of top vertex i to the base / \u03b7";
  return render_figure(panels, figure, layout);
}

namespace {

// The rest shell of a pose folder: "rest_shell" (relative to the folder) where the pose wrote it,
// else "shell" as the pose was given it (folders of earlier versions: relative to where that ran,
// so it is checked to be a shell with the posed one's faces). Empty, with `note` saying why, when
// it cannot be found or is another shell.
std::optional<RenderSubject> pose_rest_shell(const fs::path& folder, const RenderSubject& posed, std::string& note) {
  fs::path rest_dir;
  try {
    const nlohmann::json report = read_report(folder);
    if (report.contains("rest_shell")) rest_dir = folder / report.at("rest_shell").get<std::string>();
    else rest_dir = report.at("shell").get<std::string>();
  } catch (const std::exception&) {
    note = "the pose's report.json names no rest shell: the posed shell alone";
    return std::nullopt;
  }
  try {
    RenderSubject rest = load_shell_folder(rest_dir, "rest");
    if (rest.shell.F.rows() != posed.shell.F.rows() || rest.shell.base.rows() != posed.shell.base.rows() ||
        rest.shell.F != posed.shell.F) {
      note = "the rest shell " + rest_dir.generic_string() + " named in report.json is not the posed shell's (" +
             std::to_string(rest.shell.base.rows()) + " base vertices, " + std::to_string(rest.shell.F.rows()) +
             " faces, against " + std::to_string(posed.shell.base.rows()) + " and " +
             std::to_string(posed.shell.F.rows()) + "): the posed shell alone";
      return std::nullopt;
    }
    rest.face_stretch = Eigen::VectorXd::Zero(rest.shell.F.rows()); // against itself, by definition
    rest.detail = TriMesh{};
    return rest;
  } catch (const std::exception& e) {
    note = "the rest shell named in report.json cannot be read (" + std::string(e.what()) +
           "): the posed shell alone";
    return std::nullopt;
  }
}

} // namespace

PreviewPanels preview_panels(const std::string& dir, const std::string& name) {
  const fs::path folder(dir);
  // A caption names the folder, not the path it was reached by (previews are seen inside it).
  fs::path shown = fs::path(name.empty() ? dir : name).lexically_normal();
  if (shown.filename().empty()) shown = shown.parent_path();
  const std::string folder_name = shown.filename().string();
  PreviewPanels panels;
  std::vector<RenderSubject>& subjects = panels.subjects;
  std::vector<std::string>& captions = panels.captions;
  const std::vector<fs::path> frames = is_shell_folder(folder) ? std::vector<fs::path>{} : list_frames(folder);
  if (!frames.empty()) {
    std::vector<size_t> picks{0, frames.size() / 2, frames.size() - 1};
    picks.erase(std::unique(picks.begin(), picks.end()), picks.end());
    for (size_t k : picks) {
      subjects.push_back(load_shell_folder(frames[k], frames[k].string()));
      captions.push_back(frames[k].filename().string());
    }
  } else {
    RenderSubject subject = load_render_subject(dir);
    // A pose output: the rest shell first, so the pose reads as a change. Its stretch against
    // itself is 0 by definition (the posed panel's colors are measured against it).
    if (subject.method == "pose") {
      std::optional<RenderSubject> rest = pose_rest_shell(folder, subject, panels.note);
      if (rest) {
        subjects.push_back(std::move(*rest));
        captions.push_back("rest");
      }
    }
    subject.name = folder_name;
    captions.push_back(subjects.empty() ? default_caption(subject) : "posed");
    subjects.push_back(std::move(subject));
  }
  return panels;
}

std::string render_shell_preview(const std::string& dir, const std::string& name, const ViewDirection& view) {
  const PreviewPanels panels = preview_panels(dir, name);
  const std::string out = (fs::path(dir) / kPreviewFile).string();
  ShellRenderOptions options;
  options.figure.view = view;
  write_png(out, render_subjects(panels.subjects, panels.captions, options));
  return out;
}

} // namespace gshell
