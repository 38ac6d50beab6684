// The texture-field pipeline's cost, measured in one run on the device the
// client would use: holoportation against montage4d per new mesh and per
// rendered view (targets: montage4d / holoportation <= 1.5 per mesh), the
// GPU time per pass (paper 000 Table 3), and the Vulkan passes against
// their CPU reference for the same work. Prints ratios; the machine is noisy.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "capture_node/synthetic_scene.h"
#include "render_client/reference/geodesics.h"
#include "render_client/reference/visibility.h"
#include "render_client/renderer.h"

using namespace holofuse;
using Clock = std::chrono::steady_clock;

namespace {

double ms(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const int meshes = argc > 1 ? std::max(2, std::atoi(argv[1])) : 4;
  const capture::SyntheticScene scene;
  const auto cameras = capture::SyntheticScene::cameraRig(4, 320, 240);
  render::VulkanContext context;
  std::printf("device: %s; 4 cameras at 320x240, output 320x240, %d meshes per mode\n", context.deviceName().c_str(),
              meshes);
  std::map<std::string, std::vector<double>> per_mesh, per_view;
  std::map<std::string, std::map<std::string, std::vector<double>>> passes;
  size_t vertices = 0;
  for (auto mode : {render::BlendMode::kHoloportation, render::BlendMode::kMontage4D}) {
    const std::string name = render::blendModeName(mode);
    render::Renderer renderer(context, 320, 240);
    render::BlendSettings settings;
    settings.mode = mode;
    for (int m = 0; m < meshes + 1; ++m) {  // the first mesh warms up the JIT
      const Mesh mesh = scene.truthMesh(10 + m, 0.02);
      vertices = mesh.vertexCount();
      std::vector<render::ViewImages> views;
      for (const auto& cam : cameras) {
        const auto truth = scene.render(cam, 10 + m);
        views.push_back({cam, truth.color, truth.mask});
      }
      renderer.setMesh(mesh);
      renderer.setViews(views);
      const auto t0 = Clock::now();
      renderer.render(cameras[1], settings);
      const auto t1 = Clock::now();
      renderer.render(cameras[2], settings);  // a second view of the same mesh
      const auto t2 = Clock::now();
      if (m == 0) continue;
      per_mesh[name].push_back(ms(t0, t1));
      per_view[name].push_back(ms(t1, t2));
      const auto times = renderer.fieldTimesMs();
      const auto& names = render::TextureFieldPasses::stageNames();
      for (size_t s = 0; s < times.size(); ++s) passes[name][names[s]].push_back(times[s]);
    }
  }
  std::printf("\n%-14s %16s %16s\n", "mode", "per new mesh ms", "per view ms");
  for (const auto& [name, v] : per_mesh) std::printf("%-14s %16.1f %16.1f\n", name.c_str(), median(v), median(per_view[name]));
  std::printf("montage4d / holoportation: %.2f per new mesh (target <= 1.5), %.2f per view\n",
              median(per_mesh["montage4d"]) / median(per_mesh["holoportation"]),
              median(per_view["montage4d"]) / median(per_view["holoportation"]));
  std::printf("\nGPU ms per pass (timestamps; on lavapipe the boundaries are approximate)\n%-30s", "pass");
  for (const auto& [name, p] : passes) std::printf(" %14s", name.c_str());
  std::printf("\n");
  for (const auto& stage : render::TextureFieldPasses::stageNames()) {
    std::printf("%-30s", stage.c_str());
    for (auto& [name, p] : passes) std::printf(" %14.1f", median(p[stage]));
    std::printf("\n");
  }
  // The CPU reference for the same per-mesh work (visibility, vote, seams,
  // geodesics) on the last mesh.
  const Mesh mesh = scene.truthMesh(10 + meshes, 0.02);
  std::vector<render::reference::PodView> views;
  for (const auto& cam : cameras) {
    const auto truth = scene.render(cam, 10 + meshes);
    views.push_back({cam, truth.color, truth.mask});
  }
  const auto c0 = Clock::now();
  const auto sights = render::reference::vertexSights(mesh, views);
  const auto c1 = Clock::now();
  const auto trusted = render::reference::majorityVote(mesh, views, sights);
  const auto c2 = Clock::now();
  const auto seams = render::reference::seamTriangles(mesh, sights, trusted);
  std::vector<uint8_t> source(mesh.vertexCount(), 0);
  size_t sources = 0, reached = 0;
  const auto c3 = Clock::now();
  for (size_t i = 0; i < views.size(); ++i) {
    std::fill(source.begin(), source.end(), 0);
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
      if (seams[i][t]) for (int k = 0; k < 3; ++k) source[mesh.indices[3 * t + k]] = 1;
    }
    const auto distance = render::reference::approximateGeodesic(mesh, source);
    sources += static_cast<size_t>(std::count(source.begin(), source.end(), 1));
    reached += static_cast<size_t>(std::count_if(distance.begin(), distance.end(), [](double d) { return std::isfinite(d); }));
  }
  const auto c4 = Clock::now();
  const double pairs = static_cast<double>(mesh.vertexCount() * views.size());
  std::printf("\nseam vertices: %.1f%% of (vertex, camera) pairs; within k rings of a seam: %.1f%%\n",
              100.0 * static_cast<double>(sources) / pairs, 100.0 * static_cast<double>(reached) / pairs);
  auto& m4 = passes["montage4d"];
  std::printf("\nCPU reference (one thread, double) against Vulkan, %zu vertices:\n", vertices);
  std::printf("  depth maps + discontinuities + visibility: CPU %.1f ms, Vulkan %.1f ms\n", ms(c0, c1),
              median(m4["depth_maps"]) + median(m4["discontinuities"]) + median(m4["dilation"]) +
                  median(m4["visibility"]));
  std::printf("  voting: CPU %.1f ms, Vulkan %.1f ms\n", ms(c1, c2), median(m4["voting"]));
  std::printf("  geodesics: CPU %.1f ms, Vulkan %.1f ms\n", ms(c3, c4), median(m4["geodesics"]));
  return 0;
}
