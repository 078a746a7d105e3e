#include <gshell/render/figure.h>

#include <gshell/error.h>
#include <gshell/render/annotate.h>

#include <algorithm>
#include <cmath>

namespace gshell {

int FigureLayout::color_bar_column(double value) const {
  if (!color_scale || color_bar.w <= 0) return color_bar.x;
  const double span = color_scale->max - color_scale->min;
  const double t = span > 0 ? std::clamp((value - color_scale->min) / span, 0.0, 1.0) : 0.0;
  return color_bar.x + static_cast<int>(std::lround(t * (color_bar.w - 1)));
}

Image render_figure(const std::vector<Panel>& panels, const FigureOptions& options, FigureLayout* layout) {
  if (panels.empty()) throw InputError("render: nothing to render");
  const int n = static_cast<int>(panels.size());
  // Text grows with the image, more slowly than it: 18 px line boxes at 400 px high, 26 at 720.
  const int text_size = std::clamp(static_cast<int>(std::lround(8 + options.height / 40.0)), 12, 64);
  const int small = std::max(10, text_size * 3 / 4); // footnote
  const int pad = std::max(2, text_size * 2 / 5);
  const bool any_caption = std::any_of(panels.begin(), panels.end(), [](const Panel& p) { return !p.caption.empty(); });
  const int caption_h = any_caption ? text_height(text_size) + 2 * pad : 0;
  const int bar_h = std::max(4, text_size / 2);
  const int bar_block = color_bar_height(bar_h, text_size);
  const int foot_block = options.footnote.empty() ? 0 : text_height(small) + pad / 2;
  const int bottom_h = (options.color_bar ? pad + bar_block : 0) + foot_block + (options.color_bar || foot_block ? pad / 2 : 0);
  const int panel_h = options.height - caption_h - bottom_h;
  const int panel_w = options.width / n;
  if (panel_w < 16 || panel_h < 16)
    throw InputError("render: image " + std::to_string(options.width) + "x" + std::to_string(options.height) +
                     " is too small for " + std::to_string(n) + " panel(s)");
  // The CLI's limit: 100000 x 100000 ran out of memory (std::bad_alloc) instead of saying so.
  if (options.width > kMaxFigureSide || options.height > kMaxFigureSide)
    throw InputError("render: image " + std::to_string(options.width) + "x" + std::to_string(options.height) +
                     " is larger than " + std::to_string(kMaxFigureSide) + " pixels on a side");

  Image figure(options.width, options.height);
  FigureLayout placed;
  Eigen::MatrixXd all_points;
  if (options.shared_camera) {
    std::vector<Eigen::MatrixXd> each;
    Eigen::Index rows = 0;
    for (const auto& panel : panels) {
      each.push_back(scene_points(panel.scene)); // without what a cut removes
      rows += each.back().rows();
    }
    all_points.resize(rows, 3);
    rows = 0;
    for (const auto& points : each) {
      all_points.middleRows(rows, points.rows()) = points;
      rows += points.rows();
    }
  }
  const Rgb8 ink{30, 30, 30};
  for (int i = 0; i < n; ++i) {
    const Panel& panel = panels[i];
    RenderOptions ro;
    ro.width = panel_w;
    ro.height = panel_h;
    ro.supersample = options.supersample;
    placed.panels.push_back({i * panel_w, caption_h, panel_w, panel_h});
    const Eigen::MatrixXd points = options.shared_camera ? all_points : scene_points(panel.scene);
    if (scene_points(panel.scene).rows() > 0) {
      const Camera camera = frame_camera(points, options.view, static_cast<double>(panel_w) / panel_h, options.projection);
      blit(figure, render_scene(panel.scene, camera, ro), i * panel_w, caption_h);
    }
    if (!panel.caption.empty()) {
      const std::string text = fit_text(panel.caption, text_size, panel_w - 2 * pad);
      draw_text(figure, i * panel_w + (panel_w - text_width(text, text_size)) / 2, pad, text, text_size, ink);
    }
    if (i > 0) figure.fill_rect(i * panel_w, caption_h, 1, panel_h, 200, 200, 200); // thin divider
  }
  const int bottom_y = caption_h + panel_h + pad;
  if (options.color_bar) {
    const int label_w = text_width(options.color_bar->label, text_size) + text_size / 2 + pad;
    const int bar_w = std::max(options.width / 3, 40);
    const int bar_x = std::max((options.width - bar_w) / 2, label_w + pad);
    placed.color_scale = options.color_bar;
    placed.color_bar = {bar_x, bottom_y, std::min(bar_w, options.width - bar_x - 4 * pad), bar_h};
    draw_color_bar(figure, bar_x, bottom_y, placed.color_bar.w, bar_h, *options.color_bar, text_size);
  }
  if (!options.footnote.empty()) {
    const int y = options.height - text_height(small) - pad / 2;
    draw_text(figure, pad, y, fit_text(options.footnote, small, options.width - 2 * pad), small, Rgb8{90, 90, 90});
  }
  if (layout) *layout = std::move(placed);
  return figure;
}

} // namespace gshell
