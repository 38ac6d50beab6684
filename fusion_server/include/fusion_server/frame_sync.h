// FrameSync groups PodFrames from different pods by frame id. A group goes
// out when every connected pod has delivered or its deadline passes; a late
// or dead pod never stalls the loop, and no single pod's clock can move the
// rig's (SECURITY.md).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "geometry/camera.h"
#include "image/image.h"
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
  // Its deadline runs from the first arrival, but a group whose id the
  // rig's clock has not reached does not expire: a pod slightly ahead
  // would otherwise send it out alone before the others sent theirs.
  uint64_t first_arrival_ns = 0;
  uint64_t emitted_ns = 0;
  std::map<uint32_t, PodImages> pods;  // by camera id
  bool complete = false;               // every expected pod delivered
};

// What the sync knows of one pod's clock (FrameSync::add, clockOf).
struct PodClock {
  uint64_t latest_id = 0;  // the id of its latest frame, on the rig's clock or not
  uint64_t heard_ns = 0;   // when that frame reached the sync
  // Its latest id minus the rig's clock then, and the rig's clock and the
  // number of pods it was the median of.
  int64_t offset = 0;
  uint64_t rig_id = 0;
  size_t voters = 0;
  // Set from its first frame off the rig's clock until one is on it again.
  std::optional<uint64_t> off_since_ns;
  uint64_t off_frames = 0;  // every frame refused as off the clock, in all
};

// A pod's offset from the rig's clock, for the log: "54000 ids ahead of
// the rig's clock (id N, the median of 4 pods)".
std::string describeOffset(const PodClock& clock);

class FrameSync {
 public:
  // How far (in frame ids) a pod's frames may be from the rig's clock:
  // 8 ids is 0.53 s at 15 fps, 0.27 s at 30 (--max-id-skew).
  static constexpr uint64_t kDefaultMaxIdSkew = 8;

  explicit FrameSync(uint64_t deadline_ns, uint64_t max_id_skew = kDefaultMaxIdSkew);

  // Lossless (replay as fast as the server accepts): a group waits for
  // every expected pod however long it takes, and the caller bounds what
  // is pending by not reading pods that are ahead (pendingWith). A group
  // goes out without a pod once that pod has sent a later frame: a pod's
  // ids only grow, so it skipped this one (waiting would stall everyone).
  static FrameSync lossless(uint64_t max_id_skew = kDefaultMaxIdSkew);

  // The rig's clock is the median of the latest ids of the pods heard
  // within the vote window (a second, or four deadlines; every pod when
  // lossless). With an even count the middle value nearer the ids being
  // fused wins, so two pods that disagree keep the clock they were on, and
  // a pod that left or went quiet stops voting. A frame further than
  // max_id_skew from that clock is off the clock (kOffClock): that pod
  // loses it, is not waited for while it stays off, and moves nothing.
  // When the clock itself goes back past the ids fused (most pods are now
  // on another clock: the rig restarted), the sync starts over.
  enum class Added { kAccepted, kLate, kOffClock };
  // Adds a pod's frame. kLate (counted) when its group has already gone
  // out.
  Added add(uint64_t frame_id, PodImages images, uint64_t now_ns);
  // Groups ready at now_ns given the pods currently connected, oldest
  // first. A pod off the rig's clock is not waited for.
  std::vector<FrameGroup> takeReady(const std::set<uint32_t>& expected, uint64_t now_ns);
  // Time until the oldest pending group's deadline (for the poll timeout).
  std::optional<uint64_t> nextDeadline() const;

  // A pod that left or reconnected: its vote and its standing are gone,
  // and its ids are judged afresh.
  void forgetPod(uint32_t camera_id);
  // What the sync knows of a pod's clock; null before its first frame.
  const PodClock* clockOf(uint32_t camera_id) const;

  size_t pendingGroups() const { return pending_.size(); }
  // Pending groups that already hold a frame of this camera.
  size_t pendingWith(uint32_t camera_id) const;

  uint64_t maxIdSkew() const { return max_id_skew_; }
  uint64_t lateFrames() const { return late_frames_; }
  uint64_t offClockFrames() const { return off_clock_frames_; }
  uint64_t overflowedGroups() const { return overflowed_groups_; }
  uint64_t clockResets() const { return clock_resets_; }

 private:
  static constexpr uint64_t kNoDeadline = UINT64_MAX;
  static constexpr size_t kLosslessMaxPending = 4096;
  FrameSync(uint64_t deadline_ns, uint64_t max_id_skew, size_t max_pending);
  // The median of the voters' latest ids; sets voters to their count.
  uint64_t rigClock(uint64_t now_ns, size_t& voters) const;
  bool offClock(uint32_t camera_id) const;

  uint64_t deadline_ns_;
  uint64_t max_id_skew_;
  size_t max_pending_;
  uint64_t vote_window_ns_;
  std::map<uint64_t, FrameGroup> pending_;
  std::optional<uint64_t> last_emitted_;
  uint64_t rig_id_ = 0;                  // the rig's clock at the latest frame
  std::map<uint32_t, PodClock> clocks_;  // by camera
  uint64_t late_frames_ = 0;
  uint64_t off_clock_frames_ = 0;
  uint64_t overflowed_groups_ = 0;
  uint64_t clock_resets_ = 0;
};

}  // namespace holofuse::fusion
