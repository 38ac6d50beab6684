// 8-bit interleaved image, the one pixel container of the loop.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace holofuse {

struct Image8 {
  uint32_t width = 0, height = 0, channels = 0;
  std::vector<uint8_t> pixels;  // row major, channels interleaved

  Image8() = default;
  Image8(uint32_t w, uint32_t h, uint32_t c, uint8_t fill = 0)
      : width(w), height(h), channels(c), pixels(static_cast<size_t>(w) * h * c, fill) {}
  uint8_t* at(uint32_t x, uint32_t y) {
    return pixels.data() + (static_cast<size_t>(y) * width + x) * channels;
  }
  const uint8_t* at(uint32_t x, uint32_t y) const {
    return pixels.data() + (static_cast<size_t>(y) * width + x) * channels;
  }
  bool empty() const { return pixels.empty(); }
};

}  // namespace holofuse

namespace holofuse {

// A pixel rectangle: x, y of its top-left pixel, then its size.
struct PixelRect {
  uint32_t x = 0, y = 0, width = 0, height = 0;
  bool empty() const { return width == 0 || height == 0; }
};

// The smallest rectangle holding every non-zero pixel of a one-channel
// mask, grown by margin on every side and clipped to the image; empty when
// the mask has no foreground.
PixelRect foregroundRect(const Image8& mask, uint32_t margin = 0);

// The pixels of image inside rect (which must lie inside the image).
Image8 cropImage(const Image8& image, const PixelRect& rect);

// A width x height image, zero everywhere but for `crop` placed with its
// top-left pixel at (x, y) (the crop must fit).
Image8 placeInFrame(const Image8& crop, uint32_t x, uint32_t y, uint32_t width, uint32_t height);

// Whether a w x h crop at (x, y) lies inside a width x height frame,
// without overflow for any 32-bit input.
inline bool cropFits(uint64_t x, uint64_t y, uint64_t w, uint64_t h, uint64_t width,
                     uint64_t height) {
  return x + w <= width && y + h <= height;
}

}  // namespace holofuse
