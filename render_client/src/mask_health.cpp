#include "render_client/mask_health.h"

#include <algorithm>

#include "metrics/geometry_metrics.h"

namespace holofuse::render {

MaskHealthSampler::MaskHealthSampler(uint64_t interval_ns)
    : interval_ns_(interval_ns), thread_([this] { run(); }) {}

MaskHealthSampler::~MaskHealthSampler() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void MaskHealthSampler::offer(uint64_t frame_id, uint64_t now_ns, const Mesh& mesh,
                              const std::vector<ViewImages>& views) {
  if (views.size() < 2 || mesh.indices.empty()) return;
  if (last_offer_ns_ != 0 && now_ns - last_offer_ns_ < interval_ns_) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (busy_ || job_) return;
    Job job;
    job.frame_id = frame_id;
    job.mesh = mesh;
    for (const ViewImages& view : views) {
      job.cameras.push_back(view.camera);
      job.masks.push_back(view.mask);
    }
    job_ = std::move(job);
  }
  last_offer_ns_ = now_ns;
  changed_.notify_all();
}

void MaskHealthSampler::run() {
  for (;;) {
    Job job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return stop_ || job_; });
      if (!job_) return;  // stopping, nothing left
      job = std::move(*job_);
      job_.reset();
      busy_ = true;
    }
    Sample sample{job.frame_id, {}};
    for (size_t c = 0; c < job.cameras.size(); ++c) {
      const Camera& camera = job.cameras[c];
      const Image8& mask = job.masks[c];
      // A view without its whole mask is not measured.
      if (mask.width != camera.width || mask.height != camera.height) continue;
      sample.iou.emplace_back(camera.id, metrics::silhouetteIoU(job.mesh, camera, mask));
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (samples_.capacity() < kSamplesKept) samples_.reserve(kSamplesKept);
    samples_.push_back(std::move(sample));
    if (samples_.size() == kSamplesKept) {
      for (size_t i = 0; i < kSamplesKept / 2; ++i) samples_[i] = std::move(samples_[2 * i]);
      samples_.resize(kSamplesKept / 2);
      interval_ns_ = interval_ns_ * 2;
    }
    busy_ = false;
    changed_.notify_all();
  }
}

HealthOverTime MaskHealthSampler::summary(std::vector<uint32_t>* camera_ids) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return !busy_ && !job_; });
  // One column per camera any sample measured, in id order; -1 where a
  // sample did not measure it.
  std::vector<uint32_t> ids;
  for (const Sample& sample : samples_)
    for (const auto& [id, value] : sample.iou)
      if (std::find(ids.begin(), ids.end(), id) == ids.end()) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  std::vector<std::vector<double>> rows;
  std::vector<std::vector<bool>> set_apart;
  std::vector<uint64_t> frame_ids;
  for (const Sample& sample : samples_) {
    frame_ids.push_back(sample.frame_id);
    std::vector<double> row;
    for (const uint32_t id : ids) {
      const auto found = std::find_if(sample.iou.begin(), sample.iou.end(),
                                      [&](const auto& entry) { return entry.first == id; });
      row.push_back(found != sample.iou.end() ? found->second : -1.0);
    }
    set_apart.push_back(belowTheFramesMedian(row));
    rows.push_back(std::move(row));
  }
  if (camera_ids != nullptr) *camera_ids = ids;
  return summariseHealthOverTime(frame_ids, rows, set_apart);
}

}  // namespace holofuse::render
