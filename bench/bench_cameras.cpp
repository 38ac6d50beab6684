// What the camera count costs, 8 to 128 cameras of the synthetic ring in
// one run: per new mesh, the texture fields' per-camera stages (depth
// maps, discontinuities, visibility and the field of holoportation; seams
// and geodesics too in montage4d); per rendered view, each mode's blend
// with its fields in place; and the visual hull from the pods' own
// silhouettes. The exponent of each cost in N is fitted by least squares
// of log ms on log N (target: at most 1.1 for the per-camera stages and
// the hull, about 0 for the blend of each vertex's best views). Then one
// leave-one-out eval of 128 cameras through holofuse_eval. The machine is
// shared and noisy: read the exponents, not the milliseconds.
//
// Usage: bench_cameras [meshes per count, 3] [pod image width, 160]. A
// smaller pod image (same output) tells the per-view blend's work from
// the memory its N images occupy: the blend reads K cameras per fragment,
// but N images of texture, and at 160x120 and 128 cameras those outgrow
// the CPU's caches on a software device.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "base/process.h"
#include "bench_timing.h"
#include "capture_node/pod.h"
#include "hull/visual_hull.h"
#include "render_client/renderer.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

using namespace holofuse;
using bench::Clock;
using bench::median;

namespace {

// The slope of log(ms) against log(cameras).
double fittedExponent(const std::vector<int>& cameras, const std::vector<double>& ms) {
  double mx = 0, my = 0;
  for (size_t k = 0; k < cameras.size(); ++k) {
    mx += std::log(cameras[k]);
    my += std::log(std::max(ms[k], 1e-6));
  }
  mx /= static_cast<double>(cameras.size());
  my /= static_cast<double>(cameras.size());
  double sxy = 0, sxx = 0;
  for (size_t k = 0; k < cameras.size(); ++k) {
    const double x = std::log(cameras[k]) - mx;
    sxy += x * (std::log(std::max(ms[k], 1e-6)) - my);
    sxx += x * x;
  }
  return sxx > 0 ? sxy / sxx : 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  const int meshes = argc > 1 ? std::max(2, std::atoi(argv[1])) : 3;
  constexpr uint32_t kWidth = 160, kHeight = 120;
  const uint32_t pod_width = argc > 2 ? static_cast<uint32_t>(std::atoi(argv[2])) : kWidth;
  const uint32_t pod_height = pod_width * 3 / 4;
  const std::vector<int> counts = {8, 16, 32, 64, 128};
  const scene::SyntheticScene scene;
  gpu::VulkanContext context;
  std::printf("device: %s; cameras on the ring at %ux%u, output %ux%u, %d meshes per count\n\n",
              context.deviceName().c_str(), pod_width, pod_height, kWidth, kHeight, meshes);
  std::vector<Mesh> surfaces;
  for (int m = 0; m < meshes; ++m) surfaces.push_back(scene.truthMesh(40 + m, 0.015));
  const std::vector<std::string> columns = {"holoportation mesh",
                                            "montage4d mesh",
                                            "holoportation view",
                                            "montage4d view",
                                            "normal view",
                                            "fragment view",
                                            "hull"};
  std::map<std::string, std::vector<double>> cost;
  std::printf("%8s", "cameras");
  for (const auto& c : columns) std::printf(" %18s", c.c_str());
  std::printf("   (median ms)\n");
  for (int n : counts) {
    const auto rig = scene::SyntheticScene::cameraRig(n, pod_width, pod_height);
    std::vector<render::ViewImages> views;
    std::vector<hull::HullView> silhouettes;
    for (const auto& camera : rig) {
      const auto truth = scene.render(camera, 40);
      views.push_back({camera, truth.color, truth.mask, featherMap(truth.mask)});
      capture::PodCapture pod = capture::capturePodFrame(
          scene, camera, scene.backgroundPlate(camera), 40, static_cast<uint16_t>(camera.id));
      silhouettes.push_back({camera, pod.mask, pod.feather});
    }
    // The user between pods 0 and 1, moved a little per view.
    auto user = [&](int k) {
      return scene::SyntheticScene::ringPose(360.0 / n * 0.5 + 0.7 * k, 999, kWidth, kHeight);
    };
    auto timed = [&](render::Renderer& renderer, render::BlendMode mode, bool new_mesh, int k) {
      render::BlendSettings settings;
      settings.mode = mode;
      if (new_mesh) renderer.setMesh(surfaces[static_cast<size_t>(k) % surfaces.size()]);
      const auto t0 = Clock::now();
      renderer.render(user(k), settings);
      return bench::ms(t0, Clock::now());
    };
    std::map<std::string, std::vector<double>> samples;
    for (render::BlendMode mode : {render::BlendMode::kHoloportation, render::BlendMode::kMontage4D,
                                   render::BlendMode::kNormal, render::BlendMode::kFragment}) {
      const std::string name = render::blendModeName(mode);
      render::Renderer renderer(context, kWidth, kHeight);
      renderer.setViews(views);
      timed(renderer, mode, true, 0);  // warm
      for (int k = 1; k <= meshes; ++k) {
        const double mesh_ms = timed(renderer, mode, true, k);
        const double view_ms = timed(renderer, mode, false, k);  // the same mesh, a new view
        if (mode == render::BlendMode::kHoloportation || mode == render::BlendMode::kMontage4D)
          samples[name + " mesh"].push_back(mesh_ms);
        samples[name + " view"].push_back(view_ms);
      }
    }
    hull::HullOptions hull_options;
    hull_options.voxel_size = 0.02;
    hull::carveVisualHull(silhouettes, hull_options);  // warm
    for (int k = 0; k < meshes; ++k) {
      const auto t0 = Clock::now();
      hull::carveVisualHull(silhouettes, hull_options);
      samples["hull"].push_back(bench::ms(t0, Clock::now()));
    }
    std::printf("%8d", n);
    for (const auto& c : columns) {
      cost[c].push_back(median(samples[c]));
      std::printf(" %18.1f", cost[c].back());
    }
    std::printf("\n");
    std::fflush(stdout);
  }
  std::printf("%8s", "exponent");
  for (const auto& c : columns) std::printf(" %18.2f", fittedExponent(counts, cost[c]));
  // Past the default 8 best views the blend's work per pixel stops
  // growing: the exponent over 16 to 128 cameras shows what is left.
  const std::vector<int> past_k(counts.begin() + 1, counts.end());
  std::printf("\n%8s", "16-128");
  for (const auto& c : columns) {
    const std::vector<double> tail(cost[c].begin() + 1, cost[c].end());
    std::printf(" %18.2f", fittedExponent(past_k, tail));
  }
  std::printf(
      "\n   (ms ~ N^exponent; target: <= 1.1 per new mesh and for the hull, ~0 for the blend "
      "of a view;\n   montage4d's view includes its per-view field and fragment's its per-view "
      "ranking, both per camera)\n\n");

  // A 128-camera leave-one-out eval, end to end (pods' images, hull, every
  // mode, metrics), as a user would run it.
  const std::filesystem::path bin = std::filesystem::path(argv[0]).parent_path();
  const std::filesystem::path out = std::filesystem::temp_directory_path() / "holofuse_bench_128";
  std::filesystem::remove_all(out);
  const auto t0 = Clock::now();
  auto eval = spawnProcess({(bin / "holofuse_eval").string(), "--scenes", "clean", "--pods", "128",
                            "--frames", "1", "--held-out", "4", "--size", "96x72", "--modes",
                            "normal,holoportation,montage4d", "--out", out.string()},
                           {(out.string() + ".log")});
  if (!eval.isOk()) {
    std::printf("128-camera eval: %s\n", eval.status().toString().c_str());
    return 1;
  }
  const auto code = waitProcess(*eval, -1);
  std::printf(
      "128-camera eval (4 held out, 96x72, normal, holoportation, montage4d): exit %d in "
      "%.1f s; %s/quality.md\n",
      code.value_or(-1), bench::ms(t0, Clock::now()) / 1000.0, out.string().c_str());
  return code == 0 ? 0 : 1;
}
