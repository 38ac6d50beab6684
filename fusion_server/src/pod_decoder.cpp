#include "fusion_server/pod_decoder.h"

#include <unistd.h>

#include <cstdio>
#include <string>

#include "fusion_server/fusion_worker.h"
#include "protocol/messages.h"

namespace holofuse::fusion {

DecodedPodFrame decodePodFrame(PodDecodeJob job) {
  DecodedPodFrame out;
  out.connection = job.connection;
  out.pod = job.pod;
  protocol::PodFrame pod;
  out.status = protocol::decodeFrame(job.frame, pod);
  if (out.status.isOk() && pod.camera_id != job.pod) {
    out.status = Status(StatusCode::kMalformed,
                        "field 'pod_frame.camera_id': " + std::to_string(pod.camera_id) +
                            " from the pod that said it is " + std::to_string(job.pod));
  }
  if (out.status.isOk()) {
    out.frame_id = pod.frame_id;
    auto images = podImagesOf(pod, job.frame.bytes.size(), job.camera, job.arrival_ns,
                              job.clock_offset_ns, job.clock_uncertainty_ns);
    if (images.isOk()) {
      out.images = std::move(*images);
    } else {
      out.status = images.status();
    }
  }
  out.frame = std::move(job.frame);
  return out;
}

PodDecoder::PodDecoder(int threads, int wake_fd) : wake_fd_(wake_fd) {
  for (int i = 0; i < std::max(threads, 1); ++i) threads_.emplace_back([this] { run(); });
}

PodDecoder::~PodDecoder() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  for (auto& thread : threads_) thread.join();
}

void PodDecoder::submit(PodDecodeJob job) {
  ++in_flight_[job.pod];
  ++in_flight_total_;
  {
    std::lock_guard lock(mutex_);
    jobs_.emplace_back(next_submitted_++, std::move(job));
  }
  cv_.notify_one();
}

std::vector<DecodedPodFrame> PodDecoder::takeDecoded() {
  std::vector<DecodedPodFrame> out;
  {
    std::lock_guard lock(mutex_);
    for (auto it = decoded_.begin(); it != decoded_.end() && it->first == next_released_;
         it = decoded_.erase(it), ++next_released_)
      out.push_back(std::move(it->second));
  }
  for (const auto& frame : out) {
    --in_flight_total_;
    if (--in_flight_[frame.pod] == 0) in_flight_.erase(frame.pod);
  }
  return out;
}

size_t PodDecoder::inFlight(uint32_t pod) const {
  auto it = in_flight_.find(pod);
  return it == in_flight_.end() ? 0 : it->second;
}

std::set<uint32_t> PodDecoder::podsInFlight() const {
  std::set<uint32_t> pods;
  for (const auto& [pod, count] : in_flight_) pods.insert(pod);
  return pods;
}

void PodDecoder::run() {
  for (;;) {
    std::pair<uint64_t, PodDecodeJob> job;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [this] { return stop_ || !jobs_.empty(); });
      if (stop_) return;
      job = std::move(jobs_.front());
      jobs_.pop_front();
    }
    DecodedPodFrame decoded = decodePodFrame(std::move(job.second));
    {
      std::lock_guard lock(mutex_);
      decoded_.emplace(job.first, std::move(decoded));
    }
    const uint64_t one = 1;
    if (::write(wake_fd_, &one, sizeof(one)) < 0) {
      std::perror("[server] pod decoder wake");
    }
  }
}

}  // namespace holofuse::fusion
