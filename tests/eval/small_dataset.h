// A small imported dataset for the evaluation's tests: the synthetic
// scene's pods written out as PNG images and masks, imported as a real
// capture is (holofuse_dataset import), with the voxel size stored in its
// metadata.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "dataset/import.h"
#include "image/image_io.h"
#include "scene/synthetic_scene.h"

namespace holofuse::eval::test {

// cameras pods of the default scene at frame 30, width x height, into dir
// (replaced); the dataset stores voxel as its own.
inline void writeSmallDataset(const std::filesystem::path& dir, int cameras, uint32_t width,
                              uint32_t height, double voxel) {
  namespace fs = std::filesystem;
  fs::remove_all(dir);
  const fs::path source = dir.string() + ".source";
  fs::remove_all(source);
  fs::create_directories(source);
  const scene::SyntheticScene scene;
  dataset::CaptureDescription capture;
  capture.source = "synthetic test capture";
  dataset::CaptureFrame frame;
  const auto rig = scene::SyntheticScene::cameraRig(cameras, width, height);
  for (const Camera& camera : rig) {
    const std::string name = "cam" + std::to_string(camera.id);
    const auto view = scene.render(camera, 30);
    const fs::path image = source / (name + ".png"), mask = source / (name + "_mask.png");
    ASSERT_TRUE(writeImage(image.string(), view.color).isOk());
    ASSERT_TRUE(writeImage(mask.string(), view.mask).isOk());
    capture.cameras.push_back({name, camera, std::nullopt, ""});
    frame.images.push_back(image.string());
    frame.masks.push_back(mask.string());
  }
  capture.frames.push_back(frame);
  dataset::ImportOptions options;
  options.voxel_size = voxel;
  const auto imported = dataset::importCapture(capture, dir.string(), options);
  ASSERT_TRUE(imported.isOk()) << imported.status().toString();
  fs::remove_all(source);
}

}  // namespace holofuse::eval::test
