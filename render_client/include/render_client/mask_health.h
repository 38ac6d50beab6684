// Each pod's mask against the hull the server fused from all of them, as
// the client receives both: about once a second, on a thread of its own
// (never on the render path), each camera's mask IoU with the hull's
// silhouette in that camera. A mask holding what no other camera sees (a
// prop, a light) or missing what the others see falls under that frame's
// median; the report names the camera and the frames
// (metrics/health_over_time.h). A client may run for days: when
// kSamplesKept samples are held, every other one is dropped and the
// interval doubles, so the samples stay evenly spread over the run in
// bounded memory.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "geometry/mesh.h"
#include "metrics/health_over_time.h"
#include "render_client/renderer.h"

namespace holofuse::render {

class MaskHealthSampler {
 public:
  static constexpr size_t kSamplesKept = 512;

  explicit MaskHealthSampler(uint64_t interval_ns = 1000000000ull);
  ~MaskHealthSampler();
  MaskHealthSampler(const MaskHealthSampler&) = delete;
  MaskHealthSampler& operator=(const MaskHealthSampler&) = delete;

  // A frame as rendered: measured when a sample is due and the thread is
  // free (copies of the mesh and the masks go to it), else passed over.
  void offer(uint64_t frame_id, uint64_t now_ns, const Mesh& mesh,
             const std::vector<ViewImages>& views);
  // Every sample kept, the one in flight included; camera_ids: the
  // cameras' ids in its order.
  HealthOverTime summary(std::vector<uint32_t>* camera_ids = nullptr);
  // The time between samples now: the first interval, doubled at each halving.
  uint64_t intervalNs() const { return interval_ns_; }

 private:
  struct Job {
    uint64_t frame_id = 0;
    Mesh mesh;
    std::vector<Camera> cameras;
    std::vector<Image8> masks;
  };
  void run();

  std::atomic<uint64_t> interval_ns_;
  uint64_t last_offer_ns_ = 0;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<Job> job_;
  bool busy_ = false, stop_ = false;
  // Per sample, each measured camera's IoU by its id: a frame may lack a
  // camera (a group sent without a late pod), so a sample's position is
  // not a camera.
  struct Sample {
    uint64_t frame_id = 0;
    std::vector<std::pair<uint32_t, double>> iou;
  };
  std::vector<Sample> samples_;
  std::thread thread_;
};

}  // namespace holofuse::render
