// The Vulkan texture-field passes (lavapipe in CI) against their CPU
// reference, on three scenes with different camera counts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

#include "field_scenes.h"
#include "geometry/marching_cubes.h"
#include "render_client/reference/blend.h"
#include "render_client/reference/geodesics.h"
#include "render_client/reference/texture_fields.h"
#include "render_client/reference/visibility.h"
#include "render_client/renderer.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

namespace holofuse::render {
namespace {

using test::context;
using test::ghostSphere;
using test::Scene;
using test::syntheticScene;
using test::viewImages;

// A rig past 32 cameras too, so that every per-camera bit set spans two
// words.
Scene fieldPassScene(int index) {
  Scene scene = index == 0   ? syntheticScene(4, 160, 120, 4)
                : index == 1 ? syntheticScene(7, 128, 96, 11)
                : index == 2 ? ghostSphere()
                             : syntheticScene(40, 64, 48, 7);
  if (index == 1) {
    std::fill(scene.views[3].mask.pixels.begin(), scene.views[3].mask.pixels.end(), 0);
    scene.name += ", camera 3 seeing none of the subject";
  }
  return scene;
}

// One scene through the CPU reference and through the Vulkan passes (mode
// holoportation with paper 000's vote and geodesics on), so that each
// stage below compares its own output and a failure names the stage.
struct FieldPassRun {
  Scene scene;
  size_t n = 0, vertices = 0;
  std::vector<Camera> cameras;
  std::vector<std::vector<reference::Sight>> sights;
  std::vector<std::vector<uint8_t>> trusted, visible;
  reference::BlendWeights weights;
  BlendSettings settings;
  FieldSnapshot gpu;
  size_t cameras_without_subject = 0;
};

FieldPassRun runFieldPasses(int index) {
  FieldPassRun run;
  run.scene = fieldPassScene(index);
  const Scene& scene = run.scene;
  run.n = scene.views.size();
  run.vertices = scene.mesh.vertexCount();
  run.sights = reference::vertexSights(scene.mesh, scene.views);
  run.trusted = reference::majorityVote(scene.mesh, scene.views, run.sights);
  run.visible = reference::finalVisibility(run.sights, run.trusted);
  for (const auto& v : scene.views) run.cameras.push_back(v.camera);
  const auto field = reference::holoportationField(scene.mesh, run.cameras, run.visible, 2.0);
  const reference::Field ones(run.n, std::vector<double>(run.vertices, 1.0));
  run.weights = reference::normalizeFields(field, ones, field);
  Renderer renderer(context(), 96, 72);
  renderer.setMesh(scene.mesh);
  renderer.setViews(viewImages(scene));
  run.settings.mode = BlendMode::kHoloportation;
  run.settings.fields.vote_delta = 0.15f;  // the reference's: paper 000's vote
  run.settings.fields.geodesics = true;
  // Six mean edges: short of the k rings, so the radius is what bounds.
  run.settings.fields.geodesic_radius = static_cast<float>(6 * meanEdgeLength(scene.mesh));
  renderer.render(scene.views[0].camera, run.settings);
  run.gpu = renderer.readFields();
  run.cameras_without_subject = renderer.camerasWithoutSubject();
  return run;
}

class FieldPasses : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override {
    run_ = runFieldPasses(GetParam());
    ASSERT_EQ(run_.gpu.vertex_count, run_.vertices);
    ASSERT_EQ(run_.gpu.triangle_count, run_.scene.mesh.triangleCount());
  }
  FieldPassRun run_;
};

// Stage 1: each pod's depth map, per pixel, against the plain z-buffer.
// Both sample pixel centres; on the subject's outline the rasterisers'
// edge rules may differ.
TEST_P(FieldPasses, Stage1DepthMapsMatchTheReference) {
  SCOPED_TRACE(run_.scene.name);
  EXPECT_EQ(run_.cameras_without_subject, GetParam() == 1 ? 1u : 0u);
  size_t depth_pixels = 0, depth_coverage = 0, depth_compared = 0;
  double worst_depth = 0;
  for (size_t i = 0; i < run_.n; ++i) {
    if (GetParam() == 1 && i == 3) continue;  // sees none of the subject: skipped by design
    const auto cpu = reference::rasterizeDepth(run_.scene.mesh, run_.cameras[i]);
    for (size_t p = 0; p < cpu.depth.size(); ++p, ++depth_pixels) {
      const float g = run_.gpu.depth_maps[i * cpu.depth.size() + p];
      const bool gpu_surface = g < HOLOFUSE_NO_DEPTH * 0.5f,
                 cpu_surface = cpu.depth[p] != reference::kNoDepth;
      depth_coverage += gpu_surface == cpu_surface;
      if (!gpu_surface || !cpu_surface) continue;
      ++depth_compared;
      worst_depth = std::max(worst_depth, std::abs(g - cpu.depth[p]) / cpu.depth[p]);
    }
  }
  ASSERT_GT(depth_compared, 1000u);
  RecordProperty("depth_coverage_agreement",
                 std::to_string(static_cast<double>(depth_coverage) / depth_pixels));
  RecordProperty("depth_worst_relative_difference", std::to_string(worst_depth));
  // Measured: every pixel alike, within 5e-6 relative.
  EXPECT_GT(static_cast<double>(depth_coverage) / depth_pixels, 0.999);
  EXPECT_LT(worst_depth, 1e-4) << "float against double";
}

// Stage 2, the dilated discontinuities, has a test of its own below.
// Stage 3: visibility reasons, per camera and vertex. Rasterisation rules
// differ at triangle edges, so a few vertices on silhouettes may differ.
TEST_P(FieldPasses, Stage3VisibilityMatchesTheReference) {
  SCOPED_TRACE(run_.scene.name);
  size_t sight_agree = 0;
  for (size_t i = 0; i < run_.n; ++i) {
    for (size_t v = 0; v < run_.vertices; ++v) {
      sight_agree +=
          run_.gpu.sights[i * run_.vertices + v] == static_cast<uint32_t>(run_.sights[i][v]);
    }
  }
  const double sight_share = static_cast<double>(sight_agree) / (run_.n * run_.vertices);
  RecordProperty("sight_agreement", std::to_string(sight_share));
  // Measured on lavapipe: 99.998-100%. The bound leaves room for another
  // device's rasterisation rules at triangle edges.
  EXPECT_GT(sight_share, 0.9995);
}

// Stage 4: the vote, where both sides see the view.
TEST_P(FieldPasses, Stage4VotesMatchTheReference) {
  SCOPED_TRACE(run_.scene.name);
  size_t trust_agree = 0, trust_both = 0;
  for (size_t i = 0; i < run_.n; ++i) {
    for (size_t v = 0; v < run_.vertices; ++v) {
      if (run_.gpu.sights[i * run_.vertices + v] != 0 ||
          run_.sights[i][v] != reference::Sight::kVisible) {
        continue;
      }
      ++trust_both;
      trust_agree += (run_.gpu.trusted[i * run_.vertices + v] != 0) == (run_.trusted[i][v] != 0);
    }
  }
  ASSERT_GT(trust_both, 0u);
  const double trust_share = static_cast<double>(trust_agree) / trust_both;
  RecordProperty("vote_agreement", std::to_string(trust_share));
  EXPECT_GT(trust_share, 0.997);  // measured 99.87-100%
}

// Stage 5: seam rules per camera and triangle.
TEST_P(FieldPasses, Stage5SeamTrianglesMatchTheReference) {
  SCOPED_TRACE(run_.scene.name);
  const auto seams = reference::seamTriangles(run_.scene.mesh, run_.sights, run_.trusted);
  const size_t triangles = run_.scene.mesh.triangleCount();
  size_t seam_agree = 0, cpu_seams = 0;
  for (size_t i = 0; i < run_.n; ++i) {
    for (size_t t = 0; t < triangles; ++t) {
      seam_agree += run_.gpu.seams[i * triangles + t] == seams[i][t];
      cpu_seams += seams[i][t] != 0;
    }
  }
  EXPECT_GT(cpu_seams, 0u);
  const double share = static_cast<double>(seam_agree) / (run_.n * triangles);
  RecordProperty("seam_agreement", std::to_string(share));
  EXPECT_GT(share, 0.998);  // measured 99.93-100%
}

// Stage 6: geodesic distance from each camera's seam vertices, against
// the reference run from the GPU's own seams (so both start alike).
TEST_P(FieldPasses, Stage6GeodesicDistancesMatchTheReference) {
  SCOPED_TRACE(run_.scene.name);
  const size_t n = run_.n, vertices = run_.vertices, triangles = run_.scene.mesh.triangleCount();
  ASSERT_EQ(run_.gpu.distances.size(), n * vertices);
  size_t reach_agree = 0, compared = 0, bounded = 0;
  double distance_error = 0, worst_distance_error = 0;
  for (size_t i = 0; i < n; ++i) {
    std::vector<uint8_t> source(vertices, 0);
    for (size_t t = 0; t < triangles; ++t) {
      if (run_.gpu.seams[i * triangles + t] == 0) continue;
      for (int k = 0; k < 3; ++k) source[run_.scene.mesh.indices[3 * t + k]] = 1;
    }
    reference::GeodesicOptions options;
    options.max_rings = run_.settings.fields.geodesic_rings;
    options.iterations = run_.settings.fields.geodesic_iterations;
    options.max_distance = run_.settings.fields.geodesic_radius;
    options.region.resize(vertices);
    for (size_t v = 0; v < vertices; ++v)
      options.region[v] = run_.gpu.sights[i * vertices + v] == 0;  // seen
    const auto cpu = reference::approximateGeodesic(run_.scene.mesh, source, options);
    for (size_t v = 0; v < vertices; ++v) {
      const float g = run_.gpu.distances[i * vertices + v];
      const bool gpu_reached = g < 1e37f, cpu_reached = std::isfinite(cpu[v]);
      // Float and double may fall either side of the radius, and a vertex
      // just inside it lends its neighbours unfoldings a little shorter
      // than itself; there gamma is within 3% of 1 either way.
      const double reached_distance = gpu_reached ? g : cpu[v];
      const bool at_the_bound = reached_distance >= options.max_distance * 0.97;
      reach_agree += gpu_reached == cpu_reached || at_the_bound;
      bounded += cpu_reached && cpu[v] > 0.5 * options.max_distance;
      if (gpu_reached && cpu_reached && cpu[v] > 1e-6) {
        distance_error += std::abs(g - cpu[v]) / cpu[v];
        worst_distance_error = std::max(worst_distance_error, std::abs(g - cpu[v]) / cpu[v]);
        ++compared;
      }
    }
  }
  ASSERT_GT(compared, 0u);
  RecordProperty("geodesic_reach_agreement",
                 std::to_string(static_cast<double>(reach_agree) / (n * vertices)));
  RecordProperty("geodesic_mean_relative_difference", std::to_string(distance_error / compared));
  EXPECT_EQ(reach_agree, n * vertices) << "the same rings are reached";
  EXPECT_GT(bounded, 0u) << "some distances come near the radius";
  EXPECT_LT(distance_error / compared, 1e-4) << "float against double, same updates";
  // Every entry, not only on average: the GPU updates only the entries its
  // worklists hold, and one left out would stand far from the reference.
  RecordProperty("geodesic_worst_relative_difference", std::to_string(worst_distance_error));
  EXPECT_LT(worst_distance_error, 1e-3) << "float against double, same updates";
}

// Stage 7: the global visibility score from the GPU counts.
TEST_P(FieldPasses, Stage7GlobalVisibilityMatchesTheReference) {
  SCOPED_TRACE(run_.scene.name);
  const auto g = reference::globalVisibility(run_.visible);
  const auto& counts = run_.gpu.visible_counts;
  const double best = *std::max_element(counts.begin(), counts.end());
  for (size_t i = 0; i < run_.n; ++i)
    EXPECT_NEAR(best > 0 ? counts[i] / best : 0.0, g[i], 0.01) << "camera " << i;
}

// Stage 8 in holoportation's form (paper 000 eq. 2), normalised: every
// weight finite and in [0, 1], and close to the reference's.
TEST_P(FieldPasses, Stage8HoloportationWeightsMatchTheReference) {
  SCOPED_TRACE(run_.scene.name);
  double weight_error = 0;
  size_t weighted = 0;
  for (size_t v = 0; v < run_.vertices; ++v) {
    if (run_.weights.hole[v]) continue;
    for (size_t i = 0; i < run_.n; ++i) {
      const float w = run_.gpu.weights[v * run_.gpu.camera_count + i];
      ASSERT_TRUE(std::isfinite(w) && w >= 0.0f && w <= 1.0f) << "vertex " << v << " camera " << i;
      weight_error += std::abs(w - run_.weights.weight[i][v]);
      ++weighted;
    }
  }
  ASSERT_GT(weighted, 0u);
  RecordProperty("mean_weight_error", std::to_string(weight_error / weighted));
  EXPECT_LT(weight_error / weighted, 5e-4);  // measured within 8.5e-5 on average
}

INSTANTIATE_TEST_SUITE_P(FourScenes, FieldPasses, ::testing::Values(0, 1, 2, 3));

// Stage 2: the GPU evaluates the dilated discontinuities only at the pixel
// each vertex projects to, where visibility reads them. Per (camera,
// vertex) that passes the depth test, its flag must be the reference's
// whole dilated map (render::reference::dilatedDiscontinuities) at that
// pixel, for eps of 0 (paper 000's 4 px at 2048 wide, scaled to these
// images), 1 and 3 pixels.
class DiscontinuityPass : public ::testing::TestWithParam<int> {};

TEST_P(DiscontinuityPass, FlagsEachVertexAsTheDilatedMapDoes) {
  const Scene scene = fieldPassScene(GetParam());
  SCOPED_TRACE(scene.name);
  const size_t vertices = scene.mesh.vertexCount();
  Renderer renderer(context(), 96, 72);
  renderer.setMesh(scene.mesh);
  renderer.setViews(viewImages(scene));
  BlendSettings settings;
  settings.mode = BlendMode::kHoloportation;
  const reference::VisibilityOptions tests;  // the depth test's tolerance
  settings.fields.relative_depth_tolerance = static_cast<float>(tests.relative_depth_tolerance);
  for (const int eps : {reference::kDilationScaledToWidth, 1, 3}) {
    SCOPED_TRACE("eps " + std::to_string(eps));
    settings.fields.dilation_px = eps;
    renderer.render(scene.views[0].camera, settings);
    const FieldSnapshot gpu = renderer.readFields();
    ASSERT_EQ(gpu.discontinuities.size(), scene.views.size() * vertices);
    // Most vertices are far from any edge: the flagged ones are counted
    // apart, so a pass that missed the band could not hide among them.
    size_t asked = 0, agree = 0, flagged = 0, flagged_agree = 0, unasked_flags = 0;
    for (size_t i = 0; i < scene.views.size(); ++i) {
      // A camera that sees none of the subject has no depth on the GPU
      // by design: every vertex is on its background.
      if (GetParam() == 1 && i == 3) continue;
      const Camera& camera = scene.views[i].camera;
      const auto depth = reference::rasterizeDepth(scene.mesh, camera);
      reference::DiscontinuityOptions options;
      options.dilation_px = eps;
      const auto dilated = reference::dilatedDiscontinuities(depth, options);
      for (size_t v = 0; v < vertices; ++v) {
        const bool flag = gpu.discontinuities[i * vertices + v] != 0;
        const auto p = camera.project(glm::dvec3(scene.mesh.positions[v]));
        const bool inside =
            p && p->x >= 0 && p->y >= 0 && p->x < camera.width && p->y < camera.height;
        const size_t pixel =
            inside ? static_cast<size_t>(p->y) * camera.width + static_cast<size_t>(p->x) : 0;
        const double limit = depth.depth[pixel] * (1.0 + tests.relative_depth_tolerance);
        // The pass also tests vertices up to 1e-4 (relative) past the
        // limit, and those within 1e-3 px of a pixel border, in case
        // visibility rounds the test the other way; it leaves the rest 0.
        if (!inside || p->z > limit * (1 + 2e-4)) {
          auto onBorder = [](double u) { return std::abs(u - std::round(u)) < 2e-3; };
          unasked_flags +=
              flag && !(p && (onBorder(p->x) || onBorder(p->y)));  // (the image's edge too)
          continue;
        }
        if (p->z > limit) continue;
        ++asked;
        const bool same = flag == (dilated[pixel] != 0);
        agree += same;
        if (flag || dilated[pixel] != 0) {
          ++flagged;
          flagged_agree += same;
        }
      }
    }
    std::printf(
        "eps %d: %zu of %zu vertices alike, %zu of %zu flagged, %zu flags where the depth test "
        "fails\n",
        eps, agree, asked, flagged_agree, flagged, unasked_flags);
    ASSERT_GT(asked, 1000u);
    ASSERT_GT(flagged, 50u);
    // Float against double projection and depth: a vertex a hair from a
    // pixel border or from the depth test may land on the other side.
    EXPECT_GT(static_cast<double>(agree) / asked, 0.9995);  // measured 99.997-100%
    EXPECT_GT(static_cast<double>(flagged_agree) / flagged, 0.999)
        << flagged_agree << " of " << flagged;
    EXPECT_EQ(unasked_flags, 0u);
  }
}

INSTANTIATE_TEST_SUITE_P(FourScenes, DiscontinuityPass, ::testing::Values(0, 1, 2, 3));

// Stage 11, the fragment blend (eq. 1), against its CPU reference fed the
// GPU's own per-vertex weights, on the three scenes in every mode (mode
// fragment and the field modes' per-fragment test with the scenes' feather
// maps), from a view halfway between pods 0 and 1. Pixels differ where the rasterisers'
// edge rules pick different triangles on silhouettes and along steep
// depth steps; elsewhere the colours agree to a grey level or two.
class BlendPass : public ::testing::TestWithParam<int> {};

TEST_P(BlendPass, MatchesTheCpuReferenceInEveryMode) {
  Scene scene = GetParam() == 0   ? syntheticScene(4, 160, 120, 4)
                : GetParam() == 2 ? ghostSphere()
                : GetParam() == 4 ? syntheticScene(40, 96, 72, 7)
                                  : syntheticScene(7, 128, 96, 11);
  // 40 cameras, each vertex blending its 3 best: the selection and the
  // renormalisation are exercised, not only passed through.
  const int best_views = GetParam() == 4 ? 3 : FieldParameters{}.best_views;
  std::vector<bool> enabled;  // every camera
  if (GetParam() == 3) {
    // A pod that sees none of the subject, and one the user turned off.
    std::fill(scene.views[3].mask.pixels.begin(), scene.views[3].mask.pixels.end(), 0);
    enabled.assign(scene.views.size(), true);
    enabled[5] = false;
    scene.name += ", camera 3 seeing none of the subject, camera 5 off";
  }
  SCOPED_TRACE(scene.name);
  const Camera& c0 = scene.views[0].camera;
  const Camera& c1 = scene.views[1].camera;
  const glm::dvec3 eye = 0.5 * (c0.center() + c1.center());
  const glm::dvec3 up = -(glm::transpose(c0.rotation) * glm::dvec3(0, 1, 0));
  const double fov_x = 2.0 * std::atan(0.5 * c0.width / c0.fx) * 180.0 / M_PI;
  const Camera user = lookAtCamera(99, eye, eye + glm::normalize(c0.forward() + c1.forward()), up,
                                   c0.width, c0.height, fov_x);
  Renderer renderer(context(), user.width, user.height);
  renderer.setMesh(scene.mesh);
  renderer.setViews(viewImages(scene));
  // Every mode, and the field modes with paper 004's per-fragment test.
  const std::pair<BlendMode, bool> cases[] = {
      {BlendMode::kNormal, false},       {BlendMode::kHoloportation, false},
      {BlendMode::kMontage4D, false},    {BlendMode::kFragment, false},
      {BlendMode::kHoloportation, true}, {BlendMode::kMontage4D, true}};
  for (const auto& [mode, fragment_test] : cases) {
    const std::string name = blendModeName(mode) + (fragment_test ? "_fragment_test" : "");
    SCOPED_TRACE(name);
    BlendSettings settings;
    settings.mode = mode;
    settings.hole_color = {1.0f, 0.0f, 1.0f};
    settings.camera_enabled = enabled;
    settings.fragment_test = fragment_test;
    settings.fields.best_views = best_views;
    const Image8 gpu = renderer.render(user, settings);
    const FieldSnapshot fields = renderer.readFields();
    std::vector<std::vector<double>> weights;
    if (mode == BlendMode::kHoloportation || mode == BlendMode::kMontage4D) {
      weights.assign(scene.views.size(), std::vector<double>(scene.mesh.vertexCount()));
      for (size_t i = 0; i < weights.size(); ++i) {
        for (size_t v = 0; v < weights[i].size(); ++v)
          weights[i][v] = fields.weights[v * fields.camera_count + i];
      }
      // The GPU's best views are the reference's selection of its weights.
      const auto best = reference::keepBestViews(weights, best_views);
      ASSERT_EQ(fields.best_views, static_cast<uint32_t>(best_views));
      size_t mismatches = 0, truncated = 0;
      for (size_t v = 0; v < weights[0].size(); ++v) {
        size_t weighted = 0;
        for (size_t i = 0; i < weights.size(); ++i) weighted += weights[i][v] > 0;
        truncated += weighted > static_cast<size_t>(best_views);
        std::vector<double> gpu_best(weights.size(), 0.0);
        for (int k = 0; k < best_views; ++k) {
          const uint32_t camera = fields.best_cameras[v * best_views + k];
          if (camera != HOLOFUSE_NO_VIEW)
            gpu_best[camera] = fields.best_weights[v * best_views + k];
        }
        for (size_t i = 0; i < weights.size(); ++i)
          mismatches += std::abs(gpu_best[i] - best[i][v]) > 1e-5;
      }
      EXPECT_EQ(mismatches, 0u);
      if (GetParam() == 4) {
        EXPECT_GT(truncated, 100u) << "the scene must need the selection";
      }
      // Each triangle's merged list (what the blend reads) is its corners'
      // lists: each camera once, in the order met, with its weight at each
      // corner (0 where a corner does not keep it), then the end mark
      // unless the list fills its slots.
      const uint32_t slots = fields.triangle_view_slots;
      ASSERT_EQ(fields.triangle_cameras.size(), size_t{fields.triangle_count} * slots);
      size_t list_mismatches = 0, merged = 0;
      for (uint32_t t = 0; t < fields.triangle_count; ++t) {
        std::vector<uint32_t> cameras;
        std::vector<glm::vec3> at_corners;
        size_t longest_corner = 0;
        for (int j = 0; j < 3; ++j) {
          const uint32_t v = scene.mesh.indices[3 * t + j];
          size_t kept = 0;
          for (int k = 0; k < best_views; ++k, ++kept) {
            const uint32_t camera = fields.best_cameras[v * best_views + k];
            if (camera == HOLOFUSE_NO_VIEW) break;
            const size_t at = static_cast<size_t>(
                std::find(cameras.begin(), cameras.end(), camera) - cameras.begin());
            if (at == cameras.size()) {
              cameras.push_back(camera);
              at_corners.emplace_back(0.0f);
            }
            at_corners[at][j] = fields.best_weights[v * best_views + k];
          }
          longest_corner = std::max(longest_corner, kept);
        }
        merged += cameras.size() > longest_corner;
        bool same = cameras.size() <= slots;
        for (size_t e = 0; same && e < slots; ++e) {
          const uint32_t got = fields.triangle_cameras[t * slots + e];
          if (e == cameras.size()) {
            same = got == HOLOFUSE_NO_VIEW;
            break;
          }
          same = got == cameras[e] && fields.triangle_weights[t * slots + e] == at_corners[e];
        }
        list_mismatches += !same;
      }
      EXPECT_EQ(list_mismatches, 0u) << "of " << fields.triangle_count << " triangles";
      EXPECT_GT(merged, 50u) << "triangles whose corners keep different cameras";
    }
    reference::BlendOptions options;
    options.alpha = settings.alpha;
    options.depth_tolerance = settings.depth_tolerance;
    options.hole_color = glm::dvec3(settings.hole_color);
    options.camera_enabled = enabled;
    options.fragment_mode = mode == BlendMode::kFragment;
    options.fragment_test = fragment_test;
    options.relative_depth_tolerance = settings.fields.relative_depth_tolerance;
    options.depth_slack = renderer.fragmentDepthSlack();
    options.feather_width_px = settings.feather_width_px;
    options.beta = settings.beta;
    options.best_views = best_views;
    reference::BlendPaths paths;
    const Image8 cpu =
        reference::blendView(scene.mesh, scene.views, weights, user, options, &paths);
    // Both ways of blending are exercised: normal mode only the fallback,
    // the others mostly their own weights.
    if (mode == BlendMode::kNormal) {
      EXPECT_EQ(paths.fields, 0u);
      EXPECT_GT(paths.fallback, 500u);
    } else {
      EXPECT_GT(paths.fields, 500u);
    }
    ASSERT_EQ(cpu.pixels.size(), gpu.pixels.size());
    size_t covered = 0, coverage_agrees = 0, both = 0, close = 0;
    double difference = 0;
    for (size_t p = 0; p < gpu.pixels.size(); p += 4) {
      const bool g = gpu.pixels[p + 3] != 0, c = cpu.pixels[p + 3] != 0;
      covered += g || c;
      coverage_agrees += g == c;
      if (!g || !c) continue;
      ++both;
      int worst = 0;
      for (int k = 0; k < 3; ++k) {
        const int d =
            std::abs(static_cast<int>(gpu.pixels[p + k]) - static_cast<int>(cpu.pixels[p + k]));
        difference += d / 3.0;
        worst = std::max(worst, d);
      }
      close += worst <= 2;
    }
    ASSERT_GT(both, 500u);
    const double coverage = static_cast<double>(coverage_agrees) / (gpu.pixels.size() / 4);
    const double close_share = static_cast<double>(close) / both, mean = difference / both;
    RecordProperty("blend_" + name + "_coverage_agreement", std::to_string(coverage));
    RecordProperty("blend_" + name + "_within_2_grey_levels", std::to_string(close_share));
    RecordProperty("blend_" + name + "_mean_difference", std::to_string(mean));
    // Measured on lavapipe: coverage and the 2-level share 100%, mean
    // 0-0.0008 grey levels in every mode and variant (the images are
    // filtered in float in the shader, as in the reference).
    EXPECT_GT(coverage, 0.995);
    EXPECT_GT(close_share, 0.98);
    EXPECT_LT(mean, 0.75);
  }
}

INSTANTIATE_TEST_SUITE_P(FiveScenes, BlendPass, ::testing::Values(0, 1, 2, 3, 4));

// The fields and the candidates share their buffers' sizes. Mode normal
// with more best views, between two holoportation renders of one mesh,
// makes the buffers anew; the second holoportation render computes its
// fields again instead of blending lists nothing wrote.
TEST(FieldModes, AModeInBetweenThatRemakesTheBuffersLeavesTheFieldsRight) {
  const Scene scene = syntheticScene(40, 96, 72, 7);
  const Camera& user = scene.views[0].camera;
  Renderer renderer(context(), user.width, user.height);
  renderer.setMesh(scene.mesh);
  renderer.setViews(viewImages(scene));
  BlendSettings holoportation;
  holoportation.mode = BlendMode::kHoloportation;
  holoportation.fields.best_views = 2;
  const Image8 first = renderer.render(user, holoportation);
  BlendSettings normal;
  normal.fields.best_views = 12;  // 40 cameras: the candidates pass runs
  renderer.render(user, normal);
  const Image8 again = renderer.render(user, holoportation);
  ASSERT_EQ(again.pixels.size(), first.pixels.size());
  size_t differ = 0;
  for (size_t p = 0; p < first.pixels.size(); ++p) differ += again.pixels[p] != first.pixels[p];
  EXPECT_EQ(differ, 0u) << "of " << first.pixels.size() << " channels";
}

TEST(HoloportationMode, ReproducesThePodImageAndComputesFieldsOncePerMesh) {
  const Scene scene = syntheticScene(4, 200, 150, 6);
  Renderer renderer(context(), 200, 150);
  renderer.setMesh(scene.mesh);
  renderer.setViews(viewImages(scene));
  BlendSettings settings;
  settings.mode = BlendMode::kHoloportation;
  const Image8 out = renderer.render(scene.views[1].camera, settings);
  renderer.render(scene.views[2].camera, settings);  // a second view of the same mesh
  EXPECT_EQ(renderer.fieldPasses(), 1u);
  double squared = 0;
  size_t n = 0;
  for (uint32_t y = 0; y < 150; ++y) {
    for (uint32_t x = 0; x < 200; ++x) {
      if (out.at(x, y)[3] == 0 || *scene.views[1].mask.at(x, y) == 0) continue;
      for (int c = 0; c < 3; ++c) {
        const double d = static_cast<double>(out.at(x, y)[c]) - scene.views[1].color.at(x, y)[c];
        squared += d * d;
      }
      n += 3;
    }
  }
  const double psnr = 10 * std::log10(255.0 * 255.0 / (squared / static_cast<double>(n)));
  RecordProperty("psnr_db", std::to_string(psnr));
  EXPECT_GT(psnr, 24.0);
}

// The picture comes from the fields, not from the normal-weighted fallback:
// a pod whose colours every other pod outvotes (the ghost sphere's camera
// 3, painted green) tints the normal blend from its own pose but leaves no
// trace where the vote excluded it in holoportation's and montage4d's. (A vertex shader that read
// the blend mode from the wrong offset once made every mode draw the normal blend, unnoticed by the
// field comparisons above.)
TEST(FieldModes, TheBlendUsesTheFieldsSoAnOutvotedGhostLeavesNoTrace) {
  const Scene scene = ghostSphere();
  Renderer renderer(context(), 128, 96);
  renderer.setMesh(scene.mesh);
  renderer.setViews(viewImages(scene));
  auto greenShare = [&](BlendMode mode, float vote_delta = 0.15f) {  // paper 000's vote
    BlendSettings settings;
    settings.mode = mode;
    settings.fields.vote_delta = vote_delta;
    const Image8 out = renderer.render(scene.views[3].camera, settings);
    size_t covered = 0, green = 0;
    for (uint32_t y = 0; y < out.height; ++y) {
      for (uint32_t x = 0; x < out.width; ++x) {
        const uint8_t* px = out.at(x, y);
        if (px[3] == 0) continue;
        ++covered;
        green += px[1] > px[0] + 60 && px[1] > px[2] + 60;
      }
    }
    EXPECT_GT(covered, 1000u) << blendModeName(mode);
    return static_cast<double>(green) / static_cast<double>(std::max<size_t>(covered, 1));
  };
  // Measured: normal 77% green, both field modes 22%. The rest is where
  // only the ghost and one other pod see a vertex: two views that disagree
  // trust neither (eq. 3 needs one of one to agree), and the normal blend
  // fills in there.
  EXPECT_GT(greenShare(BlendMode::kNormal), 0.6);
  EXPECT_LT(greenShare(BlendMode::kHoloportation), 0.35);
  EXPECT_LT(greenShare(BlendMode::kMontage4D), 0.35);
  // Without the vote (delta 0, the default) the field modes keep the
  // ghost's colours much as the normal blend does (measured: montage4d 54%,
  // its view term spreading the weight): it is the vote that removes them.
  EXPECT_GT(greenShare(BlendMode::kHoloportation, 0.0f), 0.5);
  EXPECT_GT(greenShare(BlendMode::kMontage4D, 0.0f), 0.5);
}

// Stage 7: the count is exactly the number of vertices each camera sees
// and trusts by the GPU's own sights and votes (the workgroups' partial
// sums add up, none is lost or added twice).
TEST(FieldPassesGlobalVisibility, CountsExactlyTheVerticesSeenAndTrusted) {
  const Scene scene = syntheticScene(5, 128, 96, 8);
  const std::vector<ViewImages> views = viewImages(scene);
  BlendSettings settings;
  settings.mode = BlendMode::kMontage4D;
  settings.fields.vote_delta = 0.15f;  // paper 000's vote, so that trusted is not just seen
  Renderer renderer(context(), 64, 48);
  renderer.setMesh(scene.mesh);
  renderer.setViews(views);
  renderer.render(scene.views[0].camera, settings);
  const FieldSnapshot run = renderer.readFields();
  const size_t vertices = scene.mesh.vertexCount();
  {
    // The Holoportation baseline needs neither seams nor g^i and computes
    // neither (paper 000 Table 3: N/A).
    Renderer baseline(context(), 64, 48);
    baseline.setMesh(scene.mesh);
    baseline.setViews(views);
    settings.mode = BlendMode::kHoloportation;
    baseline.render(scene.views[0].camera, settings);
    const FieldSnapshot holoportation = baseline.readFields();
    EXPECT_EQ(std::count(holoportation.seams.begin(), holoportation.seams.end(), 0u),
              static_cast<std::ptrdiff_t>(holoportation.seams.size()));
    EXPECT_EQ(
        std::count(holoportation.visible_counts.begin(), holoportation.visible_counts.end(), 0u),
        static_cast<std::ptrdiff_t>(holoportation.visible_counts.size()));
    EXPECT_EQ(holoportation.sights, run.sights) << "the stages both modes run agree";
  }
  ASSERT_EQ(run.visible_counts.size(), views.size());
  size_t total = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    uint32_t expected = 0;
    for (size_t v = 0; v < vertices; ++v)
      expected += run.sights[i * vertices + v] == 0 && run.trusted[i * vertices + v] != 0;
    EXPECT_EQ(run.visible_counts[i], expected) << "camera " << i;
    total += expected;
  }
  EXPECT_GT(total, vertices / 2) << "the cameras see the subject";
  size_t seen = 0;
  for (size_t k = 0; k < run.sights.size(); ++k) seen += run.sights[k] == 0;
  EXPECT_LT(total, seen)
      << "the vote distrusts some view, so the count must read the votes, not the sights";
  // The same renderer switched to the baseline: the seams montage4d left
  // behind are cleared, not read back as the baseline's.
  ASSERT_GT(
      std::count_if(run.seams.begin(), run.seams.end(), [](uint32_t rules) { return rules != 0; }),
      0);
  settings.mode = BlendMode::kHoloportation;
  renderer.render(scene.views[0].camera, settings);
  const FieldSnapshot after = renderer.readFields();
  EXPECT_EQ(std::count(after.seams.begin(), after.seams.end(), 0u),
            static_cast<std::ptrdiff_t>(after.seams.size()));
}

