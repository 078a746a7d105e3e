#include <gshell/render/annotate.h>

// stb_easy_font defines all of its functions static; not every one is used here.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#include <stb_easy_font.h>
#pragma GCC diagnostic pop

#include <algorithm>
#include <cmath>
#include <vector>

namespace gshell {
namespace {

// stb_easy_font's glyphs are about 7 font pixels high above the baseline; a line is 12 apart,
// but captions look best with a tighter box.
constexpr int kLineHeight = 10;

struct FontVertex {
  float x, y, z;
  unsigned char color[4];
};

} // namespace

int text_width(const std::string& text, int scale) {
  std::vector<char> copy(text.begin(), text.end());
  copy.push_back('\0');
  return stb_easy_font_width(copy.data()) * scale;
}

int text_height(int scale) { return kLineHeight * scale; }

void draw_text(Image& image, int x, int y, const std::string& text, int scale, Rgb8 color) {
  std::vector<char> copy;
  for (unsigned char c : text) copy.push_back(c >= 32 && c < 127 ? static_cast<char>(c) : '?'); // the font is ASCII
  copy.push_back('\0');
  std::vector<FontVertex> quads(4 * (text.size() * 60 + 16)); // ~270 bytes per character, generous
  const int count = stb_easy_font_print(0, 0, copy.data(), nullptr, quads.data(),
                                        static_cast<int>(quads.size() * sizeof(FontVertex)));
  for (int q = 0; q < count; ++q) {
    float x0 = quads[4 * q].x, y0 = quads[4 * q].y, x1 = x0, y1 = y0;
    for (int k = 1; k < 4; ++k) {
      x0 = std::min(x0, quads[4 * q + k].x);
      x1 = std::max(x1, quads[4 * q + k].x);
      y0 = std::min(y0, quads[4 * q + k].y);
      y1 = std::max(y1, quads[4 * q + k].y);
    }
    const int px = x + static_cast<int>(std::lround(x0 * scale)), py = y + static_cast<int>(std::lround(y0 * scale));
    const int pw = static_cast<int>(std::lround((x1 - x0) * scale)), ph = static_cast<int>(std::lround((y1 - y0) * scale));
    image.fill_rect(px, py, pw, ph, color.r, color.g, color.b);
  }
}

std::string fit_text(const std::string& text, int scale, int max_width) {
  if (text_width(text, scale) <= max_width) return text;
  std::string shortened = text;
  while (!shortened.empty() && text_width(shortened + "...", scale) > max_width) shortened.pop_back();
  return shortened.empty() ? std::string() : shortened + "...";
}

int draw_color_bar(Image& image, int x, int y, int w, int bar_h, const ColorScale& scale, int text_scale) {
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
  const int tick = std::max(2, bar_h / 3);
  const double values[3] = {scale.min, 0.5 * (scale.min + scale.max), scale.max};
  const int label_y = y + bar_h + tick + text_scale;
  for (int k = 0; k < 3; ++k) {
    const int tx = x + (k * (w - 1)) / 2;
    image.fill_rect(tx, y + bar_h, std::max(1, text_scale / 2), tick, ink.r, ink.g, ink.b);
    // The ends saturate: values beyond them get the end colors, so say so.
    const bool two_sided = scale.ramp == ColorScale::Ramp::BlueGreenRed;
    const std::string label = (k == 2 ? ">=" : k == 0 && two_sided ? "<=" : "") + format_number(values[k]);
    const int lw = text_width(label, text_scale);
    draw_text(image, std::clamp(tx - lw / 2, 0, std::max(0, image.width - lw)), label_y, label, text_scale, ink);
  }
  const int name_w = text_width(scale.label, text_scale);
  draw_text(image, x - name_w - 4 * text_scale, y + (bar_h - text_height(text_scale)) / 2 + text_scale, scale.label,
            text_scale, ink);
  return bar_h + tick + text_scale + text_height(text_scale);
}

} // namespace gshell
