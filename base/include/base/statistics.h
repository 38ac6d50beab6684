// The statistics every report takes the same way (the live loop's, the
// evaluation's, the sweep's), so that their numbers compare.
#pragma once

#include <utility>
#include <vector>

namespace holofuse {

// p in [0, 100]; linear interpolation between order statistics. 0 for none.
double percentile(std::vector<double> values, double p);

// Interarrival jitter of RFC 3550 (base/arrival_jitter.h) over packets
// taken in order of arrival (a client learns of them out of order); in the
// unit of the times given, as (sent, received) pairs.
double interarrivalJitter(std::vector<std::pair<double, double>> sent_and_received);

}  // namespace holofuse
