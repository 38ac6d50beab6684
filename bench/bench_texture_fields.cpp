// The texture-field pipeline's cost, measured in one run on the device the
// client would use: every mode's ms per new mesh and per rendered view
// against normal's, holoportation against montage4d per new mesh (target:
// montage4d / holoportation <= 1.25, issue 24), the
// GPU time per pass (paper 000 Table 3), and the Vulkan passes against
// their CPU reference for the same work. Prints ratios; the machine is noisy.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench_timing.h"
#include "render_client/reference/depth_map.h"
#include "render_client/reference/geodesics.h"
#include "render_client/reference/texture_fields.h"
#include "render_client/reference/visibility.h"
#include "render_client/renderer.h"
#include "render_client/temporal_carry.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

using namespace holofuse;
using bench::Clock;
using bench::median;
using bench::ms;

namespace {

// What every measurement runs on: the scene, its pods, the device, and how
// many meshes each mode renders per round.
struct Setup {
  const scene::SyntheticScene& scene;
  const std::vector<Camera>& cameras;
  gpu::VulkanContext& context;
  int meshes;
};

// ms by name (a mode's or a pass's), one value per mesh.
using Times = std::map<std::string, std::vector<double>>;

// What measureModes collects, by mode name.
struct ModeCosts {
  Times per_mesh, per_view;
  std::map<std::string, Times> passes;             // GPU ms by mode, then by pass
  std::vector<double> mesh_ratios, view_ratios;    // montage4d / holoportation, per mesh
  Times mesh_against_normal, view_against_normal;  // per mesh
  size_t vertices = 0;                             // of the last mesh
};

// Rounds of measureModes: every mode renders each mesh once per round.
constexpr int kRounds = 3;
// Stages recorded this many times in one frame (FieldParameters::repeated_stage).
constexpr int kRepeats = 21;

// The pods' true views of frame `frame`, as View (render::ViewImages or
// render::reference::PodView).
template <typename View>
std::vector<View> truthViews(const scene::SyntheticScene& scene, const std::vector<Camera>& cameras,
                             uint64_t frame) {
  std::vector<View> views;
  for (const auto& cam : cameras) {
    const auto truth = scene.render(cam, frame);
    views.push_back({cam, truth.color, truth.mask, featherMap(truth.mask)});
  }
  return views;
}

// The reference's pod views as the renderer takes them.
std::vector<render::ViewImages> rendererViews(
    const std::vector<render::reference::PodView>& views) {
  std::vector<render::ViewImages> pod_views;
  for (const auto& v : views) pod_views.push_back({v.camera, v.color, v.mask, v.feather});
  return pod_views;
}

// Every mode's ms per new mesh and per rendered view, and its GPU ms per pass.
// Rounds: in each, the same meshes in turn, and each mesh rendered by
// every mode's own renderer (warm, as a client running one mode is),
// back to back, in an order that rotates from mesh to mesh. A ratio
// between two modes is taken per mesh, from renders tens of ms apart, so
// that a change in this shared machine's load between them is all that
// can move it; the report gives the median and the quartiles over every
// mesh of every round. The first mesh of a round warms up (JIT, caches,
// the carry) and is not counted.
ModeCosts measureModes(const Setup& setup) {
  const std::vector<render::BlendMode> modes = {
      render::BlendMode::kNormal, render::BlendMode::kHoloportation, render::BlendMode::kMontage4D,
      render::BlendMode::kFragment};
  std::vector<std::unique_ptr<render::Renderer>> renderers;
  for (size_t k = 0; k < modes.size(); ++k)
    renderers.push_back(std::make_unique<render::Renderer>(setup.context, 320, 240));
  ModeCosts costs;
  for (int round = 0; round < kRounds; ++round) {
    for (int m = 0; m < setup.meshes + 1; ++m) {
      const Mesh mesh = setup.scene.truthMesh(10 + m, 0.02);
      costs.vertices = mesh.vertexCount();
      const auto views = truthViews<render::ViewImages>(setup.scene, setup.cameras, 10 + m);
      std::map<std::string, double> mesh_ms, view_ms;
      for (size_t turn = 0; turn < modes.size(); ++turn) {
        const size_t k = (turn + static_cast<size_t>(m + round)) % modes.size();
        const std::string name = render::blendModeName(modes[k]);
        render::Renderer& renderer = *renderers[k];
        render::BlendSettings settings;
        settings.mode = modes[k];
        renderer.setMesh(mesh);
        renderer.setViews(views);
        const auto t0 = Clock::now();
        renderer.render(setup.cameras[1], settings);
        const auto t1 = Clock::now();
        renderer.render(setup.cameras[2], settings);  // a second view of the same mesh
        const auto t2 = Clock::now();
        if (m == 0) continue;
        mesh_ms[name] = ms(t0, t1);
        view_ms[name] = ms(t1, t2);
        costs.per_mesh[name].push_back(ms(t0, t1));
        costs.per_view[name].push_back(ms(t1, t2));
        if (modes[k] == render::BlendMode::kNormal) continue;  // no field passes to time
        const auto times = renderer.fieldTimesMs();
        const auto& names = render::TextureFieldPasses::stageNames();
        for (size_t s = 0; s < times.size(); ++s) {
          if (times[s] >= 0)
            costs.passes[name][names[s]].push_back(times[s]);  // -1: a pass this mode does not have
        }
      }
      if (m == 0) continue;
      costs.mesh_ratios.push_back(mesh_ms["montage4d"] / mesh_ms["holoportation"]);
      costs.view_ratios.push_back(view_ms["montage4d"] / view_ms["holoportation"]);
      for (const auto& [name, v] : mesh_ms) {
        costs.mesh_against_normal[name].push_back(v / mesh_ms["normal"]);
        costs.view_against_normal[name].push_back(view_ms[name] / view_ms["normal"]);
      }
    }
  }
  return costs;
}

// The modes' table (medians, ratios to normal's) and montage4d against
// holoportation per new mesh.
void printModeCosts(const ModeCosts& costs, int meshes) {
  std::printf(
      "\n%-14s %16s %16s %18s %18s   (medians over %d rounds of %d meshes; ratios per mesh)\n",
      "mode", "per new mesh ms", "per view ms", "mesh / normal's", "view / normal's", kRounds,
      meshes);
  for (const auto& [name, v] : costs.per_mesh) {
    std::printf("%-14s %16.1f %16.1f %18.2f %18.2f\n", name.c_str(), median(v),
                median(costs.per_view.at(name)), median(costs.mesh_against_normal.at(name)),
                median(costs.view_against_normal.at(name)));
  }
  const auto& mesh_ratios = costs.mesh_ratios;
  std::printf(
      "montage4d / holoportation per new mesh: %.2f, the median of %zu meshes each rendered by "
      "both "
      "(quartiles %.2f to %.2f; target <= 1.25); per view %.2f\n",
      median(mesh_ratios), mesh_ratios.size(), bench::quantile(mesh_ratios, 0.25),
      bench::quantile(mesh_ratios, 0.75), median(costs.view_ratios));
}

// Each mode's GPU ms per field pass, by timestamps.
void printPassTimes(const std::map<std::string, Times>& passes) {
  std::printf("\nGPU ms per pass (timestamps; on lavapipe the boundaries are approximate)\n%-30s",
              "pass");
  for (const auto& [name, p] : passes) std::printf(" %14s", name.c_str());
  std::printf("\n");
  for (const auto& stage : render::TextureFieldPasses::stageNames()) {
    std::printf("%-30s", stage.c_str());
    for (const auto& [name, p] : passes) {
      const auto times = p.find(stage);
      if (times == p.end() || times->second.empty()) {
        std::printf(" %14s", "-");
      } else {
        std::printf(" %14.1f", median(times->second));
      }
    }
    std::printf("\n");
  }
}

// The reference votes as the renderer does by default (delta 0: no vote).
render::reference::VoteOptions voteAsRendered(const render::FieldParameters& defaults) {
  render::reference::VoteOptions vote;
  vote.delta = defaults.vote_delta;
  vote.levels = defaults.vote_levels;
  return vote;
}

// The geodesics as the renderer runs them: k rings, K passes, the
// geodesic radius, into the vertices camera i sees.
std::vector<double> geodesicsAsRendered(const Mesh& mesh, const render::FieldParameters& defaults,
                                        const std::vector<uint8_t>& source,
                                        const std::vector<render::reference::Sight>& sight) {
  render::reference::GeodesicOptions options;
  options.max_rings = defaults.geodesic_rings;
  options.iterations = defaults.geodesic_iterations;
  options.max_distance = defaults.geodesic_radius;
  options.region.resize(sight.size());
  for (size_t v = 0; v < sight.size(); ++v)
    options.region[v] = sight[v] == render::reference::Sight::kVisible;
  return render::reference::approximateGeodesic(mesh, source, options);
}

// Sets `source` to 1 at the vertices of one camera's seam triangles, 0 elsewhere.
void markSeamVertices(const Mesh& mesh, const std::vector<uint8_t>& seams,
                      std::vector<uint8_t>& source) {
  std::fill(source.begin(), source.end(), 0);
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    if (seams[t])
      for (int k = 0; k < 3; ++k) source[mesh.indices[3 * t + k]] = 1;
  }
}

