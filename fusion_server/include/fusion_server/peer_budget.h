// PeerBudget: what one admitted peer may send the server, per message type,
// as a rate with a burst (token buckets). A key admits a peer; it does not
// let it take the server: a message over its type's budget waits (the
// server stops reading that peer, so TCP slows it), and a peer that stays
// over budget is closed by name (SECURITY.md, insiders).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "protocol/frame.h"

namespace holofuse::fusion {

// Messages a second, and how many may come at once after a quiet spell.
struct MessageRate {
  double per_second = 0;
  double burst = 0;
};

// The rates an admitted peer gets, by message type. The defaults are far
// above what an honest pod or client sends (a pod: one Calibration a
// connection, a PodFrame a frame, a heartbeat when idle, a probe answer a
// second; a client: one FrameRequest a mesh) and far below what costs the
// server a core.
struct BudgetTable {
  // A pod at 250 fps; a --lossless server (replays as fast as it reads)
  // sets no rate here, it reads pods only as fusion keeps up.
  MessageRate pod_frame{250, 120};
  MessageRate calibration{2, 8};
  MessageRate heartbeat{25, 10};
  MessageRate clock_probe{25, 20};
  MessageRate frame_request{250, 64};
  MessageRate other{25, 20};  // Bye, and types this build does not know
};

class PeerBudget {
 public:
  PeerBudget() = default;
  PeerBudget(const BudgetTable& table, uint64_t now_ns);

  // Takes one message of this type from its budget, charged `cost`
  // messages (a PodFrame: its pixels against the rig's median pod's, so
  // what it costs to decompress is the pod's to pay): true when there was
  // room; false (nothing taken) when the peer must wait until resumeAt().
  bool take(uint16_t type, uint64_t now_ns, double cost = 1.0);
  // When the type that was last refused has room for one message again.
  uint64_t resumeAt() const { return resume_at_ns_; }
  // Since when the peer has been over some budget without a second spent
  // within all of them; none while it keeps to them.
  std::optional<uint64_t> overSince() const { return over_since_ns_; }
  // The budget it went over and how often it was refused, for the log:
  // "FrameRequest messages faster than 250 a second (64 at once); held
  // back 1234 times".
  std::string describeOver() const;

 private:
  struct Bucket {
    MessageRate rate;
    double tokens = 0;
    uint64_t refilled_ns = 0;
  };
  enum Kind : size_t {
    kPodFrame,
    kCalibration,
    kHeartbeat,
    kClockProbe,
    kFrameRequest,
    kOther,
    kKinds
  };
  static Kind kindOf(uint16_t type);

  std::array<Bucket, kKinds> buckets_{};
  uint64_t resume_at_ns_ = 0;
  std::optional<uint64_t> over_since_ns_;
  uint64_t last_refused_ns_ = 0;
  uint64_t refused_ = 0;
  uint16_t refused_type_ = 0;
};

}  // namespace holofuse::fusion
