#include <gshell/render/image.h>

#include "render/box_filter.h"

#include <gshell/error.h>
#include <gshell/io/atomic_file.h>

#include <zlib.h>

#include <cstdlib>

// stb_image_write's own deflate is several times slower than zlib's; stb lets the caller plug in
// a compressor, so its PNG writer is compiled here (static, no clash with libstb) on top of zlib.
namespace {
unsigned char* zlib_compress_for_stb(unsigned char* data, int length, int* out_length, int /*stb_quality*/) {
  uLongf size = compressBound(static_cast<uLong>(length));
  auto* out = static_cast<unsigned char*>(std::malloc(size));
  if (!out) return nullptr;
  if (compress2(out, &size, data, static_cast<uLong>(length), Z_DEFAULT_COMPRESSION) != Z_OK) {
    std::free(out);
    return nullptr;
  }
  *out_length = static_cast<int>(size);
  return out;
}
} // namespace
#define STBIW_ZLIB_COMPRESS zlib_compress_for_stb
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#include <stb_image_write.h>
#pragma GCC diagnostic pop

#include <stb_image.h>

#include <algorithm>
#include <fstream>
#include <memory>
#include <sstream>
#include <ostream>
#include <stdexcept>

namespace gshell {

Image::Image(int w, int h, std::uint8_t r, std::uint8_t g, std::uint8_t b) : width(w), height(h) {
  if (w < 0 || h < 0) throw InputError("Image: width and height must be >= 0 (got " + std::to_string(w) + " x " + std::to_string(h) + ")");
  rgb.resize(static_cast<size_t>(w) * h * 3);
  for (size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = r;
    rgb[i + 1] = g;
    rgb[i + 2] = b;
  }
}

void Image::set(int x, int y, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  std::uint8_t* p = at(x, y);
  p[0] = r;
  p[1] = g;
  p[2] = b;
}

void Image::fill_rect(int x, int y, int w, int h, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  const int x0 = std::max(x, 0), y0 = std::max(y, 0);
  const int x1 = std::min(x + w, width), y1 = std::min(y + h, height);
  for (int yy = y0; yy < y1; ++yy)
    for (int xx = x0; xx < x1; ++xx) {
      std::uint8_t* p = at(xx, yy);
      p[0] = r;
      p[1] = g;
      p[2] = b;
    }
}

namespace detail {

void box_filter(const std::uint8_t* src, int src_width, int channels, int factor, Image& out) {
  const int n = factor * factor;
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      int sum[3] = {0, 0, 0};
      for (int dy = 0; dy < factor; ++dy) {
        const std::uint8_t* p =
            src + channels * (static_cast<std::size_t>(y * factor + dy) * src_width + static_cast<std::size_t>(x) * factor);
        for (int dx = 0; dx < factor; ++dx, p += channels) {
          sum[0] += p[0];
          sum[1] += p[1];
          sum[2] += p[2];
        }
      }
      std::uint8_t* q = out.at(x, y);
      for (int c = 0; c < 3; ++c) q[c] = static_cast<std::uint8_t>((sum[c] + n / 2) / n);
    }
}

} // namespace detail

Image downsample(const Image& image, int factor) {
  if (factor <= 1) return image;
  if (image.width % factor || image.height % factor)
    throw InputError("downsample: the image size " + std::to_string(image.width) + " x " +
                     std::to_string(image.height) + " is not a multiple of factor " + std::to_string(factor));
  Image out(image.width / factor, image.height / factor);
  detail::box_filter(image.rgb.data(), image.width, 3, factor, out);
  return out;
}

void blit(Image& dst, const Image& src, int x, int y) {
  for (int sy = 0; sy < src.height; ++sy) {
    const int dy = y + sy;
    if (dy < 0 || dy >= dst.height) continue;
    for (int sx = 0; sx < src.width; ++sx) {
      const int dx = x + sx;
      if (dx < 0 || dx >= dst.width) continue;
      std::copy_n(src.at(sx, sy), 3, dst.at(dx, dy));
    }
  }
}

std::string encode_png(const Image& image) {
  if (image.width <= 0 || image.height <= 0) throw InputError("encode_png: the image is empty");
  std::string bytes;
  auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<size_t>(size));
  };
  if (!stbi_write_png_to_func(append, &bytes, image.width, image.height, 3, image.rgb.data(), image.width * 3))
    throw std::runtime_error("PNG encoding failed");
  return bytes;
}

Image decode_png(const std::string& bytes, const std::string& what) {
  int w = 0, h = 0, channels = 0;
  std::unique_ptr<stbi_uc, void (*)(void*)> pixels(
      stbi_load_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()), static_cast<int>(bytes.size()), &w, &h,
                            &channels, 3),
      stbi_image_free);
  if (!pixels) throw InputError(with_file(what, std::string("cannot decode image: ") + stbi_failure_reason()));
  Image image(w, h);
  std::copy_n(pixels.get(), image.rgb.size(), image.rgb.data());
  return image;
}

Image read_png(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(with_file(path, "cannot open"));
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return decode_png(bytes.str(), path);
}

void write_png(const std::string& path, const Image& image) {
  const std::string bytes = encode_png(image);
  write_file_atomically(path, [&](std::ostream& out) { out.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); },
                        /*binary=*/true);
}

} // namespace gshell