// Seam triangles over (triangle, camera) pairs, and the geodesics' sources
// and reached vertices over (vertex, camera) pairs.
struct SeamCounts {
  size_t sources = 0, reached = 0;
  size_t rule_triangles[3] = {0, 0, 0}, seam_triangles = 0;
};

// The CPU reference's geodesics from every camera's seams, counted.
SeamCounts seamGeodesics(const Mesh& mesh, const render::FieldParameters& defaults,
                         const std::vector<std::vector<uint8_t>>& seams,
                         const std::vector<std::vector<render::reference::Sight>>& sights) {
  SeamCounts counts;
  for (const auto& per_camera : seams) {
    for (uint8_t rules : per_camera) {
      counts.seam_triangles += rules != 0;
      for (int r = 0; r < 3; ++r) counts.rule_triangles[r] += (rules >> r) & 1;
    }
  }
  std::vector<uint8_t> source(mesh.vertexCount(), 0);
  for (size_t i = 0; i < seams.size(); ++i) {
    markSeamVertices(mesh, seams[i], source);
    const auto distance = geodesicsAsRendered(mesh, defaults, source, sights[i]);
    counts.sources += static_cast<size_t>(std::count(source.begin(), source.end(), 1));
    counts.reached += static_cast<size_t>(
        std::count_if(distance.begin(), distance.end(), [](double d) { return std::isfinite(d); }));
  }
  return counts;
}

