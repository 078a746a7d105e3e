#pragma once
// Text (stb_easy_font's bitmap font, scaled by whole pixels) and color bars drawn on images.
#include <gshell/render/color_map.h>
#include <gshell/render/image.h>

#include <cstdint>
#include <string>

namespace gshell {

struct Rgb8 {
  std::uint8_t r = 0, g = 0, b = 0;
};

/// Width and height in pixels of one line of `text` at `scale` (pixels per font pixel).
int text_width(const std::string& text, int scale);
int text_height(int scale);

/// Draws `text` with its top-left corner at (x, y); clipped to the image. ASCII only (other bytes show as ?).
void draw_text(Image& image, int x, int y, const std::string& text, int scale, Rgb8 color = {});

/// `text` shortened with "..." so that it is at most `max_width` pixels wide.
std::string fit_text(const std::string& text, int scale, int max_width);

/// A horizontal color bar in the rectangle (x, y, w, bar_h) with tick labels min / middle / max
/// below it and scale.label to its left. Returns the total height used.
int draw_color_bar(Image& image, int x, int y, int w, int bar_h, const ColorScale& scale, int text_scale);

} // namespace gshell
