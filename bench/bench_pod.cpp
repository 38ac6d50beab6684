// What a synthetic pod's frame costs against what the server's hull does
// with it: the scene rendered by the reference tracer (the truth eval
// judges against) and by the closed-form ray caster the live pods use, the pod's
// segmentation and feather map, and the visual hull carved from the same
// frame's silhouettes, for the demo's rig (4 pods at 320x240 unless given).
// Also how far the closed-form picture is from the reference one. Ratios are
// measured in one run; the machine is noisy.
//   bench_pod [frames] [pods] [WxH]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench_timing.h"
#include "capture_node/pod.h"
#include "config/command_line.h"
#include "hull/visual_hull.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

using namespace holofuse;
using bench::Clock;
using bench::median;

namespace {

// How two renders of one view differ: colour per channel and the mask.
struct Agreement {
  size_t channels = 0, channels_over_2 = 0, mask_pixels = 0, mask_differs = 0;
  int worst = 0;
  double sum = 0;
  void add(const scene::RenderedView& a, const scene::RenderedView& b) {
    for (size_t i = 0; i < a.color.pixels.size(); ++i) {
      const int d = std::abs(int(a.color.pixels[i]) - int(b.color.pixels[i]));
      ++channels;
      channels_over_2 += d > 2;
      worst = std::max(worst, d);
      sum += d;
    }
    for (size_t i = 0; i < a.mask.pixels.size(); ++i) {
      ++mask_pixels;
      mask_differs += a.mask.pixels[i] != b.mask.pixels[i];
    }
  }
};

}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::max(1, std::atoi(argv[1])) : 6;
  const int pods = argc > 2 ? std::clamp(std::atoi(argv[2]), 1, 128) : 4;
  unsigned width = 320, height = 240;
  if (argc > 3) {
    if (const std::string error = parseImageSize(argv[3], width, height); !error.empty()) {
      std::fprintf(stderr, "size %s\n", error.c_str());
      return 2;
    }
  }
  const scene::SyntheticScene scene;
  const auto cameras = scene::SyntheticScene::cameraRig(pods, width, height);
  std::vector<Image8> plates;
  std::vector<scene::CameraRenderer> renderers;
  for (const auto& camera : cameras) {
    plates.push_back(scene.backgroundPlate(camera));
    renderers.emplace_back(scene, camera);
  }
  std::vector<double> reference_ms, fast_ms, silhouette_ms, pod_ms, hull_ms;
  Agreement agreement;
  std::fprintf(stderr, "bench_pod: %d frames x %d pods at %ux%u\n", frames, pods, width, height);
  for (int f = 0; f < frames; ++f) {
    const uint64_t frame_id = 30 + static_cast<uint64_t>(f);
    std::vector<hull::HullView> views;
    for (size_t i = 0; i < cameras.size(); ++i) {
      const auto t0 = Clock::now();
      const scene::RenderedView reference = scene.render(cameras[i], frame_id);
      const auto t1 = Clock::now();
      const scene::RenderedView fast = renderers[i].render(frame_id);
      const auto t2 = Clock::now();
      Image8 mask = segmentForeground(fast.color, plates[i]);
      Image8 feather = featherMap(mask);
      const auto t3 = Clock::now();
      reference_ms.push_back(bench::ms(t0, t1));
      fast_ms.push_back(bench::ms(t1, t2));
      silhouette_ms.push_back(bench::ms(t2, t3));
      pod_ms.push_back(bench::ms(t1, t3));
      agreement.add(reference, fast);
      views.push_back({cameras[i], std::move(mask), std::move(feather)});
    }
    const auto t0 = Clock::now();
    const Mesh mesh = hull::carveVisualHull(views, hull::HullOptions{});
    hull_ms.push_back(bench::ms(t0, Clock::now()));
    std::fprintf(stderr, "\r  frame %d/%d", f + 1, frames);
  }
  std::fprintf(stderr, "\n");
  const double reference = median(reference_ms), fast = median(fast_ms),
               silhouette = median(silhouette_ms), pod = median(pod_ms), hull = median(hull_ms);
  std::printf("%d pods at %ux%u, %d frames of the synthetic subject (medians)\n\n", pods, width,
              height, frames);
  std::printf("%-44s %9s\n", "stage", "ms");
  std::printf("%-44s %9.2f\n", "render, reference tracer (eval's truth)", reference);
  std::printf("%-44s %9.2f\n", "render, closed form (live pods)", fast);
  std::printf("%-44s %9.2f\n", "segmentation + feather map", silhouette);
  std::printf("%-44s %9.2f\n", "pod frame (closed-form render + silhouette)", pod);
  std::printf("%-44s %9.2f\n", "hull carve of the frame (server, 20 mm)", hull);
  std::printf("\nclosed-form render: %.1fx faster than the reference\n", reference / fast);
  std::printf("pod frame / hull carve: %.2f (target: at most 1)\n", pod / hull);
  std::printf(
      "closed form against reference: mean |difference| %.4f grey levels, %.3f%% of channels "
      "off by more than 2, worst %d; mask differs on %.3f%% of pixels\n",
      agreement.sum / std::max<size_t>(agreement.channels, 1),
      100.0 * agreement.channels_over_2 / std::max<size_t>(agreement.channels, 1), agreement.worst,
      100.0 * agreement.mask_differs / std::max<size_t>(agreement.mask_pixels, 1));
  return 0;
}