TEST(FieldPassesDeterminism, TheSameInputGivesTheSameBits) {
  const Scene scene = syntheticScene(5, 128, 96, 8);
  const std::vector<ViewImages> views = viewImages(scene);
  BlendSettings settings;
  settings.mode = BlendMode::kHoloportation;
  settings.fields.geodesics = true;
  std::vector<FieldSnapshot> runs;
  for (int run = 0; run < 2; ++run) {
    Renderer renderer(context(), 64, 48);
    renderer.setMesh(scene.mesh);
    renderer.setViews(views);
    renderer.render(scene.views[0].camera, settings);
    runs.push_back(renderer.readFields());
  }
  EXPECT_EQ(runs[0].sights, runs[1].sights);
  EXPECT_EQ(runs[0].trusted, runs[1].trusted);
  EXPECT_EQ(runs[0].seams, runs[1].seams);
  EXPECT_EQ(runs[0].visible_counts, runs[1].visible_counts);
  EXPECT_EQ(0, std::memcmp(runs[0].distances.data(), runs[1].distances.data(),
                           runs[0].distances.size() * 4));
  EXPECT_EQ(
      0, std::memcmp(runs[0].weights.data(), runs[1].weights.data(), runs[0].weights.size() * 4));
}

}  // namespace
}  // namespace holofuse::render
