// FrameSync groups PodFrames from different pods by frame id. A group goes
// out when every connected pod has delivered or its deadline passes; a late
// or dead pod never stalls the loop.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <vector>

#include "common/camera.h"
#include "common/image.h"
#include "protocol/messages.h"

namespace holofuse::fusion {

struct PodImages {
  uint32_t camera_id = 0;
  Image8 color, mask, feather;          // the whole image, or the rectangle the pod sent
  uint32_t offset_x = 0, offset_y = 0;  // where that rectangle sits in the camera's image
  std::vector<protocol::StageStamp> stamps;
  uint64_t capture_time_ns = 0;
  uint64_t bytes = 0;  // size of the frame on the wire
  Camera camera;       // the calibration in force when the frame arrived
  // The transit RFC 3550 watches (the server's kSend stamp, whose start is
  // moved to the arrival where it ends before it starts by no more than the
  // clock estimate's uncertainty): from the pod's send (its encode end, a
  // replay pod's read end) to the arrival. sent_ns
  // is on the server's clock; pod_sent_ns the same moment on the pod's own,
  // which the jitter takes: a constant offset cancels in RFC 3550's
  // differences, and the estimate's steps must not read as jitter.
  uint64_t sent_ns = 0, arrival_ns = 0, pod_sent_ns = 0;
};

struct FrameGroup {
  uint64_t frame_id = 0;
  uint64_t first_arrival_ns = 0;
  uint64_t emitted_ns = 0;
  std::map<uint32_t, PodImages> pods;  // by camera id
  bool complete = false;               // every expected pod delivered
};

class FrameSync {
 public:
  FrameSync(uint64_t deadline_ns, size_t max_pending = 8)
      : deadline_ns_(deadline_ns), max_pending_(max_pending) {}

  // Lossless (replay as fast as the server accepts): a group waits for
  // every expected pod however long it takes, and the caller bounds what
  // is pending by not reading pods that are ahead (pendingWith). A group
  // goes out without a pod once that pod has sent a later frame: a pod's
  // ids only grow, so it skipped this one (waiting would stall everyone).
  static FrameSync lossless() { return FrameSync(kNoDeadline, kLosslessMaxPending); }

  enum class Added { kAccepted, kLate, kImplausible };
  // Frame ids further than this from the last fused one are not a late or
  // early frame but a different clock. Far ahead is refused (one pod must
  // not push everyone else into lateness). Far behind is refused too,
  // unless half the pods seen or more are far behind as well: then the rig's
  // clock went back and the sync starts over. So one pod's ids, ahead or
  // behind, never decide what the others' frames are; and after a start
  // over, ids near the clock left behind stay refused.
  static constexpr uint64_t kMaxIdJump = 100000;

  // Adds a pod's frame. kLate (counted) when its group has already gone
  // out; kImplausible when its id is far from what is being fused.
  Added add(uint64_t frame_id, PodImages images, uint64_t now_ns);
  // Groups ready at now_ns given the pods currently expected, oldest first.
  std::vector<FrameGroup> takeReady(const std::set<uint32_t>& expected, uint64_t now_ns);
  // Time until the oldest pending group's deadline (for the poll timeout).
  std::optional<uint64_t> nextDeadline() const;

  // A pod that reconnected: its ids are judged afresh.
  void forgetPod(uint32_t camera_id);

  size_t pendingGroups() const { return pending_.size(); }
  // Pending groups that already hold a frame of this camera.
  size_t pendingWith(uint32_t camera_id) const;

  uint64_t lateFrames() const { return late_frames_; }
  uint64_t overflowedGroups() const { return overflowed_groups_; }
  uint64_t clockResets() const { return clock_resets_; }

 private:
  static constexpr uint64_t kNoDeadline = UINT64_MAX;
  static constexpr size_t kLosslessMaxPending = 4096;
  uint64_t deadline_ns_;
  size_t max_pending_;
  std::map<uint64_t, FrameGroup> pending_;
  std::optional<uint64_t> last_emitted_;
  std::map<uint32_t, uint64_t> last_id_from_;  // per camera: the id of its latest frame
  std::set<uint32_t> behind_;          // cameras whose latest frame was far behind the clock
  std::optional<uint64_t> abandoned_;  // the clock a start-over left behind
  uint64_t late_frames_ = 0;
  uint64_t overflowed_groups_ = 0;
  uint64_t clock_resets_ = 0;
};

}  // namespace holofuse::fusion