// The seams the CPU reference found, as shares of the (vertex or triangle, camera) pairs.
void printSeamCounts(const SeamCounts& counts, const Mesh& mesh, size_t cameras) {
  const double pairs = static_cast<double>(mesh.vertexCount() * cameras);
  std::printf(
      "\nseam vertices: %.1f%% of (vertex, camera) pairs; reached (within k rings and the radius, "
      "in view): %.1f%%\n",
      100.0 * static_cast<double>(counts.sources) / pairs,
      100.0 * static_cast<double>(counts.reached) / pairs);
  // Paper 000 section 4.3 saw under 1% seam triangles on its captures.
  const double triangle_pairs = static_cast<double>(mesh.triangleCount() * cameras);
  std::printf(
      "seam triangles: %.1f%% of (triangle, camera) pairs; by rule (a triangle may have several): "
      "occlusion "
      "%.1f%%, vote %.1f%%, field of view %.1f%%\n",
      100.0 * static_cast<double>(counts.seam_triangles) / triangle_pairs,
      100.0 * static_cast<double>(counts.rule_triangles[0]) / triangle_pairs,
      100.0 * static_cast<double>(counts.rule_triangles[1]) / triangle_pairs,
      100.0 * static_cast<double>(counts.rule_triangles[2]) / triangle_pairs);
}

