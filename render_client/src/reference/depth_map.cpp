#include "render_client/reference/depth_map.h"

#include <algorithm>
#include <cmath>

namespace holofuse::render::reference {

std::vector<uint8_t> dilatedDiscontinuities(const DepthMap& map,
                                            const DiscontinuityOptions& options) {
  const int w = static_cast<int>(map.width), h = static_cast<int>(map.height);
  std::vector<uint8_t> edge(static_cast<size_t>(w) * h, 0);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double d = map.at(x, y);
      if (d == kNoDepth) continue;
      const int nx[4] = {x - 1, x + 1, x, x};
      const int ny[4] = {y, y, y - 1, y + 1};
      for (int k = 0; k < 4; ++k) {
        if (nx[k] < 0 || ny[k] < 0 || nx[k] >= w || ny[k] >= h) continue;
        const double e = map.at(nx[k], ny[k]);
        if (e == kNoDepth || std::abs(e - d) > options.relative_jump * std::min(d, e)) {
          edge[static_cast<size_t>(y) * w + x] = 1;
          break;
        }
      }
    }
  }
  const int r = options.dilation_px == kDilationScaledToWidth ? scaledDilationPx(w)
                                                              : std::max(0, options.dilation_px);
  std::vector<uint8_t> dilated(edge.size(), 0);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (!edge[static_cast<size_t>(y) * w + x]) continue;
      for (int dy = -r; dy <= r; ++dy) {
        for (int dx = -r; dx <= r; ++dx) {
          const int u = x + dx, v = y + dy;
          if (u < 0 || v < 0 || u >= w || v >= h) continue;
          dilated[static_cast<size_t>(v) * w + u] = 1;
        }
      }
    }
  }
  return dilated;
}

int scaledDilationPx(int image_width) {
  return std::max(0, static_cast<int>(std::lround(5.0 * image_width / 2048.0)) - 1);
}

}  // namespace holofuse::render::reference
