#pragma once
// Internal: the box filter that anti-aliases supersampled renders, over any RGB(A) pixel rows
// (an Image, or the renderer's RGBA buffer without copying it into one first).
#include <gshell/render/image.h>

#include <cstdint>

namespace gshell::detail {

/// Pixel (x, y) of `out` <- the mean (rounded to nearest) of the factor x factor block of `src` at
/// (x * factor, y * factor). `src` holds rows of `src_width` pixels, top to bottom, `channels`
/// bytes per pixel with R, G, B first; it covers out.width * factor by out.height * factor pixels.
void box_filter(const std::uint8_t* src, int src_width, int channels, int factor, Image& out);

} // namespace gshell::detail
