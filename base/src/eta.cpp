#include "base/eta.h"

#include <algorithm>
#include <cmath>

namespace holofuse {

std::string Eta::text(size_t left) const {
  return textOfShares(static_cast<double>(steps_), static_cast<double>(left));
}

std::string Eta::textOfShares(double done, double left) const {
  if (!(done > 0)) return "";
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  return text(seconds / done * std::max(left, 0.0), size_t{1});
}

std::string Eta::text(double seconds_per_step, size_t left) {
  const long total = std::lround(seconds_per_step * static_cast<double>(left));
  const long hours = total / 3600, minutes = total % 3600 / 60, seconds = total % 60;
  if (hours > 0) return "ETA " + std::to_string(hours) + " h " + std::to_string(minutes) + " min";
  if (minutes > 0)
    return "ETA " + std::to_string(minutes) + " min " + std::to_string(seconds) + " s";
  return "ETA " + std::to_string(seconds) + " s";
}

std::string Eta::countOf(size_t done, size_t total, double per_second) {
  if (total == 0) return std::to_string(done);
  std::string count = std::to_string(done) + "/" + std::to_string(total);
  if (done < total && per_second > 0) count += " (" + text(1.0 / per_second, total - done) + ")";
  return count;
}

}  // namespace holofuse
