// The CPU reference of the texture-field stages, against geometry whose
// answer is known (a sphere, two planes) and the synthetic scene.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

#include "geometry/marching_cubes.h"
#include "render_client/reference/depth_map.h"
#include "render_client/reference/texture_fields.h"
#include "render_client/reference/visibility.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

namespace holofuse::render::reference {
namespace {

Mesh sphere(double radius, double spacing = 0.04) {
  const int n = static_cast<int>(std::ceil(2.4 * radius / spacing)) + 1;
  const double origin = -1.2 * radius;
  return marchingCubes(sampleGrid(glm::dvec3(origin), spacing, n, n, n,
                                  [&](const glm::dvec3& p) { return radius - glm::length(p); }));
}

Camera cameraAt(const glm::dvec3& eye, uint32_t id = 0, uint32_t w = 160, uint32_t h = 120) {
  return lookAtCamera(id, eye, glm::dvec3(0.0), glm::dvec3(0, 1, 0), w, h, 40.0);
}

// A quad (two triangles) at depth z covering [-s, s]^2 in x and y.
void addQuad(Mesh& mesh, double s, double z) {
  const auto base = static_cast<uint32_t>(mesh.positions.size());
  for (auto [x, y] : {std::pair{-s, -s}, {s, -s}, {s, s}, {-s, s}}) {
    mesh.positions.emplace_back(x, y, z);
    mesh.normals.emplace_back(0, 0, 1);
  }
  for (uint32_t k : {0u, 1u, 2u, 0u, 2u, 3u}) mesh.indices.push_back(base + k);
}

TEST(ReferenceDepth, SphereDepthMatchesGeometry) {
  const Mesh mesh = sphere(0.5);
  const Camera cam = cameraAt({0, 0, 3});
  const DepthMap map = rasterizeDepth(mesh, cam);
  EXPECT_NEAR(map.at(80, 60), 2.5, 0.01);  // nearest point of the sphere
  EXPECT_EQ(map.at(0, 0), kNoDepth);
  // Off centre the depth follows the sphere: ray through pixel, hit at
  // t with |o + t d| = r.
  const glm::dvec3 d = cam.rayDirection(100.5, 70.5), o = cam.center();
  const double b = glm::dot(o, d), c = glm::dot(o, o) - 0.25;
  const double t = -b - std::sqrt(b * b - c);
  EXPECT_NEAR(map.at(100, 70), t * glm::dot(d, cam.forward()), 0.01);
}

TEST(ReferenceDepth, DegenerateAndBehindTrianglesDrawNothing) {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 5}, {1, 0, 5}, {0, 1, 5}};
  mesh.normals.assign(6, glm::vec3(0, 0, 1));
  mesh.indices = {0, 1, 2, 3, 4, 5};  // a point, and a triangle behind the camera
  const DepthMap map = rasterizeDepth(mesh, cameraAt({0, 0, 3}));
  for (double d : map.depth) EXPECT_EQ(d, kNoDepth);
}

TEST(ReferenceDepth, DiscontinuitiesAreDilatedByEpsPixels) {
  Mesh mesh;
  addQuad(mesh, 2.0, -1.0);  // background wall
  addQuad(mesh, 0.2, 0.5);   // a small card in front of it
  const Camera cam = cameraAt({0, 0, 3}, 0, 200, 200);
  const DepthMap map = rasterizeDepth(mesh, cam);
  const auto edge = cam.project({0.2, 0.0, 0.5});  // right border of the card
  ASSERT_TRUE(edge);
  const int ex = static_cast<int>(edge->x), ey = static_cast<int>(edge->y);
  DiscontinuityOptions options;
  options.dilation_px = 4;
  const auto mask = dilatedDiscontinuities(map, options);
  auto at = [&](int x, int y) { return mask[static_cast<size_t>(y) * 200 + x]; };
  EXPECT_EQ(at(ex, ey), 1);
  EXPECT_EQ(at(ex + 3, ey), 1);
  EXPECT_EQ(at(ex - 3, ey), 1);
  EXPECT_EQ(at(ex + 7, ey), 0);
  EXPECT_EQ(at(ex - 7, ey), 0);
  EXPECT_EQ(at(100, 100), 0) << "the card's middle is continuous";
  options.dilation_px = 0;
  const auto thin = dilatedDiscontinuities(map, options);
  EXPECT_EQ(thin[static_cast<size_t>(ey) * 200 + ex + 3], 0);
}

