// Numerical extremes through the Vulkan texture-field path, in both field
// modes and mode fragment: whatever the scale, geometry, cameras or
// parameters (alpha, lambda, beta, feather width), every weight is finite
// and in [0, 1] and every covered pixel is a blend of the images or the
// hole colour.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "geometry/marching_cubes.h"
#include "render_client/reference/depth_map.h"
#include "render_client/renderer.h"

namespace holofuse::render {
namespace {

VulkanContext& context() {
  static VulkanContext ctx;
  return ctx;
}

Mesh sphere(double scale) {
  Mesh mesh =
      marchingCubes(sampleGrid(glm::dvec3(-0.6 * scale), 0.06 * scale, 21, 21, 21,
                               [&](const glm::dvec3& p) { return 0.5 * scale - glm::length(p); }));
  return mesh;
}

// A ring of cameras around the origin at 3 x scale, with plain images: the
// subject white on black and its mask from the reference depth map.
std::vector<ViewImages> ring(const Mesh& mesh, int count, double scale, bool empty_masks = false) {
  std::vector<ViewImages> views;
  for (int i = 0; i < count; ++i) {
    const double a = 2 * M_PI * i / count;
    ViewImages v;
    v.camera = lookAtCamera(static_cast<uint32_t>(i),
                            glm::dvec3(3 * std::sin(a), 0.4, 3 * std::cos(a)) * scale,
                            glm::dvec3(0.0), {0, 1, 0}, 64, 48, 40.0);
    const auto depth = reference::rasterizeDepth(mesh, v.camera, 1e-6 * scale);
    v.color = Image8(64, 48, 3, 0);
    v.mask = Image8(64, 48, 1, 0);
    for (size_t p = 0; p < depth.depth.size(); ++p) {
      if (depth.depth[p] == reference::kNoDepth || empty_masks) continue;
      v.mask.pixels[p] = 255;
      v.color.pixels[3 * p] = v.color.pixels[3 * p + 1] = v.color.pixels[3 * p + 2] = 200;
    }
    views.push_back(std::move(v));
  }
  return views;
}

struct Outcome {
  size_t covered = 0;
  size_t hole = 0;
  size_t weighted = 0;  // vertices whose weights sum to 1
};

// One render's weights and pixels: every weight finite in [0, 1], each
// vertex's summing to 1 or (no camera sees it) 0; every covered pixel the
// hole colour or a blend of the grey images.
Outcome checkRender(Renderer& renderer, const Camera& user, const BlendSettings& settings,
                    const std::string& what) {
  SCOPED_TRACE(what);
  const Image8 out = renderer.render(user, settings);
  const FieldSnapshot fields = renderer.readFields();
  Outcome outcome;
  for (uint32_t v = 0; v < fields.vertex_count; ++v) {
    float sum = 0;
    for (uint32_t i = 0; i < fields.camera_count; ++i) {
      const float w = fields.weights[v * fields.camera_count + i];
      EXPECT_TRUE(std::isfinite(w) && w >= 0.0f && w <= 1.0f)
          << "vertex " << v << " camera " << i << ": " << w;
      sum += w;
    }
    EXPECT_TRUE(sum == 0.0f || std::abs(sum - 1.0f) < 1e-4f) << sum;
    outcome.weighted += sum > 0.0f;
  }
  for (float d : fields.distances) EXPECT_TRUE(std::isfinite(d) && d >= 0.0f);
  for (size_t p = 0; p < out.pixels.size(); p += 4) {
    if (out.pixels[p + 3] == 0) continue;
    ++outcome.covered;
    const bool hole = out.pixels[p] == 255 && out.pixels[p + 1] == 0 && out.pixels[p + 2] == 255;
    outcome.hole += hole;
    // Otherwise a blend of white-ish images: grey levels only.
    if (!hole) {
      EXPECT_NEAR(out.pixels[p], out.pixels[p + 1], 2);
    }
  }
  return outcome;
}

// Both field modes. montage4d renders two frames per lambda (0, the
// default and 1), so that its temporal field also runs with a previous
// frame: the second from another pod's pose, a jump. The coverage is the
// geometry's and must not depend on the mode. montage4d weighs every
// vertex holoportation weighs: where its own field is empty it falls back
// to the same normal weights (step 10), so a field zeroed by a guard shows.
// The outcome returned has the most holes of any render.
Outcome renderAndCheck(const Mesh& mesh, const std::vector<ViewImages>& views, const Camera& user,
                       float alpha) {
  BlendSettings settings;
  settings.alpha = alpha;
  settings.hole_color = {1.0f, 0.0f, 1.0f};
  Outcome holoportation;
  {
    Renderer renderer(context(), 64, 48);
    renderer.setMesh(mesh);
    renderer.setViews(views);
    settings.mode = BlendMode::kHoloportation;
    settings.fields.geodesics =
        true;  // the geodesic passes run too, and their distances are checked
    holoportation = checkRender(renderer, user, settings, "holoportation");
  }
  Outcome worst = holoportation;
  auto keep = [&](const Outcome& o) {
    EXPECT_EQ(o.covered, holoportation.covered) << "coverage is the mesh's, whatever the weights";
    EXPECT_GE(o.weighted, holoportation.weighted)
        << "montage4d leaves vertices unweighted that holoportation weighs";
    worst.hole = std::max(worst.hole, o.hole);
  };
  settings.mode = BlendMode::kMontage4D;
  settings.fields.geodesics = false;
  for (double lambda : {0.0, 0.05, 1.0}) {
    Renderer renderer(context(), 64, 48);
    renderer.setMesh(mesh);
    renderer.setViews(views);
    settings.lambda = lambda;
    const std::string what = "montage4d, lambda " + std::to_string(lambda);
    keep(checkRender(renderer, user, settings, what + ", first frame"));
    const Camera& other = views[views.size() / 2].camera;
    EXPECT_GE(checkRender(renderer, other, settings, what + ", from another pod").weighted,
              holoportation.weighted);
    keep(checkRender(renderer, user, settings, what + ", back again"));
  }
  return worst;
}

TEST(Extremes, SceneScaleFromMillimetresToKilometres) {
  std::vector<size_t> covered;
  for (double scale : {1e-3, 1.0, 1e4}) {
    const Mesh mesh = sphere(scale);
    const auto views = ring(mesh, 6, scale);
    const Outcome o = renderAndCheck(mesh, views, views[0].camera, 2.0f);
    covered.push_back(o.covered);
    EXPECT_LT(o.hole, o.covered / 10) << scale;
  }
  EXPECT_NEAR(static_cast<double>(covered[0]), static_cast<double>(covered[1]), covered[1] * 0.02);
  EXPECT_NEAR(static_cast<double>(covered[2]), static_cast<double>(covered[1]), covered[1] * 0.02);
}

TEST(Extremes, DegenerateSliversDuplicatesNonManifoldEdgesAndBadNormals) {
  Mesh mesh = sphere(1.0);
  const uint32_t n = static_cast<uint32_t>(mesh.positions.size());
  // Duplicate vertices, a zero-area triangle, a sliver, a NaN normal.
  mesh.positions.push_back(mesh.positions[0]);
  mesh.positions.push_back(mesh.positions[0]);
  mesh.positions.push_back(mesh.positions[1] + glm::vec3(1e-7f, 0, 0));
  mesh.normals.push_back(glm::vec3(0.0f));
  mesh.normals.push_back(glm::vec3(std::nanf("")));
  mesh.normals.push_back(mesh.normals[1]);
  for (uint32_t i : {0u, n, n + 1, 1u, n + 2, 2u}) mesh.indices.push_back(i);
  mesh.normals[5] = glm::vec3(0.0f);
  // A non-manifold edge: a fin on the first triangle's first edge, which
  // three triangles then share.
  const uint32_t a = mesh.indices[0], b = mesh.indices[1];
  const glm::vec3 middle = 0.5f * (mesh.positions[a] + mesh.positions[b]);
  mesh.positions.push_back(middle * 1.2f);
  mesh.normals.push_back(glm::normalize(middle));
  for (uint32_t i : {a, b, n + 3}) mesh.indices.push_back(i);
  const auto views = ring(mesh, 4, 1.0);
  const Outcome o = renderAndCheck(mesh, views, views[1].camera, 2.0f);
  // The sphere is drawn around its broken triangles, not dropped.
  EXPECT_GT(o.covered, 100u);
  EXPECT_LT(o.hole, o.covered / 10);
}

TEST(Extremes, CameraAtAVertexBehindTheSubjectAndGrazing) {
  const Mesh mesh = sphere(1.0);
  auto views = ring(mesh, 4, 1.0);
  // A pod camera sitting exactly on a vertex, looking out, and one grazing
  // the surface.
  views[2].camera = lookAtCamera(2, glm::dvec3(mesh.positions[0]),
                                 glm::dvec3(mesh.positions[0]) * 2.0, {0, 1, 0}, 64, 48, 40.0);
  views[3].camera = lookAtCamera(3, {0.5, 0.0, 3.0}, {0.5, 0.0, -3.0}, {0, 1, 0}, 64, 48, 40.0);
  const Outcome o = renderAndCheck(mesh, views, views[0].camera, 2.0f);
  EXPECT_GT(o.covered, 100u);
  // The user at a vertex too.
  renderAndCheck(mesh, views, views[2].camera, 2.0f);
}

TEST(Extremes, AlphaAndCameraCountExtremesAndEmptyMasks) {
  const Mesh mesh = sphere(1.0);
  for (float alpha : {0.01f, 200.0f}) {
    const auto views = ring(mesh, 4, 1.0);
    EXPECT_GT(renderAndCheck(mesh, views, views[0].camera, alpha).covered, 100u) << alpha;
  }
  for (int count : {1, 16}) {
    const auto views = ring(mesh, count, 1.0);
    EXPECT_GT(renderAndCheck(mesh, views, views[0].camera, 2.0f).covered, 100u) << count;
  }
  const auto empty = ring(mesh, 4, 1.0, true);
  const Outcome o = renderAndCheck(mesh, empty, empty[0].camera, 2.0f);
  EXPECT_EQ(o.hole, o.covered) << "with every mask empty, every covered pixel is the hole colour";
}

// The distance of each mask pixel to the nearest background pixel, as a
// pod's feather map holds it (255 at most), by brute force on these small
// images.
Image8 featherOf(const Image8& mask) {
  Image8 feather(mask.width, mask.height, 1, 0);
  for (uint32_t y = 0; y < mask.height; ++y) {
    for (uint32_t x = 0; x < mask.width; ++x) {
      if (*mask.at(x, y) == 0) continue;
      double nearest = 255.0;
      for (uint32_t by = 0; by < mask.height; ++by) {
        for (uint32_t bx = 0; bx < mask.width; ++bx) {
          if (*mask.at(bx, by) != 0) continue;
          nearest = std::min(nearest, std::hypot(double(bx) - x, double(by) - y));
        }
      }
      feather.pixels[size_t{y} * mask.width + x] =
          static_cast<uint8_t>(std::lround(std::min(nearest, 255.0)));
    }
  }
  return feather;
}

// Every covered pixel of a render is the hole colour or, the pods' images
// being a uniform grey 200, that grey: a weight that went NaN, Inf or
// negative would show as another colour. Returns the covered and hole
// pixel counts.
std::pair<size_t, size_t> expectGreyOrHole(const Image8& out, const std::string& what) {
  size_t covered = 0, holes = 0;
  for (size_t p = 0; p < out.pixels.size(); p += 4) {
    if (out.pixels[p + 3] == 0) continue;
    ++covered;
    if (out.pixels[p] == 255 && out.pixels[p + 1] == 0 && out.pixels[p + 2] == 255) {
      ++holes;
      continue;
    }
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(out.pixels[p + k], 200, 1) << what << ", pixel " << p / 4;
  }
  return {covered, holes};
}

// Paper 004's per-fragment weights at the ends of their ranges, in mode
// fragment and in the field modes' per-fragment test: feather widths 0 and
// 1000 px, alpha 0.01 and 200, beta 0 and 50, one and sixteen cameras,
// empty masks and a part of the subject no camera sees.
TEST(Extremes, PerFragmentWeightsAtTheirLimitsGiveOnlyImageColoursOrTheHole) {
  const Mesh mesh = sphere(1.0);
  struct Case {
    int cameras;
    float width, alpha, beta;
    bool empty_masks;
  };
  const Case cases[] = {{4, 0, 2, 5, false},    {4, 1000, 2, 5, false}, {4, 8, 0.01f, 5, false},
                        {4, 8, 200, 5, false},  {4, 8, 2, 0, false},    {4, 8, 2, 50, false},
                        {4, 8, 200, 50, false}, {1, 8, 2, 5, false},    {16, 8, 2, 5, false},
                        {4, 8, 2, 5, true}};
  for (const Case& c : cases) {
    auto views = ring(mesh, c.cameras, 1.0, c.empty_masks);
    for (auto& view : views) view.feather = featherOf(view.mask);
    // With one pod the user looks from a quarter turn away: half of what
    // it sees no pod does.
    const double a = c.cameras == 1 ? M_PI / 2 : 2 * M_PI * 0.5 / c.cameras;
    const Camera user = lookAtCamera(99, {3 * std::sin(a), 0.4, 3 * std::cos(a)}, glm::dvec3(0.0),
                                     {0, 1, 0}, 64, 48, 40.0);
    for (const auto& [mode, fragment_test] :
         {std::pair{BlendMode::kFragment, false}, std::pair{BlendMode::kHoloportation, true},
          std::pair{BlendMode::kMontage4D, true}}) {
      const std::string what = blendModeName(mode) + ", " + std::to_string(c.cameras) +
                               " cameras, width " + std::to_string(c.width) + ", alpha " +
                               std::to_string(c.alpha) + ", beta " + std::to_string(c.beta) +
                               (c.empty_masks ? ", empty masks" : "");
      SCOPED_TRACE(what);
      Renderer renderer(context(), 64, 48);
      renderer.setMesh(mesh);
      renderer.setViews(views);
      BlendSettings settings;
      settings.mode = mode;
      settings.fragment_test = fragment_test;
      settings.feather_width_px = c.width;
      settings.alpha = c.alpha;
      settings.beta = c.beta;
      settings.hole_color = {1.0f, 0.0f, 1.0f};
      const auto [covered, holes] = expectGreyOrHole(renderer.render(user, settings), what);
      EXPECT_GT(covered, 100u);
      if (c.empty_masks) {
        EXPECT_EQ(holes, covered) << "no pod sees anything: every covered pixel is the hole";
      } else if (c.cameras == 1) {
        EXPECT_GT(holes, covered / 4) << "the side no pod sees is the hole";
        EXPECT_LT(holes, covered) << "the pod's side is not";
      } else if (mode == BlendMode::kFragment || c.alpha < 100) {
        // (The field modes' per-vertex powers underflow to 0 at alpha 200
        // and leave holes, as without the test; mode fragment sums its
        // weights in the log domain.)
        EXPECT_LT(holes, covered / 10);
      }
    }
  }
}

// The geodesic passes keep an entry's ring in 7 bits: k up to 64 renders,
// beyond it the renderer refuses by name rather than wrapping rings.
TEST(Extremes, GeodesicRingsBeyondTheirBoundAreRefusedByName) {
  const Mesh mesh = sphere(1.0);
  const auto views = ring(mesh, 4, 1.0);
  Renderer renderer(context(), 64, 48);
  renderer.setMesh(mesh);
  renderer.setViews(views);
  BlendSettings settings;
  settings.mode = BlendMode::kMontage4D;
  settings.fields.geodesic_rings = kMaxGeodesicRings;
  settings.fields.geodesic_radius = 0;  // k mean edges: the ring bound decides the reach
  const Image8 out = renderer.render(views[0].camera, settings);
  size_t covered = 0;
  for (size_t p = 3; p < out.pixels.size(); p += 4) covered += out.pixels[p] != 0;
  EXPECT_GT(covered, 100u);
  settings.fields.geodesic_rings = kMaxGeodesicRings + 1;
  try {
    renderer.render(views[0].camera, settings);
    FAIL() << "k beyond the bound rendered";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("geodesic rings k = 65"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace holofuse::render
