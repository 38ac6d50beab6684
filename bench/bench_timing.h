// Wall-clock helpers the plain benchmark programs share.
#pragma once

#include <algorithm>
#include <chrono>
#include <utility>
#include <vector>

namespace holofuse::bench {

using Clock = std::chrono::steady_clock;

inline double ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// The sorted values' element at index floor(q * n), q in 0..1 (q = 0.5:
// the median below); 0 when empty.
inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t at = static_cast<size_t>(std::clamp(q, 0.0, 1.0) * static_cast<double>(v.size()));
  return v[std::min(at, v.size() - 1)];
}

// The median, robust to the shared machine's outliers; 0 when empty.
inline double median(std::vector<double> v) { return quantile(std::move(v), 0.5); }

}  // namespace holofuse::bench