TEST(ReferenceDepth, DefaultEpsKeepsThePapersBandWidthRelativeToTheImage) {
  // Paper 000: eps = 4 px on 2048-pixel-wide textures.
  EXPECT_EQ(scaledDilationPx(2048), 4);
  EXPECT_EQ(scaledDilationPx(1280), 2);
  EXPECT_EQ(scaledDilationPx(640), 1);
  EXPECT_EQ(scaledDilationPx(320), 0);
  EXPECT_EQ(scaledDilationPx(1), 0);
  // The default option resolves it from the map's width.
  Mesh mesh;
  addQuad(mesh, 2.0, -1.0);
  addQuad(mesh, 0.2, 0.5);
  const Camera cam = cameraAt({0, 0, 3}, 0, 640, 640);
  const DepthMap map = rasterizeDepth(mesh, cam);
  DiscontinuityOptions one;
  one.dilation_px = 1;
  EXPECT_EQ(dilatedDiscontinuities(map), dilatedDiscontinuities(map, one));
}

std::vector<PodView> sphereViews(const Mesh& mesh, int count) {
  std::vector<PodView> views;
  for (int i = 0; i < count; ++i) {
    const double a = 2 * M_PI * i / count;
    PodView view;
    view.camera = cameraAt({3 * std::sin(a), 0.3, 3 * std::cos(a)}, static_cast<uint32_t>(i));
    const DepthMap map = rasterizeDepth(mesh, view.camera);
    view.color = Image8(160, 120, 3, 0);
    view.mask = Image8(160, 120, 1, 0);
    for (size_t p = 0; p < map.depth.size(); ++p) {
      if (map.depth[p] == kNoDepth) continue;
      view.mask.pixels[p] = 255;
      // A colour that depends on where on the sphere the pixel is: every
      // camera sees the same surface colour.
      const uint32_t x = static_cast<uint32_t>(p % 160), y = static_cast<uint32_t>(p / 160);
      const glm::dvec3 hit =
          view.camera.center() +
          view.camera.rayDirection(x + 0.5, y + 0.5) *
              (map.depth[p] /
               glm::dot(view.camera.rayDirection(x + 0.5, y + 0.5), view.camera.forward()));
      view.color.pixels[3 * p + 0] = static_cast<uint8_t>(128 + 100 * hit.y);
      view.color.pixels[3 * p + 1] = static_cast<uint8_t>(128 + 100 * hit.x);
      view.color.pixels[3 * p + 2] = 90;
    }
    views.push_back(std::move(view));
  }
  return views;
}

TEST(ReferenceVisibility, FrontFacingVerticesAreSeenBackFacingNever) {
  const Mesh mesh = sphere(0.5);
  const auto views = sphereViews(mesh, 1);
  const auto sights = vertexSights(mesh, views);
  const glm::dvec3 c = views[0].camera.center();
  size_t front = 0, front_seen = 0;
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    const double facing =
        glm::dot(glm::dvec3(mesh.normals[v]), glm::normalize(c - glm::dvec3(mesh.positions[v])));
    if (facing < -0.05) {
      EXPECT_NE(sights[0][v], Sight::kVisible) << v;
    }
    // Away from the silhouette's dilated band (eps = 4 px on a sphere about
    // 60 px across, square window).
    if (facing > 0.65) {
      ++front;
      front_seen += sights[0][v] == Sight::kVisible;
    }
  }
  EXPECT_GT(static_cast<double>(front_seen) / front, 0.97);
}

TEST(ReferenceLab, MatchesPublishedValues) {
  const uint8_t white[3] = {255, 255, 255}, black[3] = {0, 0, 0}, red[3] = {255, 0, 0};
  EXPECT_NEAR(srgbToLab(white).x, 1.0, 1e-3);
  EXPECT_NEAR(srgbToLab(white).y, 0.0, 1e-3);
  EXPECT_NEAR(srgbToLab(black).x, 0.0, 1e-9);
  // sRGB red is L* 53.24, a* 80.09, b* 67.20 (D65).
  EXPECT_NEAR(srgbToLab(red).x, 0.5324, 2e-3);
  EXPECT_NEAR(srgbToLab(red).y, 0.8009, 2e-3);
  EXPECT_NEAR(srgbToLab(red).z, 0.6720, 2e-3);
}

