#pragma once
/// An 8-bit raster image, the currency of render.h, png.h and html_report.h.

#include <cstdint>
#include <vector>

namespace tet2spline {

/// Row-major, top row first, channels interleaved (RGB or RGBA, 8 bits each).
struct Image {
  int width = 0;
  int height = 0;
  int channels = 3;             ///< 3 (RGB) or 4 (RGBA)
  std::vector<uint8_t> pixels;  ///< height × width × channels

  Image() = default;
  Image(int w, int h, int c = 3) : width(w), height(h), channels(c), pixels(size_t(w) * size_t(h) * size_t(c), 0) {}
  bool empty() const { return width <= 0 || height <= 0; }
  uint8_t* at(int x, int y) { return pixels.data() + (size_t(y) * size_t(width) + size_t(x)) * size_t(channels); }
  const uint8_t* at(int x, int y) const {
    return pixels.data() + (size_t(y) * size_t(width) + size_t(x)) * size_t(channels);
  }
};

/// An sRGB colour, 8 bits per channel.
struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
  friend bool operator==(const Rgb& a, const Rgb& b) { return a.r == b.r && a.g == b.g && a.b == b.b; }
  friend bool operator!=(const Rgb& a, const Rgb& b) { return !(a == b); }
};

}  // namespace tet2spline
