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

struct FigureOptions {
  int width = 1280, height = 720;           ///< the whole image, pixels
  ViewDirection view;                        ///< same direction for every panel
  Projection projection = Projection::Perspective;
  int supersample = 3;                       ///< anti-aliasing factor (see RenderOptions)
  std::optional<ColorScale> color_bar;       ///< drawn along the bottom when set
  std::string footnote;                      ///< small text at the bottom-left (e.g. how values were made)
};

/// Panels share the width equally and are framed one by one (each camera fits its own scene).
/// Text size grows with the image height. Throws InputError if the image is too small to hold them.
Image render_figure(const std::vector<Panel>& panels, const FigureOptions& options);

} // namespace gshell