TEST(ReferenceVote, AGhostViewIsOutvotedAndTheOthersAreTrusted) {
  const Mesh mesh = sphere(0.5);
  auto views = sphereViews(mesh, 8);  // 45 degrees apart: most points seen by three or four
  // Camera 1 sees something else in front of the subject (a ghost):
  // its colours disagree with everyone.
  for (size_t p = 0; p < views[1].color.pixels.size(); p += 3) {
    views[1].color.pixels[p] = 20;
    views[1].color.pixels[p + 1] = 200;
    views[1].color.pixels[p + 2] = 20;
  }
  const auto sights = vertexSights(mesh, views);
  const auto trusted = majorityVote(mesh, views, sights);
  size_t ghost_seen = 0, ghost_trusted = 0, other_seen = 0, other_trusted = 0;
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    for (size_t i = 0; i < views.size(); ++i) {
      if (sights[i][v] != Sight::kVisible) continue;
      size_t seen_by = 0;
      for (size_t j = 0; j < views.size(); ++j) seen_by += sights[j][v] == Sight::kVisible;
      if (seen_by < 3) continue;  // the vote needs company
      (i == 1 ? ghost_seen : other_seen)++;
      (i == 1 ? ghost_trusted : other_trusted) += trusted[i][v];
    }
  }
  ASSERT_GT(ghost_seen, 0u);
  EXPECT_LT(static_cast<double>(ghost_trusted) / ghost_seen, 0.05);
  EXPECT_GT(static_cast<double>(other_trusted) / other_seen, 0.95);
  // delta 0 is no vote: every view that sees a vertex is trusted, the ghost too.
  VoteOptions none;
  none.delta = 0;
  const auto all = majorityVote(mesh, views, sights, none);
  for (size_t i = 0; i < views.size(); ++i) {
    for (size_t v = 0; v < mesh.vertexCount(); ++v) {
      EXPECT_EQ(all[i][v] != 0, sights[i][v] == Sight::kVisible)
          << "camera " << i << " vertex " << v;
    }
  }
}

TEST(ReferenceSeams, LieAlongTheSilhouetteAndNameTheirRule) {
  const Mesh mesh = sphere(0.5);
  const auto views = sphereViews(mesh, 1);
  const auto sights = vertexSights(mesh, views);
  const auto trusted = majorityVote(mesh, views, sights);
  const auto seams = seamTriangles(mesh, sights, trusted);
  const glm::dvec3 c = views[0].camera.center();
  size_t count = 0;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    if (!seams[0][t]) continue;
    ++count;
    const uint32_t v = mesh.indices[3 * t];
    const double facing =
        glm::dot(glm::dvec3(mesh.normals[v]), glm::normalize(c - glm::dvec3(mesh.positions[v])));
    EXPECT_LT(std::abs(facing), 0.7) << "seam triangle far from the silhouette";
  }
  EXPECT_GT(count, 10u);
  EXPECT_LT(count, mesh.triangleCount() / 5);
}

TEST(ReferenceFields, GlobalVisibilityIsRelativeToTheBestView) {
  const auto g = globalVisibility({{1, 1, 1, 1}, {1, 1, 0, 0}, {0, 0, 0, 0}});
  EXPECT_DOUBLE_EQ(g[0], 1.0);
  EXPECT_DOUBLE_EQ(g[1], 0.5);
  EXPECT_DOUBLE_EQ(g[2], 0.0);
  EXPECT_EQ(globalVisibility({{0, 0}}), std::vector<double>{0.0});
}

