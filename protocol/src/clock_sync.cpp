#include "protocol/clock_sync.h"

#include <cstdio>
#include <cstdlib>

namespace holofuse::protocol {

std::optional<ClockProbe> ClockSync::probeDue(uint64_t now_ns) {
  if (in_flight_origin_) {
    if (now_ns - in_flight_since_ns_ < uint64_t{options_.reply_timeout_ms} * 1000000) return {};
    in_flight_origin_.reset();  // lost with a reconnect or never answered: probe afresh
  }
  const bool bursting = sent_ < options_.burst;
  if (!bursting && now_ns - last_probe_ns_ < uint64_t{options_.interval_ms} * 1000000) return {};
  ClockProbe probe;
  probe.step = ProbeStep::kRequest;
  probe.origin_ns = now_ns;
  in_flight_origin_ = now_ns;
  in_flight_since_ns_ = now_ns;
  last_probe_ns_ = now_ns;
  ++sent_;
  return probe;
}

Status ClockSync::onReply(const ClockProbe& reply, uint64_t now_ns) {
  if (reply.step != ProbeStep::kReply || !in_flight_origin_ ||
      reply.origin_ns != *in_flight_origin_) {
    return Status(StatusCode::kUnexpectedMessage, "clock probe reply with origin " +
                                                      std::to_string(reply.origin_ns) +
                                                      " answers no probe in flight");
  }
  in_flight_origin_.reset();
  const uint64_t t1 = reply.origin_ns, t2 = reply.receive_ns, t3 = reply.transmit_ns, t4 = now_ns;
  if (t3 < t2 || t4 < t1 || t4 - t1 < t3 - t2) {
    return Status(StatusCode::kMalformed, "clock probe reply with impossible times: received " +
                                              std::to_string(t2) + ", answered " +
                                              std::to_string(t3) + ", within a round trip of " +
                                              std::to_string(t4 >= t1 ? t4 - t1 : 0) + " ns");
  }
  // In signed 128-bit arithmetic: two hosts' monotonic clocks may be days
  // apart, and the differences of u64 times must not wrap.
  const __int128 sum = (static_cast<__int128>(t2) - t1) + (static_cast<__int128>(t3) - t4);
  // Monotonic clocks count from boot: two hosts' differ by years at most.
  // An offset past 2^62 ns (146 years) is a peer's nonsense, and refusing
  // it keeps every later sum and negation inside int64.
  constexpr __int128 kMaxOffset = __int128{1} << 62;
  if (sum / 2 > kMaxOffset || sum / 2 < -kMaxOffset) {
    return Status(StatusCode::kMalformed, "clock probe reply puts the peer's clock " +
                                              std::to_string(static_cast<double>(sum / 2) / 1e9) +
                                              " s from ours");
  }
  Sample sample{static_cast<int64_t>(sum / 2), (t4 - t1) - (t3 - t2)};
  window_.push_back(sample);
  if (window_.size() > options_.window) window_.pop_front();
  best_ = window_.front();
  for (const Sample& s : window_) {
    if (s.delay_ns < best_->delay_ns) best_ = s;
  }
  ++samples_;
  if (!first_ && samples_ >= options_.burst) first_ = best_;
  return Status::ok();
}

ClockProbe ClockSync::answer(const ClockProbe& request, uint64_t received_ns, uint64_t now_ns) {
  ClockProbe reply;
  reply.step = ProbeStep::kReply;
  reply.origin_ns = request.origin_ns;
  reply.receive_ns = received_ns;
  reply.transmit_ns = now_ns;
  return reply;
}

int64_t ClockSync::driftNs() const {
  return first_ && best_ ? best_->offset_ns - first_->offset_ns : 0;
}

bool ClockSync::drifted(uint64_t threshold_ns) const {
  if (!first_ || !best_) return false;
  const uint64_t moved = static_cast<uint64_t>(std::llabs(driftNs()));
  const uint64_t noise = (first_->delay_ns + 1) / 2 + uncertaintyNs();
  return moved > noise + threshold_ns;
}

uint64_t ClockSync::toLocal(uint64_t peer_ns) const { return shiftedNs(peer_ns, offsetNs()); }

uint64_t ClockSync::toPeer(uint64_t local_ns) const { return shiftedNs(local_ns, -offsetNs()); }

std::string ClockSync::describe() const {
  if (!known()) return "not measured";
  char text[96];
  std::snprintf(text, sizeof text, "%+.3f ms +- %.3f ms", static_cast<double>(offsetNs()) / 1e6,
                static_cast<double>(uncertaintyNs()) / 1e6);
  return text;
}

uint64_t shiftedNs(uint64_t ns, int64_t offset_ns) {
  if (ns == 0) return 0;  // an open stamp's end stays open
  const __int128 shifted = static_cast<__int128>(ns) - offset_ns;
  return shifted < 1 ? 1 : static_cast<uint64_t>(shifted);
}

void shiftStamps(std::vector<StageStamp>& stamps, int64_t offset_ns) {
  if (offset_ns == 0) return;
  for (StageStamp& s : stamps) {
    s.start_ns = shiftedNs(s.start_ns, offset_ns);
    s.end_ns = shiftedNs(s.end_ns, offset_ns);
  }
}

}  // namespace holofuse::protocol
