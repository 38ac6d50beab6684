#include "config/settings.h"

#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace holofuse {

std::string parseNumberIn(const std::string& text, double min, double max, double& out) {
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, out);
  if (error != std::errc() || stop != end || text.empty() || !(out >= min && out <= max)) {
    char range[96];
    std::snprintf(range, sizeof(range), "a number in [%g, %g]", min, max);
    return "'" + text + "' is not " + range;
  }
  return "";
}

std::string parseNumberIn(const std::string& text, double min, double max, uint64_t& out) {
  const char* end = text.data() + text.size();
  uint64_t v = 0;
  const auto [stop, error] = std::from_chars(text.data(), end, v);
  if (error != std::errc() || stop != end || text.empty() ||
      !(static_cast<double>(v) >= min && static_cast<double>(v) <= max)) {
    char range[96];
    if (max >= 18446744073709551615.0) {  // every uint64_t above min
      std::snprintf(range, sizeof(range), "a whole number, %.0f or more", min);
    } else {
      std::snprintf(range, sizeof(range), "a whole number in [%.0f, %.0f]", min, max);
    }
    return "'" + text + "' is not " + range;
  }
  out = v;
  return "";
}

std::string formatNumber(double v) {
  const bool single = static_cast<double>(static_cast<float>(v)) == v;
  char buffer[40];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buffer, sizeof(buffer), "%.*g", digits, v);
    // (20 as "20", not "2e+01")
    const bool exponent =
        std::strchr(buffer, 'e') != nullptr && std::abs(v) >= 1e-4 && std::abs(v) < 1e15;
    const double back = std::strtod(buffer, nullptr);
    if (exponent) continue;
    if (back == v || (single && static_cast<float>(back) == static_cast<float>(v))) break;
  }
  return buffer;
}

}  // namespace holofuse
