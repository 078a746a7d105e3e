#pragma once
// 8-bit RGB images: what the renderer produces, the annotator draws on and the PNG writer saves.
#include <cstdint>
#include <string>
#include <vector>

namespace gshell {

/// An RGB image, rows top to bottom, 3 bytes per pixel.
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb; ///< width * height * 3 bytes

  Image() = default;
  /// \throws InputError when w or h is negative.
  Image(int w, int h, std::uint8_t r = 255, std::uint8_t g = 255, std::uint8_t b = 255);
  std::uint8_t* at(int x, int y) { return rgb.data() + 3 * (static_cast<size_t>(y) * width + x); }
  const std::uint8_t* at(int x, int y) const { return rgb.data() + 3 * (static_cast<size_t>(y) * width + x); }
  void set(int x, int y, std::uint8_t r, std::uint8_t g, std::uint8_t b);
  void fill_rect(int x, int y, int w, int h, std::uint8_t r, std::uint8_t g, std::uint8_t b); ///< clipped
};

/// Box-filters `factor` x `factor` blocks into one pixel (the anti-aliasing of supersampled renders).
/// \throws InputError unless width and height are multiples of `factor` (factor <= 1: a copy).
Image downsample(const Image& image, int factor);

/// Copies `src` into `dst` with its top-left corner at (x, y), clipped to `dst`.
void blit(Image& dst, const Image& src, int x, int y);

/// PNG file bytes (stb_image_write).
/// \throws InputError on an empty image; std::runtime_error if the encoder fails (out of memory).
std::string encode_png(const Image& image);

/// Decodes PNG (or any format stb_image reads) bytes to RGB.
/// \throws InputError naming `what` when the bytes cannot be decoded.
Image decode_png(const std::string& bytes, const std::string& what = "image");

/// Reads an image file.
/// \throws InputError naming `path` if it cannot be read or decoded.
Image read_png(const std::string& path);

/// Writes a PNG atomically.
/// \throws InputError naming `path` if it cannot be written (nothing is left behind), or as
///         encode_png.
void write_png(const std::string& path, const Image& image);

} // namespace gshell
