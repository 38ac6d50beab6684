// The synthetic capture the import and capture-format tests write out in
// each format: four cameras named so that plain string order is wrong, one
// with skew; and the check that an imported dataset holds them.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dataset/dataset.h"
#include "protocol/messages.h"
#include "scene/synthetic_scene.h"

namespace holofuse::dataset {

namespace fs = std::filesystem;

inline cv::Mat toMat(const Image8& image) {
  cv::Mat m(static_cast<int>(image.height), static_cast<int>(image.width),
            CV_8UC(static_cast<int>(image.channels)), const_cast<uint8_t*>(image.pixels.data()));
  cv::Mat out;
  if (image.channels == 3) {
    cv::cvtColor(m, out, cv::COLOR_RGB2BGR);
  } else {
    out = m.clone();
  }
  return out;
}

inline double maskIoU(const Image8& a, const Image8& b) {
  size_t inter = 0, uni = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    inter += a.pixels[i] != 0 && b.pixels[i] != 0;
    uni += a.pixels[i] != 0 || b.pixels[i] != 0;
  }
  return uni ? static_cast<double>(inter) / static_cast<double>(uni) : 1.0;
}

// Four synthetic cameras, named so that plain string order is wrong.
class SyntheticCapture : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() /
            ("holofuse_import_" + std::to_string(::getpid()) + "_" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    fs::create_directories(root_);
    cameras_ = scene::SyntheticScene::cameraRig(4, 160, 120);
    cameras_[1].skew = 3.5;  // a real K with skew
    for (const auto& c : cameras_) views_.push_back(scene_.render(c, 30));
  }
  void TearDown() override { fs::remove_all(root_); }

  // Natural order of names_: cam1 (camera 3), cam2 (0), cam10 (1), cam11 (2).
  std::string name(size_t i) const { return names_[i]; }

  void writeImages(const fs::path& dir, const std::string& ext, bool rgba = false) {
    fs::create_directories(dir);
    for (size_t i = 0; i < cameras_.size(); ++i) {
      cv::Mat image = toMat(views_[i].color);
      if (rgba) {
        cv::Mat alpha = toMat(views_[i].mask);
        cv::Mat bgra;
        cv::cvtColor(image, bgra, cv::COLOR_BGR2BGRA);
        std::vector<cv::Mat> ch;
        cv::split(bgra, ch);
        ch[3] = alpha;
        cv::merge(ch, image);
      }
      ASSERT_TRUE(cv::imwrite((dir / (name(i) + ext)).string(), image));
    }
  }

  nlohmann::json holofuseJson(const std::string& ext, bool with_masks) const {
    nlohmann::json j;
    j["format"] = "holofuse-capture";
    j["version"] = 1;
    j["fps"] = 10;
    nlohmann::json frame;
    for (size_t i = 0; i < cameras_.size(); ++i) {
      const Camera& c = cameras_[i];
      nlohmann::json cam;
      cam["name"] = name(i);
      cam["width"] = c.width;
      cam["height"] = c.height;
      cam["K"] = {{c.fx, c.skew, c.cx}, {0, c.fy, c.cy}, {0, 0, 1}};
      nlohmann::json r = nlohmann::json::array();
      for (int row = 0; row < 3; ++row)
        r.push_back({c.rotation[0][row], c.rotation[1][row], c.rotation[2][row]});
      cam["R"] = r;
      cam["t"] = {c.translation.x, c.translation.y, c.translation.z};
      j["cameras"].push_back(cam);
      frame["images"][name(i)] = "images/" + name(i) + ext;
      if (with_masks) frame["masks"][name(i)] = "masks/" + name(i) + ".png";
    }
    j["frames"].push_back(frame);
    return j;
  }

  void writeMasks(const fs::path& dir, const std::string& suffix, bool rgb) {
    fs::create_directories(dir);
    for (size_t i = 0; i < cameras_.size(); ++i) {
      cv::Mat mask = toMat(views_[i].mask);
      if (rgb) {
        cv::Mat coloured;
        cv::cvtColor(mask, coloured, cv::COLOR_GRAY2BGR);
        coloured.setTo(cv::Scalar(0, 0, 0), mask == 0);
        coloured.setTo(cv::Scalar(0, 200, 0), mask != 0);  // only one channel set
        mask = coloured;
      }
      ASSERT_TRUE(cv::imwrite((dir / (name(i) + suffix)).string(), mask));
    }
  }

  // The imported dataset: cameras in natural name order, each calibration
  // as the source said, each mask as the truth.
  void expectDatasetMatches(const fs::path& out, double min_iou,
                            const std::string& name_suffix = "", size_t frames = 1) {
    auto dataset = Dataset::open(out.string());
    ASSERT_TRUE(dataset.isOk()) << dataset.status().toString();
    ASSERT_TRUE(dataset->metadata().has_value());
    const std::string x = name_suffix;
    EXPECT_EQ(dataset->metadata()->camera_names,
              (std::vector<std::string>{"cam1" + x, "cam2" + x, "cam10" + x, "cam11" + x}));
    EXPECT_EQ(dataset->metadata()->still, frames == 1);
    ASSERT_EQ(dataset->cameras().size(), 4u);
    const size_t source_of[4] = {3, 0, 1, 2};  // pod id -> index in cameras_
    for (const auto& [id, cam] : dataset->cameras()) {
      const Camera& truth = cameras_[source_of[id]];
      auto frame = dataset->readFrame(*cam.calibration);
      ASSERT_TRUE(frame.isOk());
      protocol::Calibration calibration;
      ASSERT_TRUE(protocol::decodeFrame(*frame, calibration).isOk());
      const Camera got = fromCalibration(calibration);
      EXPECT_EQ(got.id, id);
      EXPECT_NEAR(got.fx, truth.fx, 1e-6);
      EXPECT_NEAR(got.fy, truth.fy, 1e-6);
      EXPECT_NEAR(got.cx, truth.cx, 1e-6);
      EXPECT_NEAR(got.skew, truth.skew, 1e-6);
      EXPECT_LT(glm::length(got.center() - truth.center()), 1e-6) << "camera " << id;
      EXPECT_LT(glm::length(got.forward() - truth.forward()), 1e-6) << "camera " << id;
      ASSERT_EQ(cam.frames.size(), frames);
      auto pod = dataset->readFrame(cam.frames[0]);
      ASSERT_TRUE(pod.isOk());
      auto images = decodePodImages(*pod, got);
      ASSERT_TRUE(images.isOk()) << images.status().toString();
      EXPECT_GE(maskIoU(images->mask, views_[source_of[id]].mask), min_iou) << "camera " << id;
    }
    // The capture volume holds the subject's true surface, and not much more.
    const Mesh truth = scene_.truthMesh(30, 0.02);
    const glm::dvec3 lo = dataset->metadata()->volume_min, hi = dataset->metadata()->volume_max;
    glm::dvec3 subject_lo(1e9), subject_hi(-1e9);
    for (const auto& p : truth.positions) {
      subject_lo = glm::min(subject_lo, glm::dvec3(p));
      subject_hi = glm::max(subject_hi, glm::dvec3(p));
    }
    for (int k = 0; k < 3; ++k) {
      EXPECT_LE(lo[k], subject_lo[k]) << "axis " << k;
      EXPECT_GE(hi[k], subject_hi[k]) << "axis " << k;
      EXPECT_LT(hi[k] - lo[k], 2.0 * (subject_hi[k] - subject_lo[k]) + 0.3) << "axis " << k;
    }
  }

  fs::path root_;
  scene::SyntheticScene scene_;
  std::vector<Camera> cameras_;
  std::vector<scene::RenderedView> views_;
  std::vector<std::string> names_ = {"cam2", "cam10", "cam11", "cam1"};
};

}  // namespace holofuse::dataset
