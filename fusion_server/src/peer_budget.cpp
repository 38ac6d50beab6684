#include "fusion_server/peer_budget.h"

#include <algorithm>
#include <cmath>

namespace holofuse::fusion {

namespace {

// A peer that has kept to its budgets this long is no longer over them.
constexpr uint64_t kWithinBudgetNs = 1'000'000'000ull;

std::string count(double value) {
  return std::to_string(static_cast<long long>(std::llround(value)));
}

}  // namespace

PeerBudget::PeerBudget(const BudgetTable& table, uint64_t now_ns) {
  buckets_[kPodFrame].rate = table.pod_frame;
  buckets_[kCalibration].rate = table.calibration;
  buckets_[kHeartbeat].rate = table.heartbeat;
  buckets_[kClockProbe].rate = table.clock_probe;
  buckets_[kFrameRequest].rate = table.frame_request;
  buckets_[kOther].rate = table.other;
  for (Bucket& bucket : buckets_) {
    bucket.tokens = bucket.rate.burst;
    bucket.refilled_ns = now_ns;
  }
}

PeerBudget::Kind PeerBudget::kindOf(uint16_t type) {
  switch (static_cast<protocol::MessageType>(type)) {
    case protocol::MessageType::kPodFrame:
      return kPodFrame;
    case protocol::MessageType::kCalibration:
      return kCalibration;
    case protocol::MessageType::kHeartbeat:
      return kHeartbeat;
    case protocol::MessageType::kClockProbe:
      return kClockProbe;
    case protocol::MessageType::kFrameRequest:
      return kFrameRequest;
    default:
      return kOther;
  }
}

bool PeerBudget::take(uint16_t type, uint64_t now_ns, double cost) {
  Bucket& bucket = buckets_[kindOf(type)];
  // A rate of 0 with no burst is no limit (BudgetTable: a lossless pod).
  if (bucket.rate.per_second <= 0 && bucket.rate.burst <= 0) return true;
  if (now_ns > bucket.refilled_ns) {
    bucket.tokens =
        std::min(bucket.rate.burst,
                 bucket.tokens + bucket.rate.per_second *
                                     static_cast<double>(now_ns - bucket.refilled_ns) / 1e9);
    bucket.refilled_ns = now_ns;
  }
  // A message dearer than the whole burst is charged the burst: it passes
  // once the bucket is full, and the rate still holds.
  cost = std::min(cost, bucket.rate.burst);
  if (bucket.tokens >= cost) {
    bucket.tokens -= cost;
    if (over_since_ns_ && now_ns - last_refused_ns_ > kWithinBudgetNs) over_since_ns_.reset();
    return true;
  }
  const double wait_s =
      bucket.rate.per_second > 0 ? (cost - bucket.tokens) / bucket.rate.per_second : 1.0;
  resume_at_ns_ = now_ns + static_cast<uint64_t>(std::ceil(wait_s * 1e9));
  if (!over_since_ns_) over_since_ns_ = now_ns;
  last_refused_ns_ = now_ns;
  refused_type_ = type;
  ++refused_;
  return false;
}

std::string PeerBudget::describeOver() const {
  const MessageRate& rate = buckets_[kindOf(refused_type_)].rate;
  const std::string name = protocol::messageTypeName(refused_type_);
  return (name == "unknown" ? "messages of type " + std::to_string(refused_type_) + " (unknown)"
                            : name + " messages") +
         " faster than " + count(rate.per_second) + " a second (" + count(rate.burst) +
         " at once); " + "held back " + std::to_string(refused_) + " times";
}

}  // namespace holofuse::fusion
