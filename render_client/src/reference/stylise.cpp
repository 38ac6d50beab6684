#include "render_client/reference/stylise.h"

#include <algorithm>
#include <cmath>

#include "shaders/config.h"

namespace holofuse::render::reference {

float stippleRandom(uint32_t x, uint32_t y) {
  uint32_t h = (x * 0x8da6b343u) ^ (y * 0xd8163841u);
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return static_cast<float>(h >> 8) * (1.0f / 16777216.0f);
}

namespace {

float luminance(const float c[3]) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; }

}  // namespace

Image8 stipple(const Image8& picture) {
  Image8 out = picture;
  if (picture.channels != 4) return out;
  const int w = static_cast<int>(picture.width), h = static_cast<int>(picture.height);
  auto at = [&](int x, int y, int c) {
    return static_cast<float>(picture.pixels[4 * (static_cast<size_t>(y) * w + x) + c]) / 255.0f;
  };
  constexpr int r = HOLOFUSE_STIPPLE_RADIUS;
  constexpr float taps = static_cast<float>((2 * r + 1) * (2 * r + 1));
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (picture.pixels[4 * (static_cast<size_t>(y) * w + x) + 3] == 0) continue;
      float blurred[3] = {0, 0, 0};
      for (int dy = -r; dy <= r; ++dy) {
        for (int dx = -r; dx <= r; ++dx) {
          const int sx = std::clamp(x + dx, 0, w - 1), sy = std::clamp(y + dy, 0, h - 1);
          for (int c = 0; c < 3; ++c) blurred[c] += at(sx, sy, c);
        }
      }
      for (float& b : blurred) b /= taps;
      const bool stippled = stippleRandom(static_cast<uint32_t>(x), static_cast<uint32_t>(y)) <
                            1.0f - luminance(blurred);
      float dodged[3];
      for (int c = 0; c < 3; ++c) {
        const float dotted = std::min(
            blurred[c] * (stippled ? 1.0f + static_cast<float>(HOLOFUSE_STIPPLE_STRENGTH) : 1.0f),
            1.0f);
        dodged[c] = std::clamp(at(x, y, c) / std::max(dotted, 1.0f / 255.0f), 0.0f, 1.0f);
      }
      const float grey = std::pow(luminance(dodged), static_cast<float>(HOLOFUSE_STIPPLE_CONTRAST));
      const auto level = static_cast<uint8_t>(std::lround(std::clamp(grey, 0.0f, 1.0f) * 255.0f));
      for (int c = 0; c < 3; ++c) out.pixels[4 * (static_cast<size_t>(y) * w + x) + c] = level;
    }
  }
  return out;
}

}  // namespace holofuse::render::reference