TEST(ReferenceFields, TemporalLambdaDoesNotDependOnFrameRate) {
  Field at30 = {{0.0}}, at10 = {{0.0}};
  const Field target = {{1.0}};
  for (int k = 0; k < 30; ++k) temporalUpdate(at30, target, temporalLambda(0.05, 1.0 / 30));
  for (int k = 0; k < 10; ++k) temporalUpdate(at10, target, temporalLambda(0.05, 1.0 / 10));
  EXPECT_NEAR(at30[0][0], at10[0][0], 1e-12);
  EXPECT_NEAR(at30[0][0], 1 - std::pow(0.95, 30), 1e-12);
  EXPECT_NEAR(temporalLambda(0.05, 1.0 / 30), 0.05, 1e-12);
  EXPECT_DOUBLE_EQ(temporalLambda(0.0, 0.1), 0.0);  // lambda 0: the field never moves
  EXPECT_DOUBLE_EQ(temporalLambda(1.0, 0.1), 1.0);  // lambda 1: it jumps to the target
  EXPECT_DOUBLE_EQ(temporalLambda(0.05, -1.0), 0.0);
}

TEST(ReferenceFields, ExtremeParametersStayFiniteAndBounded) {
  Mesh mesh = sphere(0.5, 0.1);
  mesh.normals[0] = glm::vec3(0.0f);  // a degenerate normal
  mesh.normals[1] = glm::vec3(std::nanf(""));
  std::vector<Camera> cameras = {cameraAt({0, 0, 3}),
                                 cameraAt({0, 0, 0.5000001})};  // one at the surface
  const std::vector<std::vector<uint8_t>> all(2, std::vector<uint8_t>(mesh.vertexCount(), 1));
  const Field ones(2, std::vector<double>(mesh.vertexCount(), 1.0));
  for (double alpha : {0.0, 0.01, 2.0, 200.0, 1e6}) {
    const Field h = holoportationField(mesh, cameras, all, alpha);
    const Field m = montageTargetField(mesh, cameras, all, {1.0, 0.5}, ones, {0, 0, 0},
                                       alpha);  // user at a vertex-free centre
    for (const Field* f : {&h, &m}) {
      for (const auto& row : *f) {
        for (double x : row) ASSERT_TRUE(std::isfinite(x) && x >= 0 && x <= 1) << alpha;
      }
    }
  }
  const Field zero(2, std::vector<double>(mesh.vertexCount(), 0.0));
  const BlendWeights none = normalizeFields(zero, ones, zero);
  EXPECT_EQ(std::accumulate(none.hole.begin(), none.hole.end(), 0),
            static_cast<int>(mesh.vertexCount()));
  const Field h = holoportationField(mesh, cameras, all, 2.0);
  const BlendWeights w = normalizeFields(h, ones, h);
  for (size_t v = 0; v < mesh.vertexCount(); ++v) {
    if (w.hole[v]) continue;
    EXPECT_NEAR(w.weight[0][v] + w.weight[1][v], 1.0, 1e-12);
  }
  // Geodesic fields summing below 1 fall back to the normal-weighted field.
  const Field small(2, std::vector<double>(mesh.vertexCount(), 0.2));
  const BlendWeights fb = normalizeFields(small, small, h);
  EXPECT_EQ(fb.fallback[5], 1);
}

TEST(ReferencePipeline, SyntheticSceneVisibilityFollowsTheTruthMask) {
  const scene::SyntheticScene scene;
  const Mesh mesh = scene.truthMesh(3, 0.02);
  std::vector<PodView> views;
  for (const auto& cam : scene::SyntheticScene::cameraRig(4, 120, 90)) {
    const auto truth = scene.render(cam, 3);
    views.push_back({cam, truth.color, truth.mask, featherMap(truth.mask)});
  }
  const auto sights = vertexSights(mesh, views);
  const auto trusted = majorityVote(mesh, views, sights);
  const auto visible = finalVisibility(sights, trusted);
  const auto g = globalVisibility(visible);
  EXPECT_DOUBLE_EQ(*std::max_element(g.begin(), g.end()), 1.0);
  // Side cameras see the narrow profile (about 40% of the front view here);
  // none is left out.
  for (double s : g) EXPECT_GT(s, 0.25);
  // Seen vertices project inside the true silhouette.
  for (size_t i = 0; i < views.size(); ++i) {
    for (size_t v = 0; v < mesh.vertexCount(); ++v) {
      if (!visible[i][v]) continue;
      const auto p = views[i].camera.project(glm::dvec3(mesh.positions[v]));
      ASSERT_NE(*views[i].mask.at(static_cast<uint32_t>(p->x), static_cast<uint32_t>(p->y)), 0);
    }
  }
}

}  // namespace
}  // namespace holofuse::render::reference
