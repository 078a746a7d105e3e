#pragma once
// Several rendered panels side by side, each with a caption, and an optional shared color bar.
#include <gshell/render/camera.h>
#include <gshell/render/color_map.h>
#include <gshell/render/image.h>
#include <gshell/render/scene.h>

#include <optional>
#include <string>
#include <vector>

namespace gshell {

struct Panel {
  Scene scene;
  std::string caption;
};

/// The largest figure side, pixels (the CLI's --size limit): larger ones are an InputError.
constexpr int kMaxFigureSide = 8192;

struct FigureOptions {
  int width = 1280, height = 720;           ///< the whole image, pixels, each at most kMaxFigureSide
  ViewDirection view;                        ///< same direction for every panel
  Projection projection = Projection::Perspective;
  int supersample = 2;                       ///< anti-aliasing factor (see RenderOptions)
  std::optional<ColorScale> color_bar;       ///< drawn along the bottom when set
  std::string footnote;                      ///< small text at the bottom-left (e.g. how values were made)
  /// One camera framing all panels together, so they show at the same scale (before/after,
  /// method A/B). False: each panel is framed on its own scene.
  bool shared_camera = true;
};

/// Where render_figure put things, in pixels (x, y = top-left corner).
struct PixelRect {
  int x = 0, y = 0, w = 0, h = 0;
};
struct FigureLayout {
  std::vector<PixelRect> panels; ///< the rendered area of each panel (below its caption)
  PixelRect color_bar;           ///< the gradient itself (w = 0 when there is none); min at x, max at x + w - 1
  std::optional<ColorScale> color_scale; ///< the scale of the bar

  /// Pixel column of `value` on the color bar (clamped to it).
  int color_bar_column(double value) const;
};

/// Panels share the width equally; the camera frames all of them together or each on its own
/// (FigureOptions::shared_camera).
/// Text size grows with the image height.
/// \throws InputError when there are no panels, the image is too small to hold them, or as
///         render_scene.
Image render_figure(const std::vector<Panel>& panels, const FigureOptions& options, FigureLayout* layout = nullptr);

} // namespace gshell
