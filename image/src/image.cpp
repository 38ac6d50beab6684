#include "image/image.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace holofuse {

PixelRect foregroundRect(const Image8& mask, uint32_t margin) {
  uint32_t x0 = mask.width, y0 = mask.height, x1 = 0, y1 = 0;
  bool any = false;
  for (uint32_t y = 0; y < mask.height; ++y) {
    const uint8_t* row = mask.at(0, y);
    for (uint32_t x = 0; x < mask.width; ++x) {
      if (row[x * mask.channels] == 0) continue;
      any = true;
      x0 = std::min(x0, x);
      y0 = std::min(y0, y);
      x1 = std::max(x1, x);
      y1 = std::max(y1, y);
    }
  }
  if (!any) return {};
  x0 = x0 > margin ? x0 - margin : 0;
  y0 = y0 > margin ? y0 - margin : 0;
  x1 = std::min<uint64_t>(uint64_t{x1} + margin, mask.width - 1);
  y1 = std::min<uint64_t>(uint64_t{y1} + margin, mask.height - 1);
  return {x0, y0, x1 - x0 + 1, y1 - y0 + 1};
}

Image8 cropImage(const Image8& image, const PixelRect& rect) {
  if (!cropFits(rect.x, rect.y, rect.width, rect.height, image.width, image.height)) {
    throw std::invalid_argument("crop outside the image");
  }
  Image8 out(rect.width, rect.height, image.channels);
  const size_t row_bytes = size_t{rect.width} * image.channels;
  for (uint32_t y = 0; y < rect.height; ++y)
    std::memcpy(out.at(0, y), image.at(rect.x, rect.y + y), row_bytes);
  return out;
}

Image8 placeInFrame(const Image8& crop, uint32_t x, uint32_t y, uint32_t width, uint32_t height) {
  if (!cropFits(x, y, crop.width, crop.height, width, height))
    throw std::invalid_argument("crop outside the frame");
  Image8 out(width, height, crop.channels);
  const size_t row_bytes = size_t{crop.width} * crop.channels;
  for (uint32_t r = 0; r < crop.height; ++r)
    std::memcpy(out.at(x, y + r), crop.at(0, r), row_bytes);
  return out;
}

}  // namespace holofuse
