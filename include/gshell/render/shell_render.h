#pragma once
// Renders of shells (and plain surfaces) for `gshell render`, the `--render` previews of
// generate / deform / pose, and `gshell report`.
#include <gshell/mesh.h>
#include <gshell/render/figure.h>
#include <gshell/shell/shell.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <string>
#include <vector>

namespace gshell {

/// One render input, loaded. A plain surface has an empty `shell.top`.
struct RenderSubject {
  std::string name;            ///< the input as given (path or builtin spec)
  std::string method;          ///< report.json `method` (rigid, offset, ...) or `command` (deform, pose); may be empty
  Shell shell;                 ///< base, top (may be empty), faces, thickness eta (0 if unknown)
  Eigen::VectorXd face_stretch;///< one value per face (see face_stretch_from_tets), or empty
  TriMesh detail;              ///< geometry embedded in the shell (DIR/detail.obj of deform), or empty
  std::vector<std::string> warnings; ///< a surface input's validation warnings (cuts, unused vertices; load_mesh)

  bool is_shell() const { return shell.top.rows() > 0; }
};

/// Loads a render input:
/// - a shell folder written by generate / pose (shell.vtu with cell data `stretch`, and/or
///   base.obj + top.obj + report.json). Without shell.vtu the stretch is measured against the ideal
///   normal prisms of thickness eta, as `generate` does.
/// - a deform output folder (frame_NNNN/ subfolders): its last frame.
/// A detail.obj in the shell folder (embedded detail carried by deform) is drawn inside the shell.
/// - anything else: a surface file or builtin spec (gshell::load_mesh).
/// \throws InputError naming the input when it cannot be read (read_shell_folder, load_mesh).
RenderSubject load_render_subject(const std::string& input);

/// The value shown on base face f: the mean of its three tets' stretch weighted by their volumes
/// |det|/6 at X (tets 3f..3f+2 belong to face f). This is the prism's energy per volume, so the
/// colors add up to what the solver minimises. `tet_stretch` has one value per row of T.
/// \throws InputError unless X is n x 3, T is m x 4 with 3 rows per face and ids in [0, n), and
///         tet_stretch has one value per row of T.
Eigen::VectorXd face_stretch_from_tets(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T,
                                       const Eigen::VectorXd& tet_stretch);

/// Per-vertex thickness / eta as the report measures it (vertex_thickness: the distance of top
/// vertex i to the base surface on its side; 1 = the requested thickness).
/// \throws InputError when shell.thickness is not positive.
Eigen::VectorXd vertex_thickness_ratio(const Shell& shell);

/// Stretch drawn red by default: sum (sigma_i - 1)^2 = 0.1 is e.g. one singular value off by 0.32,
/// or all three by 0.18.
constexpr double kDefaultStretchMax = 0.1;
/// Thickness colors span 1 -/+ this by default (blue = half of eta, red = 1.5 eta).
constexpr double kDefaultThicknessSpread = 0.5;

enum class ColorBy { Auto, Stretch, Thickness, None }; ///< Auto: stretch when any input has it
enum class ShellStyle {
  Translucent, ///< opaque base, translucent top with the same colors
  Cut,         ///< both opaque, the half nearer the eye cut away by a plane through the box centre
  Base,        ///< base only
  Top          ///< top only
};

struct ShellRenderOptions {
  ColorBy color_by = ColorBy::Auto;
  ShellStyle style = ShellStyle::Translucent;
  /// Value shown red: stretch, or the largest |thickness/eta - 1| (thickness colors).
  /// 0 = the default: kDefaultStretchMax for stretch (absolute, so figures compare across runs),
  /// kDefaultThicknessSpread for thickness. Ignored when auto_max is set.
  double color_max = 0;
  /// Scale to the data instead, rounded up to 1, 2, 2.5 or 5 x 10^k. Stretch: the smallest of the
  /// panels' 99th percentiles (the best panel spans the ramp, worse ones turn red where they are
  /// worse). Thickness: the largest of the panels' 99th percentiles of |t - 1| (none saturates).
  bool auto_max = false;
  float top_opacity = 0.35f;
  FigureOptions figure; ///< size, view, projection, anti-aliasing
};

/// Default panel caption: "NAME (METHOD)" or just NAME, NAME being the input's last path component
/// (a deform frame: "RUN/frame_NNNN").
std::string default_caption(const RenderSubject& subject);

/// Renders the subjects side by side (captions: one per subject, or empty for the defaults).
/// \throws InputError when there are no subjects, the caption count does not match, or coloring by
///         stretch / thickness has no shell to take it from; or as render_figure.
/// `layout` (optional) receives where panels and color bar went, and the color scale used.
Image render_subjects(const std::vector<RenderSubject>& subjects, const std::vector<std::string>& captions,
                      const ShellRenderOptions& options, FigureLayout* layout = nullptr);

/// What a preview of an output folder shows (see render_shell_preview), with captions.
struct PreviewPanels {
  std::vector<RenderSubject> subjects;
  std::vector<std::string> captions;
  /// Why a pose folder's rest shell is not among the subjects (not found, unreadable, or another
  /// shell than the posed one's rest); empty otherwise.
  std::string note;
};
/// \throws InputError naming DIR or a file in it when it cannot be read (load_render_subject).
PreviewPanels preview_panels(const std::string& dir, const std::string& name = {});

/// Renders a shell folder written by generate / deform / pose to DIR/preview.png (1280x720,
/// iso view, colored by stretch; for a deform output: first, middle and last frame side by side;
/// for a pose output: the rest shell named in its report.json (stretch 0) beside the posed one).
/// Writes the PNG atomically. Returns the path written. Captions name the folder by its last
/// component, or by `name` when given (the final folder's name while DIR is a staging folder).
/// `view`: the direction every panel is seen from (default iso).
/// \throws InputError as preview_panels and render_subjects, or when the PNG cannot be written.
std::string render_shell_preview(const std::string& dir, const std::string& name = {}, const ViewDirection& view = {});

} // namespace gshell
