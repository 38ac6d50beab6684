// ClockSync: one connection's estimate of the peer's CLOCK_MONOTONIC
// against ours, from ClockProbe exchanges (since 1.8). Each exchange gives
// NTP's four timestamps (Mills, RFC 5905 section 8): t1 our send, t2 the
// peer's receive, t3 the peer's send, t4 our receive, and from them
//   offset = ((t2 - t1) + (t3 - t4)) / 2   (peer minus us)
//   delay  = (t4 - t1) - (t3 - t2)          (the round trip on the wire)
// The true offset lies within offset +- delay / 2 whatever the asymmetry
// of the two ways, so the sample with the smallest delay of the last few
// is the one kept (RFC 5905's clock filter). A burst of probes follows
// the handshake (NTP's iburst) so the first estimate is there before the
// first frame; then one probe per interval follows the drift.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>

#include "protocol/messages.h"

namespace holofuse::protocol {

struct ClockSyncOptions {
  uint32_t interval_ms = 1000;  // between probes after the burst
  uint32_t burst = 4;           // probes back to back after the handshake
  size_t window = 8;            // samples the filter picks the smallest delay from
  // A probe unanswered for this long is given up (a new one may go).
  uint32_t reply_timeout_ms = 2000;
};

class ClockSync {
 public:
  explicit ClockSync(ClockSyncOptions options = {}) : options_(options) {}

  // The request to send now, if one is due: none while one is in flight,
  // `burst` back to back at first, then one per interval.
  std::optional<ClockProbe> probeDue(uint64_t now_ns);
  // A reply arrived at now_ns. A reply that does not answer our probe in
  // flight, or whose timestamps are impossible (the peer answered before
  // it received, or the round trip is negative), is refused by name and
  // changes nothing.
  Status onReply(const ClockProbe& reply, uint64_t now_ns);
  // The answer to a peer's request that arrived at received_ns.
  static ClockProbe answer(const ClockProbe& request, uint64_t received_ns, uint64_t now_ns);

  bool known() const { return best_.has_value(); }
  // Peer minus ours, in ns (0 until known).
  int64_t offsetNs() const { return best_ ? best_->offset_ns : 0; }
  // Half the round trip of the sample the offset came from (0 until known).
  uint64_t uncertaintyNs() const { return best_ ? (best_->delay_ns + 1) / 2 : 0; }
  uint64_t roundTripNs() const { return best_ ? best_->delay_ns : 0; }
  uint64_t samples() const { return samples_; }
  // How far the estimate moved since the first one after the burst, and
  // whether that move exceeds threshold_ns beyond both estimates'
  // uncertainty (a clock that drifts, not a noisy sample).
  int64_t driftNs() const;
  // The estimate once the burst was in (the current one until then).
  int64_t firstOffsetNs() const { return first_ ? first_->offset_ns : offsetNs(); }
  uint64_t firstUncertaintyNs() const {
    return first_ ? (first_->delay_ns + 1) / 2 : uncertaintyNs();
  }
  bool drifted(uint64_t threshold_ns) const;
  // A time on the peer's clock read on ours, and the reverse.
  uint64_t toLocal(uint64_t peer_ns) const;
  uint64_t toPeer(uint64_t local_ns) const;
  // "+5000.012 ms +- 0.084 ms" (or "not measured").
  std::string describe() const;

 private:
  struct Sample {
    int64_t offset_ns = 0;
    uint64_t delay_ns = 0;
  };
  ClockSyncOptions options_;
  std::deque<Sample> window_;
  std::optional<Sample> best_;
  std::optional<Sample> first_;  // the estimate once the burst is in
  std::optional<uint64_t> in_flight_origin_;
  uint64_t in_flight_since_ns_ = 0;
  uint64_t last_probe_ns_ = 0;
  uint64_t samples_ = 0;
  uint32_t sent_ = 0;
};

// Shifts every stamp, a time on some host's clock, onto ours by offset_ns
// (that host's clock minus ours).
void shiftStamps(std::vector<StageStamp>& stamps, int64_t offset_ns);
uint64_t shiftedNs(uint64_t ns, int64_t offset_ns);

}  // namespace holofuse::protocol
