#include "base/statistics.h"

#include <algorithm>

#include "base/arrival_jitter.h"

namespace holofuse {

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double rank = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(values.size() - 1);
  const size_t lo = static_cast<size_t>(rank);
  const size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (rank - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

double interarrivalJitter(std::vector<std::pair<double, double>> sent_and_received) {
  // In order of arrival, as RFC 3550 (and the server) takes them.
  std::sort(sent_and_received.begin(), sent_and_received.end(), arrivedBefore);
  ArrivalJitter jitter;
  for (const auto& [sent, received] : sent_and_received) jitter.add(sent, received);
  return jitter.ms();
}

}  // namespace holofuse
