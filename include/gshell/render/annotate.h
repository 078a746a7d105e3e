#pragma once
// Text and color bars drawn on images. Text is set in DejaVu Sans (a TrueType font compiled into
// the library, rasterised by stb_truetype, anti-aliased), UTF-8, one line at a time.
#include <gshell/render/color_map.h>
#include <gshell/render/image.h>

#include <cstdint>
#include <string>

namespace gshell {

struct Rgb8 {
  std::uint8_t r = 0, g = 0, b = 0;
};

/// Text sizes are the height of the line box in pixels (ascender to descender: every glyph of
/// the font fits; capitals are about 0.63 of it).
/// Width in pixels of one line of `text` (everything drawn lies within it) and the line box's height.
int text_width(const std::string& text, int size);
int text_height(int size);

/// Draws `text` (UTF-8; characters the font lacks show as its replacement box) with the top-left
/// corner of its box at (x, y), blended over the image by coverage; clipped to the image.
void draw_text(Image& image, int x, int y, const std::string& text, int size, Rgb8 color = {});

/// `text` shortened with an ellipsis so that it is at most `max_width` pixels wide.
std::string fit_text(const std::string& text, int size, int max_width);

/// A horizontal color bar in the rectangle (x, y, w, bar_h) with tick labels min / middle / max
/// below it and scale.label to its left, in text of `text_size`. Returns the height used below y
/// (color_bar_height).
int draw_color_bar(Image& image, int x, int y, int w, int bar_h, const ColorScale& scale, int text_size);
int color_bar_height(int bar_h, int text_size);

} // namespace gshell