// The CPU reference's ms per stage (visibility, vote, seams, geodesics) on
// the mesh, each stage timed alone, best of three (the machine is noisy);
// prints the seams it found.
std::map<std::string, double> cpuReferenceStages(
    const Mesh& mesh, const std::vector<render::reference::PodView>& views) {
  const render::FieldParameters defaults;
  const auto vote = voteAsRendered(defaults);
  std::map<std::string, double> cpu;
  auto best = [&](const std::string& stage, double value) {
    cpu[stage] = cpu.count(stage) ? std::min(cpu[stage], value) : value;
  };
  SeamCounts counts;
  for (int repeat = 0; repeat < 3; ++repeat) {
    auto c0 = Clock::now();
    std::vector<render::reference::DepthMap> maps;
    for (const auto& view : views)
      maps.push_back(render::reference::rasterizeDepth(mesh, view.camera));
    auto c1 = Clock::now();
    for (const auto& map : maps) render::reference::dilatedDiscontinuities(map);
    auto c2 = Clock::now();
    const auto sights = render::reference::vertexSights(
        mesh, views);  // maps and discontinuities again, then the tests
    auto c3 = Clock::now();
    const auto trusted = render::reference::majorityVote(mesh, views, sights, vote);
    auto c4 = Clock::now();
    const auto seams = render::reference::seamTriangles(mesh, sights, trusted);
    render::reference::globalVisibility(render::reference::finalVisibility(sights, trusted));
    auto c5 = Clock::now();
    counts = seamGeodesics(mesh, defaults, seams, sights);
    auto c6 = Clock::now();
    best("depth_maps", ms(c0, c1));
    best("discontinuities", ms(c1, c2));
    // vertexSights draws the maps and finds the discontinuities again:
    // its visibility tests cost the best of it less the best of those
    // (the best of each difference would keep the luckiest noise).
    best("sights_with_maps", ms(c2, c3));
    best("maps_and_discontinuities", ms(c0, c2));
    best("voting", ms(c3, c4));
    best("seams_and_global_visibility", ms(c4, c5));
    best("geodesics", ms(c5, c6));
  }
  cpu["visibility"] = std::max(0.0, cpu["sights_with_maps"] - cpu["maps_and_discontinuities"]);
  printSeamCounts(counts, mesh, views.size());
  return cpu;
}

// gamma of eq. 4 for every camera: the geodesic distance from its seams
// over `scale`, clamped to 0..1; 1 where the geodesics do not reach.
render::reference::Field seamGamma(const Mesh& mesh, const render::FieldParameters& defaults,
                                   const std::vector<std::vector<uint8_t>>& seams,
                                   const std::vector<std::vector<render::reference::Sight>>& sights,
                                   double scale) {
  render::reference::Field gamma(seams.size(), std::vector<double>(mesh.vertexCount(), 1.0));
  std::vector<uint8_t> source(mesh.vertexCount(), 0);
  for (size_t i = 0; i < seams.size(); ++i) {
    markSeamVertices(mesh, seams[i], source);
    const auto distance = geodesicsAsRendered(mesh, defaults, source, sights[i]);
    for (size_t v = 0; v < mesh.vertexCount(); ++v) {
      if (std::isfinite(distance[v])) gamma[i][v] = std::clamp(distance[v] / scale, 0.0, 1.0);
    }
  }
  return gamma;
}

