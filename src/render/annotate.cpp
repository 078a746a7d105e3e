#include <gshell/render/annotate.h>

#include <gshell/error.h>

#include "io/utf8_code_points.h"

#include <stb_truetype.h> // implementation in Debian's libstb

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <vector>

namespace gshell {

namespace detail {
// DejaVu Sans, compiled in at build time (cmake/embed_file.cmake): renders need no font file at
// run time, wherever the library or a program using it is installed, and look the same everywhere.
extern const unsigned char caption_font[];
extern const std::size_t caption_font_size;
} // namespace detail

namespace {

const stbtt_fontinfo& font() {
  static const stbtt_fontinfo info = [] {
    stbtt_fontinfo f;
    if (!stbtt_InitFont(&f, detail::caption_font, stbtt_GetFontOffsetForIndex(detail::caption_font, 0)))
      throw std::runtime_error("the compiled-in caption font cannot be read");
    return f;
  }();
  return info;
}

// One line of text laid out at `size`: glyphs at fractional pen positions from x = 0 on the
// baseline, and the horizontal extent of everything drawn (advances and ink).
struct LineLayout {
  float scale = 0;    // font units -> pixels
  int ascent = 0;     // baseline below the top of the line box, pixels
  struct Glyph {
    int index;
    float x;
  };
  std::vector<Glyph> glyphs;
  float left = 0, right = 0;
};

LineLayout layout(const std::string& text, int size) {
  const stbtt_fontinfo& f = font();
  LineLayout line;
  line.scale = stbtt_ScaleForPixelHeight(&f, static_cast<float>(size));
  int ascent = 0, descent = 0, gap = 0;
  stbtt_GetFontVMetrics(&f, &ascent, &descent, &gap);
  line.ascent = static_cast<int>(std::lround(ascent * line.scale));
  float pen = 0;
  int previous = -1;
  for (int cp : utf8_code_points(text)) {
    const int glyph = stbtt_FindGlyphIndex(&f, cp);
    if (previous >= 0) pen += line.scale * static_cast<float>(stbtt_GetGlyphKernAdvance(&f, previous, glyph));
    int advance = 0, bearing = 0;
    stbtt_GetGlyphHMetrics(&f, glyph, &advance, &bearing);
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    stbtt_GetGlyphBitmapBoxSubpixel(&f, glyph, line.scale, line.scale, pen - std::floor(pen), 0, &x0, &y0, &x1, &y1);
    if (x1 > x0) {
      line.left = std::min(line.left, std::floor(pen) + static_cast<float>(x0));
      line.right = std::max(line.right, std::floor(pen) + static_cast<float>(x1));
    }
    line.glyphs.push_back({glyph, pen});
    pen += line.scale * static_cast<float>(advance);
    previous = glyph;
  }
  line.right = std::max(line.right, pen);
  return line;
}

int color_bar_tick(int bar_h) { return std::max(2, bar_h / 3); }     // tick length below the bar
int color_bar_gap(int text_size) { return std::max(1, text_size / 8); } // between ticks and labels

} // namespace

int text_width(const std::string& text, int size) {
  const LineLayout line = layout(text, size);
  return static_cast<int>(std::ceil(line.right - line.left));
}

int text_height(int size) { return size; }

void draw_text(Image& image, int x, int y, const std::string& text, int size, Rgb8 color) {
  const stbtt_fontinfo& f = font();
  const LineLayout line = layout(text, size);
  const float origin = static_cast<float>(x) - line.left; // so that the ink starts at x
  const int baseline = y + line.ascent;
  std::vector<unsigned char> coverage;
  for (const auto& g : line.glyphs) {
    const float pen = origin + g.x, shift = pen - std::floor(pen);
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    stbtt_GetGlyphBitmapBoxSubpixel(&f, g.index, line.scale, line.scale, shift, 0, &x0, &y0, &x1, &y1);
    const int w = x1 - x0, h = y1 - y0;
    if (w <= 0 || h <= 0) continue;
    coverage.assign(static_cast<std::size_t>(w) * h, 0);
    stbtt_MakeGlyphBitmapSubpixel(&f, coverage.data(), w, h, w, line.scale, line.scale, shift, 0, g.index);
    const int gx = static_cast<int>(std::floor(pen)) + x0, gy = baseline + y0;
    for (int j = 0; j < h; ++j) {
      const int py = gy + j;
      if (py < 0 || py >= image.height) continue;
      for (int i = 0; i < w; ++i) {
        const int px = gx + i;
        const int a = coverage[static_cast<std::size_t>(j) * w + i];
        if (px < 0 || px >= image.width || a == 0) continue;
        std::uint8_t* p = image.at(px, py);
        const std::uint8_t ink[3] = {color.r, color.g, color.b};
        for (int c = 0; c < 3; ++c) p[c] = static_cast<std::uint8_t>((p[c] * (255 - a) + ink[c] * a + 127) / 255);
      }
    }
  }
}

std::string fit_text(const std::string& text, int size, int max_width) {
  if (text_width(text, size) <= max_width) return text;
  std::string shortened = text;
  const std::string ellipsis = "\u2026";
  while (!shortened.empty() && text_width(shortened + ellipsis, size) > max_width) {
    shortened.pop_back();
    while (!shortened.empty() && (static_cast<unsigned char>(shortened.back()) >> 6) == 0x2)
      shortened.pop_back(); // never cut inside a UTF-8 sequence
    if (!shortened.empty() && static_cast<unsigned char>(shortened.back()) >= 0xC0) shortened.pop_back();
  }
  return shortened.empty() ? std::string() : shortened + ellipsis;
}

int draw_color_bar(Image& image, int x, int y, int w, int bar_h, const ColorScale& scale, int text_size) {
  if (w <= 0 || bar_h <= 0) return 0;
  for (int i = 0; i < w; ++i) {
    const Eigen::Vector3f c = scale.ramp_color(w > 1 ? static_cast<double>(i) / (w - 1) : 0.0);
    image.fill_rect(x + i, y, 1, bar_h, static_cast<std::uint8_t>(std::lround(255 * c.x())),
                    static_cast<std::uint8_t>(std::lround(255 * c.y())), static_cast<std::uint8_t>(std::lround(255 * c.z())));
  }
  const Rgb8 ink{40, 40, 40};
  // Frame and ticks.
  image.fill_rect(x - 1, y - 1, w + 2, 1, ink.r, ink.g, ink.b);
  image.fill_rect(x - 1, y + bar_h, w + 2, 1, ink.r, ink.g, ink.b);
  image.fill_rect(x - 1, y - 1, 1, bar_h + 2, ink.r, ink.g, ink.b);
  image.fill_rect(x + w, y - 1, 1, bar_h + 2, ink.r, ink.g, ink.b);
  const int tick = color_bar_tick(bar_h), gap = color_bar_gap(text_size);
  const double values[3] = {scale.min, 0.5 * (scale.min + scale.max), scale.max};
  const int label_y = y + bar_h + tick + gap;
  for (int k = 0; k < 3; ++k) {
    const int tx = x + (k * (w - 1)) / 2;
    image.fill_rect(tx, y + bar_h, std::max(1, text_size / 12), tick, ink.r, ink.g, ink.b);
    // The ends saturate: values beyond them get the end colors, so say so.
    const bool two_sided = scale.ramp == ColorScale::Ramp::BlueGreenRed;
    const std::string label = (k == 2 ? "\u2265 " : k == 0 && two_sided ? "\u2264 " : "") + format_number(values[k]);
    const int lw = text_width(label, text_size);
    draw_text(image, std::clamp(tx - lw / 2, 0, std::max(0, image.width - lw)), label_y, label, text_size, ink);
  }
  const int name_w = text_width(scale.label, text_size);
  draw_text(image, x - name_w - text_size / 2, y + (bar_h - text_height(text_size)) / 2, scale.label, text_size, ink);
  return color_bar_height(bar_h, text_size);
}

int color_bar_height(int bar_h, int text_size) {
  return bar_h + color_bar_tick(bar_h) + color_bar_gap(text_size) + text_height(text_size);
}

} // namespace gshell
