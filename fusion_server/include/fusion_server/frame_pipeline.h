// The fusion server's pipeline part: each pod's frames decoded off the
// loop, grouped across pods by the frame sync, fused on the worker (only as
// clients ask, where every client does), fanned out to each client in the
// spelling it decodes, and recorded. The session part (fusion_server.h)
// owns the connections and tells it what they send and who comes and goes;
// it reads the peers to pace and to fan out, and never closes one itself.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "base/arrival_jitter.h"
#include "dataset/recorder.h"
#include "fusion_server/frame_sync.h"
#include "fusion_server/fusion_worker.h"
#include "fusion_server/peer.h"
#include "fusion_server/pod_decoder.h"
#include "fusion_server/server_options.h"
#include "geometry/camera.h"
#include "protocol/frame.h"

namespace holofuse::fusion {

class FramePipeline {
 public:
  // Holds options by reference: the server's, which outlive it.
  explicit FramePipeline(const ServerOptions& options);
  ~FramePipeline();

  // Opens the recording (record_dir), starts the decoder and the worker.
  Status start();
  // The descriptor the decoder and the worker wake the loop with, and the
  // loop's read of it.
  int wakeFd() const { return wake_fd_; }
  void drainWake();

  // A pod came in (a new connection: its clock and transit start afresh)
  // or left (its vote on the rig's clock with it).
  void podJoined(uint32_t pod);
  void podLeft(uint32_t pod);
  // A pod's Calibration message, checked by the session part: recorded,
  // and relayed to every client, now and as each joins.
  void relayCalibration(uint32_t camera_id, const protocol::Frame& frame, std::vector<Peer>& peers);
  void welcomeClient(Peer& client) const;

  // A pod's frame, handed to the decoder with the pod's camera and its
  // clock estimate.
  Status podFrame(const Peer& pod, const Camera& camera, protocol::Frame frame);
  // Frames the decoder finished go to the sync; those it refused as
  // malformed are returned, by the connection that sent them, for the
  // session part to close.
  struct Refused {
    uint64_t connection = 0;
    Status why;
  };
  std::vector<Refused> takeDecodedFrames();
  // Groups the sync has ready go to the worker (or wait for a client to
  // ask), and the worker's fused frames to every client.
  void dispatchReadyGroups(const std::vector<Peer>& peers);
  void fanOut(std::vector<Peer>& peers);

  // Backpressure: false while this pod must not be read (no client yet
  // where one is awaited, its frames still decoding, or, lossless,
  // fusion behind).
  bool readable(const Peer& pod, const std::vector<Peer>& peers);
  // Every configured pod joined and left, and what they sent is fused and
  // delivered.
  bool podsDone(const std::vector<Peer>& peers) const;
  // When the next group expires at the sync deadline.
  std::optional<uint64_t> nextDeadline() const { return sync_.nextDeadline(); }
  // The rig's clock as the sync sees a pod (null before its first frame).
  const PodClock* clockOf(uint32_t pod) const { return sync_.clockOf(pod); }

  void reportRecordingProgress();
  void closeRecording();
  uint64_t groupsFused() const { return groups_fused_; }
  uint64_t groupsNotAskedFor() const { return groups_not_asked_for_; }
  size_t groupsFusing() const { return worker_->jobsNotTaken(); }
  // "fusing N groups (late pod frames, dropped, not asked for)", for the
  // server's last line.
  std::string summary() const;

 private:
  std::set<uint32_t> expectedPods() const;
  void syncDecoded(protocol::Frame frame, uint32_t pod, uint64_t frame_id, PodImages images);
  // A pod's frame off the rig's clock: told in the log (the first of a
  // run and every 100th).
  void tellOffClock(uint32_t pod, uint64_t frame_id);
  // Whether groups are fused only as clients ask (ServerOptions::
  // fuse_when_asked), and whether one more may start now.
  bool fusingWhenAsked(const std::vector<Peer>& peers) const;
  bool aClientWaitsForAFrame(const std::vector<Peer>& peers) const;
  void submitGroup(FrameGroup group, const std::vector<Peer>& peers);

  const ServerOptions& options_;
  int wake_fd_ = -1;
  std::map<uint32_t, protocol::SharedFrame> calibration_frames_;
  std::map<uint32_t, ArrivalJitter> pod_arrivals_;  // per pod, over every PodFrame received
  std::set<uint32_t> departed_pods_;                // pods that joined and then left
  std::set<uint32_t> streaming_;  // pods whose first frame on this connection is in (logged)
  FrameSync sync_;
  std::unique_ptr<FusionWorker> worker_;
  std::unique_ptr<PodDecoder> decoder_;
  std::optional<dataset::Recorder> recorder_;
  uint64_t groups_fused_ = 0;
  // The newest ready group no client has asked for yet; a newer one
  // replaces it (counted: groups_not_asked_for_).
  std::optional<FrameGroup> held_group_;
  uint64_t groups_not_asked_for_ = 0;
  bool clients_arrived_ = false;  // wait_for_clients reached once
};

}  // namespace holofuse::fusion