// How often montage4d's field is used at all: where the geodesic
// fields sum below 1 the normal-weighted (holoportation) field is
// (paper 000 section 4.5). Seen from between pods 0 and 1.
void printMontageFieldUse(const Mesh& mesh, const std::vector<render::reference::PodView>& views,
                          const std::vector<Camera>& cameras) {
  namespace ref = render::reference;
  const render::FieldParameters defaults;
  const auto sights = ref::vertexSights(mesh, views);
  const auto trusted = ref::majorityVote(mesh, views, sights, voteAsRendered(defaults));
  const auto seams = ref::seamTriangles(mesh, sights, trusted);
  const auto visible = ref::finalVisibility(sights, trusted);
  const double scale = defaults.geodesic_radius > 0
                           ? defaults.geodesic_radius
                           : defaults.geodesic_rings * meanEdgeLength(mesh);
  const ref::Field gamma = seamGamma(mesh, defaults, seams, sights, scale);
  const glm::dvec3 eye = 0.5 * (cameras[0].center() + cameras[1].center());
  const auto target =
      ref::montageTargetField(mesh, cameras, visible, ref::globalVisibility(visible), gamma, eye,
                              render::BlendSettings{}.beta);
  const auto blend =
      ref::normalizeFields(target, gamma, ref::holoportationField(mesh, cameras, visible, 2.0));
  // Counted over the vertices facing the eye, which are what a picture
  // from there shows: behind the subject every pod's view weight is 0
  // and the field is empty by design.
  size_t facing = 0, fallback = 0, no_field = 0;
  size_t seen_by[4] = {0, 0, 0, 0};  // 1, 2, 3, 4 or more pods
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    const glm::dvec3 p(mesh.positions[v]);
    if (blend.hole[v] || !(glm::dot(glm::dvec3(mesh.normals[v]), eye - p) > 0)) continue;
    ++facing;
    double gamma_sum = 0;
    size_t pods = 0;
    for (size_t i = 0; i < views.size(); ++i) {
      gamma_sum += gamma[i][v];
      pods += visible[i][v] != 0;
    }
    if (pods > 0) ++seen_by[std::min<size_t>(pods, 4) - 1];
    if (blend.fallback[v]) ++(gamma_sum >= 1.0 ? no_field : fallback);
  }
  const double n = std::max<double>(1.0, static_cast<double>(facing));
  std::printf(
      "of the %zu seen vertices facing a view between pods 0 and 1: seen by 1 pod %.1f%%, 2 pods "
      "%.1f%%, "
      "3 %.1f%%, 4 %.1f%% (only where two or more see a vertex can the modes' weights differ)\n",
      facing, 100.0 * static_cast<double>(seen_by[0]) / n,
      100.0 * static_cast<double>(seen_by[1]) / n, 100.0 * static_cast<double>(seen_by[2]) / n,
      100.0 * static_cast<double>(seen_by[3]) / n);
  std::printf(
      "montage4d falls back to normal weighting there at %.1f%%: %.1f%% where the geodesic "
      "fields sum "
      "below 1 (normalising distance, the geodesic radius: %.0f mm), %.1f%% where every seeing "
      "pod's "
      "target is 0 (the vertex is on its seams)\n",
      100.0 * static_cast<double>(fallback + no_field) / n,
      100.0 * static_cast<double>(fallback) / n, 1000 * scale,
      100.0 * static_cast<double>(no_field) / n);
}

// Each Vulkan stage by wall clock: montage4d renders of the same new mesh
// that stop after stage k (FieldParameters::last_stage), interleaved so
// the machine's noise spreads over every stop; stage k costs the median
// at k minus the median at k - 1. Timestamps on a CPU device put lazily
// rasterised depth maps into later passes.
void printWallClockPerStage(const Setup& setup, const Mesh& mesh,
                            const std::vector<render::reference::PodView>& views) {
  const auto& stage_names = render::TextureFieldPasses::stageNames();
  std::vector<std::vector<double>> stop_ms(stage_names.size());
  {
    render::Renderer renderer(setup.context, 320, 240);
    render::BlendSettings settings;
    settings.mode = render::BlendMode::kMontage4D;
    const auto pod_views = rendererViews(views);
    for (int repeat = 0; repeat < 2 + 2 * setup.meshes; ++repeat) {
      for (size_t k = 0; k < stage_names.size(); ++k) {
        settings.fields.last_stage = static_cast<int>(k);
        renderer.setMesh(mesh);
        renderer.setViews(pod_views);
        const auto t0 = Clock::now();
        renderer.render(setup.cameras[1], settings);
        if (repeat > 0) stop_ms[k].push_back(ms(t0, Clock::now()));  // the first round warms up
      }
    }
  }
  auto wall = [&](size_t stage) {
    return median(stop_ms[stage]) - (stage > 0 ? median(stop_ms[stage - 1]) : 0.0);
  };
  std::printf(
      "\nVulkan per stage by wall clock (montage4d renders stopping after each stage, medians of "
      "%zu; a "
      "difference under about 1 ms is within a shared machine's noise):\n",
      stop_ms[0].size());
  for (size_t k = 1; k < stage_names.size(); ++k)
    std::printf("%-30s %10.1f ms\n", stage_names[k].c_str(), wall(k));
}

