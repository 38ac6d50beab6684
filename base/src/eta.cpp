#include "base/eta.h"

#include <cmath>

namespace holofuse {

std::string Eta::text(size_t left) const {
  if (steps_ == 0) return "";
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  return text(seconds / static_cast<double>(steps_), left);
}

std::string Eta::text(double seconds_per_step, size_t left) {
  const long total = std::lround(seconds_per_step * static_cast<double>(left));
  const long hours = total / 3600, minutes = total % 3600 / 60, seconds = total % 60;
  if (hours > 0) return "ETA " + std::to_string(hours) + " h " + std::to_string(minutes) + " min";
  if (minutes > 0)
    return "ETA " + std::to_string(minutes) + " min " + std::to_string(seconds) + " s";
  return "ETA " + std::to_string(seconds) + " s";
}

}  // namespace holofuse
