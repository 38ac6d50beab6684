#include "render_client/mask_health.h"

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
    std::vector<double> iou;
    for (size_t c = 0; c < job.cameras.size(); ++c) {
      const Camera& camera = job.cameras[c];
      const Image8& mask = job.masks[c];
      if (mask.width != camera.width || mask.height != camera.height) {
        iou.push_back(-1.0);  // a view without its whole mask
        continue;
      }
      iou.push_back(metrics::silhouetteIoU(job.mesh, camera, mask));
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (camera_ids_.empty())
      for (const Camera& camera : job.cameras) camera_ids_.push_back(camera.id);
    frame_ids_.push_back(job.frame_id);
    values_.push_back(std::move(iou));
    busy_ = false;
    changed_.notify_all();
  }
}

HealthOverTime MaskHealthSampler::summary(std::vector<uint32_t>* camera_ids) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return !busy_ && !job_; });
  if (camera_ids != nullptr) *camera_ids = camera_ids_;
  std::vector<std::vector<bool>> set_apart;
  for (const auto& frame : values_) set_apart.push_back(belowTheFramesMedian(frame));
  return summariseHealthOverTime(frame_ids_, values_, set_apart);
}

}  // namespace holofuse::render