// Renders of the mesh, each with one stage of `stages` recorded kRepeats
// times (-1: none), interleaved so the machine's noise spreads over all
// of them; by stage, the first round left out (it warms up).
std::map<int, std::vector<double>> repeatedRuns(const Setup& setup, const Mesh& mesh,
                                                render::Renderer& renderer,
                                                render::BlendSettings settings,
                                                const std::vector<render::ViewImages>& pod_views,
                                                const std::vector<int>& stages) {
  std::map<int, std::vector<double>> runs;
  for (int round = 0; round < 2 + 2 * setup.meshes; ++round) {
    for (int stage : stages) {
      settings.fields.repeated_stage = stage;
      settings.fields.stage_repeats = kRepeats;
      renderer.setMesh(mesh);
      renderer.setViews(pod_views);
      const auto t0 = Clock::now();
      renderer.render(setup.cameras[1], settings);
      if (round > 0) runs[stage].push_back(ms(t0, Clock::now()));
    }
  }
  return runs;
}

// The small stages once more, each recorded kRepeats times in one frame
// (FieldParameters::repeated_stage): the extra time over kRepeats - 1
// is one run of the stage, barrier included, with the noise divided.
// Returns ms by stage name: every stage after the depth maps.
std::map<std::string, double> repeatedStages(const Setup& setup, const Mesh& mesh,
                                             const std::vector<render::reference::PodView>& views) {
  const auto& stage_names = render::TextureFieldPasses::stageNames();
  std::map<std::string, double> repeated;
  render::Renderer renderer(setup.context, 320, 240);
  render::BlendSettings settings;
  settings.mode = render::BlendMode::kMontage4D;
  const auto pod_views = rendererViews(views);
  std::vector<int> stages = {-1};  // every stage but the depth maps (timestamps)
  for (int stage = 1; stage < static_cast<int>(stage_names.size()); ++stage)
    stages.push_back(stage);
  auto runs = repeatedRuns(setup, mesh, renderer, settings, pod_views, stages);
  std::printf(
      "\nVulkan per stage, each recorded %d times in one frame (medians of %zu; extra time / "
      "%d):\n",
      kRepeats, runs[-1].size(), kRepeats - 1);
  for (size_t k = 1; k < stage_names.size(); ++k) {
    repeated[stage_names[k]] =
        std::max(0.0, (median(runs[static_cast<int>(k)]) - median(runs[-1])) / (kRepeats - 1));
    std::printf("%-30s %10.2f ms\n", stage_names[k].c_str(), repeated[stage_names[k]]);
  }
  return repeated;
}

// Vulkan ms per stage: the depth maps by montage4d's timestamps, the rest
// by the repeats.
std::map<std::string, double> vulkanStages(const std::map<std::string, double>& repeated,
                                           std::map<std::string, Times>& passes) {
  std::map<std::string, double> gpu = repeated;
  gpu["depth_maps"] = median(passes["montage4d"]["depth_maps"]);
  return gpu;
}

// Each stage's CPU reference against its Vulkan pass.
void printCpuAgainstVulkan(const std::map<std::string, double>& cpu,
                           const std::map<std::string, double>& gpu, size_t vertices) {
  std::printf(
      "\nPer stage, CPU reference (one thread, double, best of 3) against Vulkan (depth maps: "
      "timestamps; "
      "the rest: repeats above), %zu vertices:\n",
      vertices);
  std::printf("%-30s %10s %10s %16s\n", "stage", "CPU ms", "Vulkan ms", "Vulkan / CPU");
  for (const auto& stage : {"depth_maps", "discontinuities", "visibility", "voting",
                            "seams_and_global_visibility", "geodesics"}) {
    const double ratio = cpu.at(stage) > 0 ? gpu.at(stage) / cpu.at(stage) : 0.0;
    std::printf("%-30s %10.1f %10.1f %10.2f %s\n", stage, cpu.at(stage), gpu.at(stage), ratio,
                ratio <= 1.0 ? "ok" : "SLOWER");
  }
}

