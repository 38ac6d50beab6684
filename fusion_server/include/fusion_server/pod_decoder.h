// PodDecoder decompresses pods' frames on its own threads, so the loop that
// accepts and reads every peer never waits on a pod's LZ4 planes: one pod's
// large frames cannot delay another peer's handshake or heartbeat
// (SECURITY.md, fair service). The loop submits each PodFrame as read and
// takes the decoded frames when the wake descriptor fires.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <vector>

#include "fusion_server/frame_sync.h"
#include "geometry/camera.h"
#include "protocol/frame.h"

namespace holofuse::fusion {

struct PodDecodeJob {
  uint64_t connection = 0;  // the serial of the connection it came on
  uint32_t pod = 0;         // the id that connection authenticated as
  protocol::Frame frame;
  Camera camera;  // the calibration in force when it arrived
  uint64_t arrival_ns = 0;
  // The pod's clock minus ours as estimated at arrival; none while a pod of
  // 1.8 or later is not measured yet (its times cannot be placed).
  std::optional<int64_t> clock_offset_ns = 0;
  uint64_t clock_uncertainty_ns = 0;  // of that estimate
};

struct DecodedPodFrame {
  uint64_t connection = 0;
  uint32_t pod = 0;
  uint64_t frame_id = 0;
  protocol::Frame frame;  // as received, for the recording
  Status status;          // not ok: the frame is refused and its peer closed
  PodImages images;
};

// What one frame decodes to: the message, checked against the pod that sent
// it, and its planes against the calibration (podImagesOf).
DecodedPodFrame decodePodFrame(PodDecodeJob job);

class PodDecoder {
 public:
  // wake_fd is written (8 bytes, eventfd style) whenever a frame is decoded.
  PodDecoder(int threads, int wake_fd);
  ~PodDecoder();
  PodDecoder(const PodDecoder&) = delete;
  PodDecoder& operator=(const PodDecoder&) = delete;

  void submit(PodDecodeJob job);
  // The frames decoded so far, in the order they were submitted whatever
  // thread finished first: a pod's ids only grow on the wire, and the
  // lossless sync and the recording rely on seeing them so.
  std::vector<DecodedPodFrame> takeDecoded();

  // Frames submitted and not yet taken, counted by the submitting thread
  // (the only one that calls submit and takeDecoded).
  size_t inFlight(uint32_t pod) const;
  size_t inFlight() const { return in_flight_total_; }
  // Pods with a frame still in the decoder: the sync must wait for them
  // even after they have left.
  std::set<uint32_t> podsInFlight() const;

 private:
  void run();

  int wake_fd_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::pair<uint64_t, PodDecodeJob>> jobs_;  // by submission number
  std::map<uint64_t, DecodedPodFrame> decoded_;
  uint64_t next_submitted_ = 0;
  uint64_t next_released_ = 0;
  bool stop_ = false;
  std::vector<std::thread> threads_;
  std::map<uint32_t, size_t> in_flight_;
  size_t in_flight_total_ = 0;
};

}  // namespace holofuse::fusion
