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
  uint8_t* at(uint32_t x, uint32_t y) { return pixels.data() + (static_cast<size_t>(y) * width + x) * channels; }
  const uint8_t* at(uint32_t x, uint32_t y) const {
    return pixels.data() + (static_cast<size_t>(y) * width + x) * channels;
  }
  bool empty() const { return pixels.empty(); }
};

}  // namespace holofuse