// The discontinuity pass tests up to (2 eps + 1)^2 pixels around each
// vertex, where the reference dilates whole maps. Both grow with the
// pods' resolution, since eps is paper 000's 4 px at 2048 wide, scaled:
// the same mesh seen at 320, 640 and 1280 wide, with eps 0, 1 and 2.
void discontinuitiesByResolution(const Setup& setup, const Mesh& mesh) {
  std::printf(
      "\nDiscontinuities by pod resolution, eps scaled (CPU: the whole dilated maps, best of 3; "
      "Vulkan: %d "
      "repeats, medians of %d):\n%-10s %4s %10s %10s %16s\n",
      kRepeats, 1 + 2 * setup.meshes, "pods", "eps", "CPU ms", "Vulkan ms", "Vulkan / CPU");
  for (uint32_t width : {320u, 640u, 1280u}) {
    const uint32_t height = width * 3 / 4;
    std::vector<render::reference::DepthMap> maps;
    std::vector<render::ViewImages> pod_views;
    for (const auto& cam : scene::SyntheticScene::cameraRig(4, width, height)) {
      const auto truth = setup.scene.render(cam, 10 + setup.meshes);
      pod_views.push_back({cam, truth.color, truth.mask, featherMap(truth.mask)});
      maps.push_back(render::reference::rasterizeDepth(mesh, cam));
    }
    double cpu_ms = 1e30;
    for (int repeat = 0; repeat < 3; ++repeat) {
      const auto t0 = Clock::now();
      for (const auto& map : maps) render::reference::dilatedDiscontinuities(map);
      cpu_ms = std::min(cpu_ms, ms(t0, Clock::now()));
    }
    render::Renderer renderer(setup.context, 320, 240);
    render::BlendSettings settings;
    settings.mode = render::BlendMode::kHoloportation;
    auto runs = repeatedRuns(setup, mesh, renderer, settings, pod_views,
                             {-1, 1});  // 1: the discontinuities
    const double gpu_ms = std::max(0.0, (median(runs[1]) - median(runs[-1])) / (kRepeats - 1));
    std::printf("%4ux%-5u %4d %10.2f %10.2f %10.2f %s\n", width, height,
                render::reference::scaledDilationPx(static_cast<int>(width)), cpu_ms, gpu_ms,
                gpu_ms / cpu_ms, gpu_ms <= cpu_ms ? "ok" : "SLOWER");
  }
}

// Holoportation's field passes by wall clock against their CPU reference.
// Timestamps on a CPU device include its flushes; wall clock is the
// ground truth. Normal mode draws the depth maps too, so holoportation
// minus normal is what holoportation's field passes cost (it has no
// seams or geodesics; its field pass has no CPU timing).
void printHoloportationFields(const Times& per_mesh, const std::map<std::string, double>& cpu) {
  const double fields_wall = median(per_mesh.at("holoportation")) - median(per_mesh.at("normal"));
  const double fields_cpu = cpu.at("discontinuities") + cpu.at("visibility") + cpu.at("voting");
  std::printf(
      "wall clock, holoportation's field passes (holoportation - normal per mesh): Vulkan %.1f ms, "
      "CPU "
      "reference (discontinuities, visibility, voting) %.1f ms\n",
      fields_wall, fields_cpu);
}

// The temporal update has a CPU half: carrying the field from the
// previous frame's surface (by marching-cubes edge key, else the nearest
// vertex), timed between two consecutive frames' meshes as the client
// does it per new mesh. (The renders above reuse one mesh: every key matches.)
// Returns its ms, best of 5.
double temporalCarryMs(const Setup& setup, const Mesh& mesh) {
  double carry_ms = 1e30;
  const Mesh before = setup.scene.truthMesh(9 + setup.meshes, 0.02);
  render::CarryMap map;
  for (int repeat = 0; repeat < 5; ++repeat) {
    const auto t0 = Clock::now();
    map = render::carryAcross(before, mesh, 2.0 * meanEdgeLength(mesh));
    carry_ms = std::min(carry_ms, ms(t0, Clock::now()));
  }
  std::printf(
      "temporal carry between consecutive meshes (CPU, best of 5): %.2f ms; %zu vertices by key, "
      "%zu by "
      "nearest, %zu fresh\n",
      carry_ms, map.by_key, map.by_nearest, map.fresh);
  return carry_ms;
}

// The share of montage4d's ms per new mesh that the seams, geodesics and
// temporal update take.
void printDiffusionShare(const std::map<std::string, double>& gpu,
                         const std::map<std::string, double>& repeated, double carry_ms,
                         double m4_mesh) {
  const double diffusion =
      gpu.at("seams_and_global_visibility") + gpu.at("geodesics") + repeated.at("field") + carry_ms;
  std::printf(
      "seams + geodesics + temporal update (field pass and carry): %.1f ms = %.0f%% of montage4d's "
      "mesh frame "
      "(target <= 10%%)\n",
      diffusion, m4_mesh > 0 ? 100.0 * diffusion / m4_mesh : 0.0);
}

