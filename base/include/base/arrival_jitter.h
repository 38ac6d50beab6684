// Interarrival jitter of RFC 3550 (section 6.4.1), the running estimate
// of how much the transit time (arrival minus send time) changes from one
// packet to the next: J += (|D| - J) / 16 with D the change in transit
// between consecutive packets in order of arrival. A constant clock offset
// between sender and receiver cancels in D.
#pragma once

#include <cmath>
#include <cstdint>
#include <utility>

namespace holofuse {

// Packets as (sent, received) in the order RFC 3550 takes them: by
// arrival, then by send time.
inline bool arrivedBefore(const std::pair<double, double>& a, const std::pair<double, double>& b) {
  return a.second != b.second ? a.second < b.second : a.first < b.first;
}

class ArrivalJitter {
 public:
  void add(double sent_ms, double received_ms) {
    const double transit = received_ms - sent_ms;
    if (packets_ > 0 && !fresh_)
      jitter_ms_ += (std::abs(transit - last_transit_ms_) - jitter_ms_) / 16.0;
    last_transit_ms_ = transit;
    fresh_ = false;
    ++packets_;
  }
  // The next packet has no previous transit to differ from (its sender
  // came back, maybe with another clock); the estimate and count stay.
  void restart() { fresh_ = true; }
  double ms() const { return jitter_ms_; }
  uint64_t packets() const { return packets_; }

 private:
  double jitter_ms_ = 0, last_transit_ms_ = 0;
  uint64_t packets_ = 0;
  bool fresh_ = false;
};

}  // namespace holofuse
