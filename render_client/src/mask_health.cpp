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
    std::map<uint32_t, double> iou;
    for (size_t c = 0; c < job.cameras.size(); ++c) {
      const Camera& camera = job.cameras[c];
      const Image8& mask = job.masks[c];
      // A view without its whole mask is not measured.
      if (mask.width != camera.width || mask.height != camera.height) continue;
      iou[camera.id] = metrics::silhouetteIoU(job.mesh, camera, mask);
    }
    std::lock_guard<std::mutex> lock(mutex_);
    frame_ids_.push_back(job.frame_id);
    values_.push_back(std::move(iou));
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
  for (const auto& sample : values_)
    for (const auto& [id, value] : sample)
      if (std::find(ids.begin(), ids.end(), id) == ids.end()) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  std::vector<std::vector<double>> rows;
  std::vector<std::vector<bool>> set_apart;
  for (const auto& sample : values_) {
    std::vector<double> row;
    for (const uint32_t id : ids) {
      const auto found = sample.find(id);
      row.push_back(found != sample.end() ? found->second : -1.0);
    }
    set_apart.push_back(belowTheFramesMedian(row));
    rows.push_back(std::move(row));
  }
  if (camera_ids != nullptr) *camera_ids = ids;
  return summariseHealthOverTime(frame_ids_, rows, set_apart);
}

}  // namespace holofuse::render
