// Wall-clock helpers the plain benchmark programs share.
#pragma once

#include <algorithm>
#include <chrono>
#include <vector>

namespace holofuse::bench {

using Clock = std::chrono::steady_clock;

inline double ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// The median, robust to the shared machine's outliers; 0 when empty.
inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

}  // namespace holofuse::bench
