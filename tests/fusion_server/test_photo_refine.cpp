// Photo-consistency refinement of the visual hull: it moves the surface
// toward the subject, only inward, never bares a silhouette pixel, leaves
// colour that agrees everywhere alone, and the server stamps it as its own
// stage.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <stdexcept>

#include "codec/mesh_codec.h"
#include "fusion_server/fusion_worker.h"
#include "fusion_server/photo_refine.h"
#include "geometry/depth_raster.h"
#include "hull/visual_hull.h"
#include "protocol/frame.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

namespace holofuse::fusion {
namespace {

constexpr uint64_t kFrame = 12;
constexpr double kVoxel = 0.02;

struct Capture {
  std::vector<hull::HullView> views;
  std::vector<Image8> colors;
};

Capture syntheticCapture(int cameras, uint32_t w = 240, uint32_t h = 180) {
  const scene::SyntheticScene scene;
  Capture capture;
  for (const auto& camera : scene::SyntheticScene::cameraRig(cameras, w, h)) {
    const auto view = scene.render(camera, kFrame);
    capture.views.push_back({camera, view.mask, featherMap(view.mask)});
    capture.colors.push_back(view.color);
  }
  return capture;
}

Mesh carve(const Capture& capture) {
  hull::HullOptions options;
  options.voxel_size = kVoxel;
  return hull::carveVisualHull(capture.views, options);
}

PhotoRefineOptions refineOptions(double voxels) {
  PhotoRefineOptions options;
  options.depth_voxels = voxels;
  options.voxel_size = kVoxel;
  return options;
}

// Mean distance of the mesh's vertices from the subject's true surface.
double meanDistanceToTruth(const Mesh& mesh) {
  const scene::SyntheticScene scene;
  const double t = scene.timeOf(kFrame);
  double sum = 0;
  for (const auto& p : mesh.positions) sum += std::abs(scene.signedDistance(glm::dvec3(p), t));
  return sum / static_cast<double>(mesh.vertexCount());
}

TEST(PhotoRefine, MovesTheHullTowardTheSubjectOnlyInwardAndKeepsItsTriangles) {
  const Capture capture = syntheticCapture(6);
  const Mesh hull = carve(capture);
  ASSERT_GT(hull.vertexCount(), 1000u);
  PhotoRefineStats stats;
  const Mesh refined =
      refineByPhotoConsistency(hull, capture.views, capture.colors, refineOptions(4), &stats);
  ASSERT_EQ(refined.vertexCount(), hull.vertexCount());
  EXPECT_EQ(refined.indices, hull.indices);
  EXPECT_EQ(refined.vertex_keys, hull.vertex_keys);
  EXPECT_GT(stats.vertices_moved, hull.vertexCount() / 20)
      << "the subject is textured: a part of it moves";
  // Each vertex on the line inward along its normal, at most 4 voxels deep.
  for (size_t v = 0; v < hull.vertexCount(); ++v) {
    const glm::dvec3 moved = glm::dvec3(hull.positions[v]) - glm::dvec3(refined.positions[v]);
    const glm::dvec3 normal = glm::normalize(glm::dvec3(hull.normals[v]));
    const double depth = glm::dot(moved, normal);
    ASSERT_GE(depth, -1e-6) << "vertex " << v << " moved outward";
    ASSERT_LE(depth, 4 * kVoxel + 1e-6) << "vertex " << v;
    ASSERT_LT(glm::length(moved - depth * normal), 1e-5) << "vertex " << v << " moved sideways";
  }
  const double before = meanDistanceToTruth(hull), after = meanDistanceToTruth(refined);
  EXPECT_LT(after, 0.95 * before) << "mean distance to the true surface " << 1000 * before
                                  << " mm -> " << 1000 * after << " mm";
}

TEST(PhotoRefine, EverySilhouettePixelTheHullCoversStaysCovered) {
  const Capture capture = syntheticCapture(6);
  const Mesh hull = carve(capture);
  PhotoRefineStats stats;
  const Mesh refined =
      refineByPhotoConsistency(hull, capture.views, capture.colors, refineOptions(8), &stats);
  EXPECT_GT(stats.vertices_restored, 0u)
      << "8 voxels deep, some outline vertex must have been put back";
  for (const auto& view : capture.views) {
    const DepthMap before = rasterizeDepth(hull, view.camera),
                   after = rasterizeDepth(refined, view.camera);
    size_t covered = 0, bared = 0;
    for (size_t pixel = 0; pixel < before.depth.size(); ++pixel) {
      if (view.mask.pixels[pixel] == 0 || before.depth[pixel] == kNoDepth) continue;
      ++covered;
      bared += after.depth[pixel] == kNoDepth;
    }
    EXPECT_GT(covered, 1000u);
    EXPECT_EQ(bared, 0u) << "camera " << view.camera.id << ": of " << covered
                         << " silhouette pixels";
  }
}

TEST(PhotoRefine, ColourThatAgreesEverywhereMovesNothing) {
  Capture capture = syntheticCapture(4);
  for (auto& color : capture.colors) color = Image8(color.width, color.height, 3, 128);
  const Mesh hull = carve(capture);
  PhotoRefineStats stats;
  const Mesh refined =
      refineByPhotoConsistency(hull, capture.views, capture.colors, refineOptions(4), &stats);
  EXPECT_EQ(stats.vertices_moved, 0u);
  EXPECT_EQ(refined.positions, hull.positions);
}

TEST(PhotoRefine, OffGivesTheHullAndImagesThatDoNotFitAreRefusedByCamera) {
  Capture capture = syntheticCapture(4);
  const Mesh hull = carve(capture);
  EXPECT_EQ(
      refineByPhotoConsistency(hull, capture.views, capture.colors, refineOptions(0)).positions,
      hull.positions);
  capture.colors[2] = Image8(100, 100, 3, 0);
  try {
    refineByPhotoConsistency(hull, capture.views, capture.colors, refineOptions(4));
    FAIL() << "a 100x100 image for a 240x180 camera was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("camera 2"), std::string::npos) << e.what();
  }
}

// The server refines when asked and stamps the time between the hull and
// the mesh's encoding as the refine stage; unasked, there is no such stage.
TEST(PhotoRefine, TheServerStampsRefinementAsItsOwnStage) {
  const Capture capture = syntheticCapture(4, 160, 120);
  GroupJob job;
  job.group.frame_id = kFrame;
  job.group.complete = true;
  for (size_t i = 0; i < capture.views.size(); ++i) {
    PodImages pod;
    pod.camera_id = static_cast<uint32_t>(i);
    pod.color = capture.colors[i];
    pod.mask = capture.views[i].mask;
    pod.feather = capture.views[i].feather;
    pod.camera = capture.views[i].camera;
    job.group.pods[pod.camera_id] = pod;
  }
  const auto meshFrameOf = [&](double voxels, Mesh* mesh) {
    FusionSettings settings;
    settings.pods_expected = 4;
    settings.hull.voxel_size = kVoxel;
    settings.refine.depth_voxels = voxels;
    protocol::StreamDecoder decoder;
    decoder.feed(fuseGroup(job, settings).mesh_frame->flatten());
    EXPECT_TRUE(decoder.hasFrame());
    protocol::MeshFrame frame;
    const protocol::Frame bytes = decoder.takeFrame();
    EXPECT_TRUE(protocol::decodeFrame(bytes, frame).isOk());
    auto decoded = decodeDraco(frame.mesh.data(), frame.mesh.size());
    EXPECT_TRUE(decoded.isOk());
    if (decoded.isOk()) *mesh = std::move(*decoded);
    return frame.stamps;
  };
  const auto spanOf = [](const std::vector<protocol::StageStamp>& stamps, protocol::Stage stage) {
    for (const auto& s : stamps) {
      if (s.stage == static_cast<uint16_t>(stage)) return std::optional<protocol::StageStamp>(s);
    }
    return std::optional<protocol::StageStamp>();
  };
  Mesh plain, refined;
  const auto plain_stamps = meshFrameOf(0, &plain), refined_stamps = meshFrameOf(4, &refined);
  EXPECT_FALSE(spanOf(plain_stamps, protocol::Stage::kRefine));
  const auto hull = spanOf(refined_stamps, protocol::Stage::kHull);
  const auto refine = spanOf(refined_stamps, protocol::Stage::kRefine);
  const auto encode = spanOf(refined_stamps, protocol::Stage::kMeshEncode);
  ASSERT_TRUE(hull && refine && encode);
  EXPECT_EQ(refine->start_ns, hull->end_ns);
  EXPECT_EQ(encode->start_ns, refine->end_ns);
  EXPECT_GT(refine->end_ns, refine->start_ns);
  // The same triangles, some vertices elsewhere.
  ASSERT_EQ(refined.triangleCount(), plain.triangleCount());
  EXPECT_NE(refined.positions, plain.positions);
}

}  // namespace
}  // namespace holofuse::fusion