// Holoportation's median ms per new mesh with `count` of the 8 ring cameras
// (4: every other one), the odd ones' masks emptied when `odd_empty`.
double holoportationMeshMs(const Setup& setup, const std::vector<Camera>& ring8,
                           const Mesh& subject, int count, bool odd_empty) {
  std::vector<render::ViewImages> chosen;
  for (int i = 0; i < 8; i += count == 4 ? 2 : 1) {
    const auto truth = setup.scene.render(ring8[static_cast<size_t>(i)], 10 + setup.meshes);
    render::ViewImages view{ring8[static_cast<size_t>(i)], truth.color, truth.mask,
                            featherMap(truth.mask)};
    if (odd_empty && i % 2 == 1) std::fill(view.mask.pixels.begin(), view.mask.pixels.end(), 0);
    chosen.push_back(std::move(view));
  }
  render::Renderer renderer(setup.context, 320, 240);
  render::BlendSettings settings;
  settings.mode = render::BlendMode::kHoloportation;
  std::vector<double> times;
  for (int repeat = 0; repeat < 2 + 2 * setup.meshes; ++repeat) {
    renderer.setMesh(subject);
    renderer.setViews(chosen);
    const auto t0 = Clock::now();
    renderer.render(ring8[1], settings);
    if (repeat > 0) times.push_back(ms(t0, Clock::now()));
  }
  return median(times);
}

// Cameras that see none of the subject: the client skips their depth map
// and discontinuities. 8 pods where 4 see the subject and 4 have empty
// masks, against the 4 alone and against 8 that all see it.
void camerasSeeingNothing(const Setup& setup) {
  const auto ring8 = scene::SyntheticScene::cameraRig(8, 320, 240);
  const Mesh subject = setup.scene.truthMesh(10 + setup.meshes, 0.02);
  const double four = holoportationMeshMs(setup, ring8, subject, 4, false);
  const double skipped = holoportationMeshMs(setup, ring8, subject, 8, true);
  const double eight = holoportationMeshMs(setup, ring8, subject, 8, false);
  std::printf(
      "\nCameras that see none of the subject (holoportation per new mesh): 4 pods %.1f ms; 8 "
      "pods of which 4 "
      "see nothing %.1f ms; 8 that all see it %.1f ms\n",
      four, skipped, eight);
}

}  // namespace

int main(int argc, char** argv) {
  const int meshes = argc > 1 ? std::max(2, std::atoi(argv[1])) : 4;
  const scene::SyntheticScene scene;
  const auto cameras = scene::SyntheticScene::cameraRig(4, 320, 240);
  gpu::VulkanContext context;
  std::printf("device: %s; 4 cameras at 320x240, output 320x240, %d meshes per mode and round\n",
              context.deviceName().c_str(), meshes);
  const Setup setup{scene, cameras, context, meshes};
  ModeCosts costs = measureModes(setup);
  printModeCosts(costs, meshes);
  printPassTimes(costs.passes);
  // The CPU reference for the same per-mesh work (visibility, vote, seams,
  // geodesics) on the last mesh.
  const Mesh mesh = scene.truthMesh(10 + meshes, 0.02);
  const auto views = truthViews<render::reference::PodView>(scene, cameras, 10 + meshes);
  const auto cpu = cpuReferenceStages(mesh, views);
  printMontageFieldUse(mesh, views, cameras);
  printWallClockPerStage(setup, mesh, views);
  const auto repeated = repeatedStages(setup, mesh, views);
  const auto gpu = vulkanStages(repeated, costs.passes);
  printCpuAgainstVulkan(cpu, gpu, costs.vertices);
  discontinuitiesByResolution(setup, mesh);
  printHoloportationFields(costs.per_mesh, cpu);
  const double carry_ms = temporalCarryMs(setup, mesh);
  printDiffusionShare(gpu, repeated, carry_ms, median(costs.per_mesh.at("montage4d")));
  camerasSeeingNothing(setup);
  return 0;
}
