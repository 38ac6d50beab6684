#include "fusion_server/frame_sync.h"

namespace holofuse::fusion {

FrameSync::Added FrameSync::add(uint64_t frame_id, PodImages images, uint64_t now_ns) {
  const uint32_t camera = images.camera_id;
  // After a start-over, the clock left behind stays refused: a pod still on
  // it must not start the sync over again.
  if (abandoned_ &&
      (frame_id > *abandoned_ ? frame_id - *abandoned_ : *abandoned_ - frame_id) <= kMaxIdJump)
    return Added::kImplausible;
  if (last_emitted_) {
    if (frame_id > *last_emitted_ && frame_id - *last_emitted_ > kMaxIdJump)
      return Added::kImplausible;
    if (frame_id<*last_emitted_&& * last_emitted_ - frame_id> kMaxIdJump) {
      behind_.insert(camera);
      last_id_from_[camera] = frame_id;
      if (2 * behind_.size() < last_id_from_.size()) return Added::kImplausible;
      // Most pods' clocks went back (or the first ids seen were bogus):
      // start over rather than calling every frame late forever.
      abandoned_ = *last_emitted_;
      last_emitted_.reset();
      pending_.clear();
      last_id_from_.clear();
      behind_.clear();
      ++clock_resets_;
    } else if (frame_id <= *last_emitted_) {
      behind_.erase(camera);
      ++late_frames_;
      return Added::kLate;
    }
  }
  behind_.erase(camera);
  last_id_from_[images.camera_id] = frame_id;
  auto [it, inserted] = pending_.try_emplace(frame_id);
  if (inserted) {
    it->second.frame_id = frame_id;
    it->second.first_arrival_ns = now_ns;
  }
  it->second.pods[images.camera_id] = std::move(images);
  // Bound memory: a flood of new ids pushes the oldest groups out.
  while (pending_.size() > max_pending_) {
    pending_.erase(pending_.begin());
    ++overflowed_groups_;
  }
  return Added::kAccepted;
}

void FrameSync::forgetPod(uint32_t camera_id) {
  last_id_from_.erase(camera_id);
  behind_.erase(camera_id);
}

std::vector<FrameGroup> FrameSync::takeReady(const std::set<uint32_t>& expected, uint64_t now_ns) {
  std::vector<FrameGroup> ready;
  for (auto it = pending_.begin(); it != pending_.end();) {
    FrameGroup& group = it->second;
    bool complete = !expected.empty();
    for (uint32_t id : expected) complete = complete && group.pods.count(id) > 0;
    // Lossless groups wait for their pods; once every pod has left, or
    // every missing pod has moved past this id, what they sent goes out.
    bool expired = false;
    if (deadline_ns_ == kNoDeadline) {
      expired = true;
      for (uint32_t id : expected) {
        if (group.pods.count(id)) continue;
        const auto last = last_id_from_.find(id);
        expired = expired && last != last_id_from_.end() && last->second > group.frame_id;
      }
    } else {
      expired = now_ns - group.first_arrival_ns >= deadline_ns_;
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
  if (pending_.empty() || deadline_ns_ == kNoDeadline) return std::nullopt;
  uint64_t earliest = UINT64_MAX;
  for (const auto& [id, group] : pending_)
    earliest = std::min(earliest, group.first_arrival_ns + deadline_ns_);
  return earliest;
}

}  // namespace holofuse::fusion
