#include "fusion_server/frame_sync.h"

#include <algorithm>

namespace holofuse::fusion {

namespace {

// a - b, saturated to int64's range (ids are any 64-bit value a pod sends).
int64_t signedDifference(uint64_t a, uint64_t b) {
  if (a >= b) return a - b > uint64_t{INT64_MAX} ? INT64_MAX : static_cast<int64_t>(a - b);
  return b - a > uint64_t{INT64_MAX} ? INT64_MIN : -static_cast<int64_t>(b - a);
}

uint64_t distance(uint64_t a, uint64_t b) { return a > b ? a - b : b - a; }

}  // namespace

FrameSync::FrameSync(uint64_t deadline_ns, uint64_t max_id_skew)
    // Room for the groups in flight and for a pod up to max_id_skew ahead,
    // whose frames wait for the others (FrameGroup::first_arrival_ns).
    : FrameSync(deadline_ns, max_id_skew, static_cast<size_t>(max_id_skew) + 8) {}

FrameSync::FrameSync(uint64_t deadline_ns, uint64_t max_id_skew, size_t max_pending)
    : deadline_ns_(deadline_ns),
      max_id_skew_(max_id_skew),
      max_pending_(max_pending),
      // A pod whose last frame is older than this does not vote: a pod that
      // stalled must not hold the clock back. Lossless pods are silent when
      // they are not read (they are ahead), so every one votes.
      vote_window_ns_(deadline_ns == kNoDeadline
                          ? kNoDeadline
                          : std::max<uint64_t>(1'000'000'000ull, 4 * deadline_ns)) {}

FrameSync FrameSync::lossless(uint64_t max_id_skew) {
  return FrameSync(kNoDeadline, max_id_skew, kLosslessMaxPending);
}

uint64_t FrameSync::rigClock(uint64_t now_ns, size_t& voters) const {
  std::vector<uint64_t> ids;
  for (const auto& [camera, clock] : clocks_) {
    if (vote_window_ns_ == kNoDeadline || now_ns < clock.heard_ns ||
        now_ns - clock.heard_ns <= vote_window_ns_)
      ids.push_back(clock.latest_id);
  }
  voters = ids.size();
  std::sort(ids.begin(), ids.end());
  const size_t n = ids.size();
  if (n % 2 == 1) return ids[n / 2];
  // Two middle values: the one nearer the ids being fused (the clock the
  // rig was on), or the lower before anything was fused.
  const uint64_t low = ids[n / 2 - 1], high = ids[n / 2];
  if (last_emitted_ && distance(high, *last_emitted_) < distance(low, *last_emitted_)) return high;
  return low;
}

bool FrameSync::offClock(uint32_t camera_id) const {
  const auto it = clocks_.find(camera_id);
  return it != clocks_.end() && it->second.off_since_ns.has_value();
}

FrameSync::Added FrameSync::add(uint64_t frame_id, PodImages images, uint64_t now_ns) {
  const uint32_t camera = images.camera_id;
  PodClock& clock = clocks_[camera];
  clock.latest_id = frame_id;
  clock.heard_ns = now_ns;
  const uint64_t rig = rigClock(now_ns, clock.voters);
  clock.rig_id = rig;
  rig_id_ = rig;
  clock.offset = signedDifference(frame_id, rig);
  if (distance(frame_id, rig) > max_id_skew_) {
    if (!clock.off_since_ns) clock.off_since_ns = now_ns;
    ++clock.off_frames;
    ++off_clock_frames_;
    return Added::kOffClock;
  }
  clock.off_since_ns.reset();
  if (last_emitted_ && rig<*last_emitted_&& * last_emitted_ - rig> max_id_skew_) {
    // Most pods went back past what was fused: start over rather than
    // calling every frame late forever.
    last_emitted_.reset();
    pending_.clear();
    ++clock_resets_;
  }
  if (last_emitted_ && frame_id <= *last_emitted_) {
    ++late_frames_;
    return Added::kLate;
  }
  auto [it, inserted] = pending_.try_emplace(frame_id);
  if (inserted) {
    it->second.frame_id = frame_id;
    it->second.first_arrival_ns = now_ns;
  }
  it->second.pods[camera] = std::move(images);
  // Bound memory: a flood of new ids pushes the oldest groups out.
  while (pending_.size() > max_pending_) {
    pending_.erase(pending_.begin());
    ++overflowed_groups_;
  }
  return Added::kAccepted;
}

std::string describeOffset(const PodClock& clock) {
  const uint64_t ids = clock.offset < 0 ? 0 - static_cast<uint64_t>(clock.offset)
                                        : static_cast<uint64_t>(clock.offset);
  return std::to_string(ids) + (clock.offset < 0 ? " ids behind" : " ids ahead of") +
         " the rig's clock (id " + std::to_string(clock.rig_id) + ", the median of " +
         std::to_string(clock.voters) + (clock.voters == 1 ? " pod)" : " pods)");
}

void FrameSync::forgetPod(uint32_t camera_id) { clocks_.erase(camera_id); }

const PodClock* FrameSync::clockOf(uint32_t camera_id) const {
  const auto it = clocks_.find(camera_id);
  return it == clocks_.end() ? nullptr : &it->second;
}

std::vector<FrameGroup> FrameSync::takeReady(const std::set<uint32_t>& connected, uint64_t now_ns) {
  std::set<uint32_t> expected;
  for (uint32_t id : connected)
    if (!offClock(id)) expected.insert(id);
  std::vector<FrameGroup> ready;
  for (auto it = pending_.begin(); it != pending_.end();) {
    FrameGroup& group = it->second;
    bool complete = !expected.empty();
    for (uint32_t id : expected) complete = complete && group.pods.count(id) > 0;
    // Lossless groups wait for their pods; once every pod has left, or
    // every missing pod has moved past this id, what they sent goes out.
    bool no_one_to_wait_for = true;
    for (uint32_t id : expected) {
      if (group.pods.count(id)) continue;
      const auto clock = clocks_.find(id);
      no_one_to_wait_for =
          no_one_to_wait_for && clock != clocks_.end() && clock->second.latest_id > group.frame_id;
    }
    bool expired = no_one_to_wait_for;
    if (deadline_ns_ != kNoDeadline) {
      // A group ahead of the rig's clock waits for the pods behind it, but
      // not once none is left to fill it (they left, or moved past it):
      // the clock stops when the last pod leaves, and its frames must go.
      expired = (group.frame_id <= rig_id_ || no_one_to_wait_for) &&
                now_ns - group.first_arrival_ns >= deadline_ns_;
    }
    if (!complete && !expired) {
      ++it;
      continue;
    }
    // Groups go out in frame order: anything older still pending is given
    // up with this one, so ids never go backwards.
    group.complete = complete;
    group.emitted_ns = now_ns;
    last_emitted_ = group.frame_id;
    for (auto older = pending_.begin(); older != it;) {
      ++overflowed_groups_;
      older = pending_.erase(older);
    }
    ready.push_back(std::move(group));
    it = pending_.erase(it);
  }
  return ready;
}

size_t FrameSync::pendingWith(uint32_t camera_id) const {
  size_t n = 0;
  for (const auto& [id, group] : pending_) n += group.pods.count(camera_id);
  return n;
}

std::optional<uint64_t> FrameSync::nextDeadline() const {
  if (deadline_ns_ == kNoDeadline) return std::nullopt;
  std::optional<uint64_t> earliest;
  for (const auto& [id, group] : pending_) {
    if (id > rig_id_) break;  // waits for the clock, not the deadline
    earliest = std::min(earliest.value_or(UINT64_MAX), group.first_arrival_ns + deadline_ns_);
  }
  return earliest;
}

}  // namespace holofuse::fusion
