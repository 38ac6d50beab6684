// Every calibration format imports to the same cameras: one synthetic
// capture (import_fixture.h) is written out in each format the import
// reads, and each import must give back its calibrations, masks and names;
// a projection matrix is decomposed whatever its scale, sign and skew; bad
// input names the file and the line, byte or key.
#include <cmath>
#include <fstream>
#include <functional>
#include <iomanip>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "dataset/capture_formats.h"
#include "dataset/import.h"
#include "import_fixture.h"

namespace holofuse::dataset {
namespace {

class CaptureFormats : public SyntheticCapture {
 protected:
  // Formats without skew: camera 1 loses its skew and is rendered again.
  void dropSkew() {
    cameras_[1].skew = 0;
    views_[1] = scene_.render(cameras_[1], 30);
  }

  // K as OpenCV stores it: the first pixel's centre at 0, not 0.5.
  cv::Mat opencvK(const Camera& c) const {
    return (cv::Mat_<double>(3, 3) << c.fx, c.skew, c.cx - 0.5, 0, c.fy, c.cy - 0.5, 0, 0, 1);
  }
  static cv::Mat rotationOf(const Camera& c) {
    cv::Mat r(3, 3, CV_64F);
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 3; ++col) r.at<double>(row, col) = c.rotation[col][row];
    }
    return r;
  }
  static cv::Mat translationOf(const Camera& c) {
    return (cv::Mat_<double>(3, 1) << c.translation.x, c.translation.y, c.translation.z);
  }

  // Each camera's images as a folder of `frames` frames, masks likewise.
  void writeSequences(const fs::path& images, const fs::path& masks, size_t frames,
                      const std::string& prefix = "") {
    for (size_t i = 0; i < cameras_.size(); ++i) {
      fs::create_directories(images / name(i));
      fs::create_directories(masks / name(i));
      for (size_t f = 0; f < frames; ++f) {
        std::ostringstream file;
        file << (prefix.empty() ? "" : prefix + name(i) + "_") << std::setw(6) << std::setfill('0')
             << f << ".png";
        ASSERT_TRUE(cv::imwrite((images / name(i) / file.str()).string(), toMat(views_[i].color)));
        ASSERT_TRUE(cv::imwrite((masks / name(i) / file.str()).string(), toMat(views_[i].mask)));
      }
    }
  }

  // P = K [R | t] in OpenCV's pixel convention, times `scale`.
  std::array<double, 12> projectionOf(const Camera& c, double scale) const {
    const cv::Mat k = opencvK(c), r = rotationOf(c), t = translationOf(c);
    cv::Mat rt;
    cv::hconcat(r, t, rt);
    const cv::Mat p = k * rt * scale;
    std::array<double, 12> out{};
    for (int i = 0; i < 12; ++i) out[static_cast<size_t>(i)] = p.at<double>(i / 4, i % 4);
    return out;
  }

  // EasyMocap's intri.yml and extri.yml of the cameras: names, K, Rot, T.
  void writeIntriExtri(const fs::path& src) const {
    cv::FileStorage intri((src / "intri.yml").string(), cv::FileStorage::WRITE);
    cv::FileStorage extri((src / "extri.yml").string(), cv::FileStorage::WRITE);
    intri << "names"
          << "[";
    for (size_t i = 0; i < cameras_.size(); ++i) intri << name(i);
    intri << "]";
    for (size_t i = 0; i < cameras_.size(); ++i) {
      intri << "K_" + name(i) << opencvK(cameras_[i]);
      extri << "Rot_" + name(i) << rotationOf(cameras_[i]);
      extri << "T_" + name(i) << translationOf(cameras_[i]);
    }
  }

  // The capture read and imported into root_/out, with its masks counted.
  void importInto(const fs::path& src, CaptureFormat format, size_t masks_given) {
    auto capture = readCapture(src.string(), format);
    ASSERT_TRUE(capture.isOk()) << capture.status().toString();
    auto summary = importCapture(*capture, (root_ / "out").string(), {});
    ASSERT_TRUE(summary.isOk()) << summary.status().toString();
    EXPECT_EQ(summary->masks_given, masks_given);
  }

  void importAndMatch(const fs::path& src, CaptureFormat format, size_t masks_given,
                      const std::string& name_suffix = "", size_t frames = 1) {
    importInto(src, format, masks_given);
    if (HasFatalFailure()) return;
    expectDatasetMatches(root_ / "out", 0.999, name_suffix, frames);
  }

  // The message of a capture that must not read or import, and no dataset.
  std::string failure(const fs::path& src, CaptureFormat format) {
    const fs::path out = root_ / "refused";
    auto capture = readCapture(src.string(), format);
    if (!capture.isOk()) return capture.status().message();
    auto summary = importCapture(*capture, out.string(), {});
    EXPECT_FALSE(summary.isOk());
    EXPECT_FALSE(fs::exists(out));
    return summary.isOk() ? "" : summary.status().message();
  }
};

TEST_F(CaptureFormats, HolofuseJsonWithGreyMasksAndJpegImages) {
  const fs::path src = root_ / "src";
  writeImages(src / "images", ".jpg");
  writeMasks(src / "masks", ".png", false);
  std::ofstream(src / "capture.json") << holofuseJson(".jpg", true).dump(2);
  auto capture = readCapture(src.string(), CaptureFormat::kHolofuse);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  auto summary = importCapture(*capture, (root_ / "out").string(), {});
  ASSERT_TRUE(summary.isOk()) << summary.status().toString();
  EXPECT_EQ(summary->masks_given, 4u);
  expectDatasetMatches(root_ / "out", 0.999);
}

TEST_F(CaptureFormats, ColmapTextInSparseZeroWithRgbMasks) {
  const fs::path src = root_ / "src";
  dropSkew();  // COLMAP's models have no skew
  writeImages(src / "images", ".png");
  fs::create_directories(src / "sparse" / "0");
  std::ofstream cameras(src / "sparse" / "0" / "cameras.txt");
  std::ofstream images(src / "sparse" / "0" / "images.txt");
  cameras << "# CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  images << "# IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n";
  for (size_t i = 0; i < cameras_.size(); ++i) {
    const Camera& c = cameras_[i];
    cameras << i + 1 << " PINHOLE " << c.width << " " << c.height << " " << std::setprecision(17)
            << c.fx << " " << c.fy << " " << c.cx << " " << c.cy << "\n";
    const glm::dquat q = glm::quat_cast(c.rotation);
    images << i + 1 << " " << std::setprecision(17) << q.w << " " << q.x << " " << q.y << " " << q.z
           << " " << c.translation.x << " " << c.translation.y << " " << c.translation.z << " "
           << i + 1 << " " << name(i) << ".png\n";
    images << "12.5 3.5 -1 40.0 7.25 -1\n";  // POINTS2D
  }
  cameras.close();
  images.close();
  // COLMAP's convention: masks/<image name>.png.
  writeMasks(src / "masks", ".png.png", true);
  auto capture = readCapture(src.string(), CaptureFormat::kColmap);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  auto summary = importCapture(*capture, (root_ / "out").string(), {});
  ASSERT_TRUE(summary.isOk()) << summary.status().toString();
  EXPECT_EQ(summary->masks_given, 4u);
  expectDatasetMatches(root_ / "out", 0.999, ".png");  // COLMAP names cameras by image file
}

// A transforms file's frames for the cameras of `indices`: OpenGL camera
// axes, file paths under `folder` without extension, intrinsics from the
// field of view.
nlohmann::json nerfTransforms(const std::vector<Camera>& cameras,
                              const std::vector<size_t>& indices,
                              const std::function<std::string(size_t)>& file_of) {
  nlohmann::json j;
  j["camera_angle_x"] = 2 * std::atan(0.5 * cameras[0].width / cameras[0].fx);
  j["w"] = cameras[0].width;
  j["h"] = cameras[0].height;
  for (const size_t i : indices) {
    const Camera& c = cameras[i];
    const glm::dmat3 to_world = glm::transpose(c.rotation);
    const glm::dvec3 centre = c.center();
    nlohmann::json m = nlohmann::json::array();
    for (int row = 0; row < 3; ++row) {
      // OpenGL axes: OpenCV's y and z negated.
      m.push_back({to_world[0][row], -to_world[1][row], -to_world[2][row], centre[row]});
    }
    m.push_back({0, 0, 0, 1});
    j["frames"].push_back({{"file_path", file_of(i)}, {"transform_matrix", m}});
  }
  return j;
}

// transforms.json: OpenGL camera axes, RGBA images whose alpha is the mask,
// file paths without extension, intrinsics from the field of view.
TEST_F(CaptureFormats, NerfTransformsWithAlphaMasks) {
  const fs::path src = root_ / "src";
  cameras_[1].skew = 0;
  views_[1] = scene_.render(cameras_[1], 30);
  writeImages(src / "train", ".png", true);
  std::ofstream(src / "transforms.json") << nerfTransforms(cameras_, {0, 1, 2, 3}, [&](size_t i) {
                                              return "./train/" + name(i);
                                            }).dump(2);
  importAndMatch(src, CaptureFormat::kNerf, 4);
}

// The NeRF synthetic scenes' Blender layout: a transforms file per split,
// each camera named by its split and kept in that split in the metadata.
TEST_F(CaptureFormats, NerfBlenderSplitsKeepEachCamerasSplit) {
  const fs::path src = root_ / "src";
  dropSkew();
  const std::vector<std::pair<std::string, std::vector<size_t>>> splits = {
      {"train", {0, 1}}, {"val", {2}}, {"test", {3}}};
  for (const auto& [split, indices] : splits) {
    writeImages(src / split, ".png", true);
    std::ofstream(src / ("transforms_" + split + ".json"))
        << nerfTransforms(cameras_, indices, [&, split = split](size_t i) {
             return "./" + split + "/" + name(i);
           }).dump(2);
  }
  importInto(src, CaptureFormat::kNerf, 4);
  ASSERT_FALSE(HasFatalFailure());
  const auto dataset = Dataset::open((root_ / "out").string());
  ASSERT_TRUE(dataset.isOk()) << dataset.status().toString();
  const DatasetMetadata& metadata = *dataset->metadata();
  ASSERT_EQ(metadata.camera_names.size(), 4u);
  ASSERT_EQ(metadata.camera_splits.size(), 4u);
  std::map<std::string, std::string> split_of;
  for (size_t c = 0; c < 4; ++c) split_of[metadata.camera_names[c]] = metadata.camera_splits[c];
  EXPECT_EQ(split_of["train/" + name(0)], "train");
  EXPECT_EQ(split_of["train/" + name(1)], "train");
  EXPECT_EQ(split_of["val/" + name(2)], "val");
  EXPECT_EQ(split_of["test/" + name(3)], "test");
  // Neither layout: every file looked for is named.
  fs::create_directories(root_ / "empty");
  EXPECT_NE(failure(root_ / "empty", CaptureFormat::kNerf)
                .find("no transforms.json, nor the Blender layout's transforms_train.json"),
            std::string::npos);
}

// nerfstudio's per-frame mask_path, and its camera_model: a fisheye is
// refused by name rather than read as a pinhole with radial distortion.
TEST_F(CaptureFormats, NerfstudioMaskPathsAndCameraModels) {
  const fs::path src = root_ / "src";
  dropSkew();
  writeImages(src / "images", ".png", false);
  writeMasks(src / "segmentation", "_person.png", false);
  nlohmann::json j = nerfTransforms(cameras_, {0, 1, 2, 3},
                                    [&](size_t i) { return "images/" + name(i) + ".png"; });
  j["camera_model"] = "OPENCV";
  for (size_t i = 0; i < 4; ++i)
    j["frames"][i]["mask_path"] = "segmentation/" + name(i) + "_person.png";
  std::ofstream(src / "transforms.json") << j.dump(2);
  importAndMatch(src, CaptureFormat::kNerf, 4, ".png");

  j["frames"][2]["mask_path"] = "segmentation/missing.png";
  std::ofstream(src / "transforms.json") << j.dump(2);
  EXPECT_NE(failure(src, CaptureFormat::kNerf).find("frames[2]: mask_path"), std::string::npos);

  j["frames"][2]["mask_path"] = "segmentation/" + name(2) + "_person.png";
  j["frames"][1]["camera_model"] = "OPENCV_FISHEYE";
  std::ofstream(src / "transforms.json") << j.dump(2);
  const std::string fisheye = failure(src, CaptureFormat::kNerf);
  EXPECT_NE(fisheye.find("frames[1]: camera_model \"OPENCV_FISHEYE\" is not supported yet (a "
                         "fisheye"),
            std::string::npos)
      << fisheye;
  j["frames"][1].erase("camera_model");
  j["camera_model"] = "EQUIRECTANGULAR";
  std::ofstream(src / "transforms.json") << j.dump(2);
  EXPECT_NE(failure(src, CaptureFormat::kNerf).find("camera_model \"EQUIRECTANGULAR\""),
            std::string::npos);
}

// COLMAP's default output: cameras.bin and images.bin, little-endian.
class LittleEndian {
 public:
  template <typename T>
  LittleEndian& operator<<(T value) {
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof(T));
    return *this;
  }
  LittleEndian& name(const std::string& text) {
    bytes_.append(text).push_back('\0');
    return *this;
  }
  void writeTo(const fs::path& file) const { std::ofstream(file, std::ios::binary) << bytes_; }
  std::string bytes_;
};

TEST_F(CaptureFormats, ColmapBinaryInSparseZero) {
  const fs::path src = root_ / "src";
  dropSkew();
  writeImages(src / "images", ".png");
  writeMasks(src / "masks", ".png.png", false);
  fs::create_directories(src / "sparse" / "0");
  LittleEndian cameras, images;
  cameras << uint64_t{cameras_.size()};
  images << uint64_t{cameras_.size()};
  for (size_t i = 0; i < cameras_.size(); ++i) {
    const Camera& c = cameras_[i];
    const int32_t id = static_cast<int32_t>(7 * i + 3);  // ids need not be contiguous
    cameras << id << int32_t{1} << uint64_t{c.width} << uint64_t{c.height} << c.fx << c.fy << c.cx
            << c.cy;  // model 1: PINHOLE
    const glm::dquat q = glm::quat_cast(c.rotation);
    images << static_cast<int32_t>(i + 1) << q.w << q.x << q.y << q.z << c.translation.x
           << c.translation.y << c.translation.z << id;
    images.name(name(i) + ".png") << uint64_t{2} << 12.5 << 3.5 << int64_t{-1} << 40.0 << 7.25
                                  << int64_t{5};
  }
  cameras.writeTo(src / "sparse" / "0" / "cameras.bin");
  images.writeTo(src / "sparse" / "0" / "images.bin");
  importAndMatch(src, CaptureFormat::kColmap, 4, ".png");

  // A file cut short is named with the byte where it ends.
  const std::string cut = images.bytes_.substr(0, images.bytes_.size() - 30);
  std::ofstream(src / "sparse" / "0" / "images.bin", std::ios::binary) << cut;
  const std::string message = failure(src, CaptureFormat::kColmap);
  EXPECT_NE(message.find("images.bin at byte"), std::string::npos) << message;
  EXPECT_NE(message.find("the file ends inside the 2D points"), std::string::npos) << message;
}

// EasyMocap and ZJU-MoCap: intri.yml and extri.yml, one folder of frames
// per camera; R as a Rodrigues vector for some cameras, Rot for others.
TEST_F(CaptureFormats, OpencvIntriAndExtriWithAFolderOfFramesPerCamera) {
  const fs::path src = root_ / "src";
  writeSequences(src / "images", src / "mask", 2);
  cv::FileStorage intri((src / "intri.yml").string(), cv::FileStorage::WRITE);
  cv::FileStorage extri((src / "extri.yml").string(), cv::FileStorage::WRITE);
  intri << "names"
        << "[";
  extri << "names"
        << "[";
  for (size_t i = 0; i < cameras_.size(); ++i) {
    intri << name(i);
    extri << name(i);
  }
  intri << "]";
  extri << "]";
  for (size_t i = 0; i < cameras_.size(); ++i) {
    const Camera& c = cameras_[i];
    intri << "K_" + name(i) << opencvK(c);
    intri << "dist_" + name(i) << cv::Mat::zeros(1, 5, CV_64F);
    if (i % 2 == 0) {
      const glm::dquat q = glm::quat_cast(c.rotation);
      const glm::dvec3 rodrigues = glm::axis(q) * glm::angle(q);  // axis times angle
      extri << "R_" + name(i) << (cv::Mat_<double>(3, 1) << rodrigues.x, rodrigues.y, rodrigues.z);
    } else {
      extri << "Rot_" + name(i) << rotationOf(c);
    }
    extri << "T_" + name(i) << translationOf(c);
  }
  intri.release();
  extri.release();
  importAndMatch(src, CaptureFormat::kOpencv, 8, "", 2);

  // One camera with a frame fewer: named, with both counts.
  fs::remove(src / "images" / "cam10" / "000001.png");
  const std::string message = failure(src, CaptureFormat::kOpencv);
  EXPECT_NE(message.find("camera \"cam10\" has 1 frames"), std::string::npos) << message;
}

// A capture as one video per camera (ZJU-MoCap's and Panoptic's layout),
// masks as videos too: read with OpenCV's FFmpeg reader, frames matched by
// index; a camera whose video is a frame short is named with both counts.
TEST_F(CaptureFormats, OneVideoPerCameraWithMaskVideos) {
  const fs::path src = root_ / "src";
  fs::create_directories(src / "images");
  fs::create_directories(src / "mask");
  auto writeVideo = [&](const fs::path& file, const cv::Mat& frame, int frames) {
    // FFV1: lossless, so the masks and colours come back as written.
    cv::VideoWriter writer(file.string(), cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 15,
                           frame.size());
    ASSERT_TRUE(writer.isOpened()) << file;
    for (int f = 0; f < frames; ++f) writer << frame;
  };
  for (size_t i = 0; i < cameras_.size(); ++i) {
    writeVideo(src / "images" / (name(i) + ".mkv"), toMat(views_[i].color), 3);
    cv::Mat mask;
    cv::cvtColor(toMat(views_[i].mask), mask, cv::COLOR_GRAY2BGR);
    writeVideo(src / "mask" / (name(i) + ".mkv"), mask, 3);
  }
  writeIntriExtri(src);
  auto capture = readCapture(src.string(), CaptureFormat::kOpencv);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  EXPECT_NEAR(capture->fps, 15.0, 1e-6) << "the videos' frame rate";
  importAndMatch(src, CaptureFormat::kOpencv, 12, "", 3);

  // A camera that stopped a frame early: its last time is dropped, and
  // said so by camera and video.
  writeVideo(src / "images" / "cam10.mkv", toMat(views_[1].color), 2);
  capture = readCapture(src.string(), CaptureFormat::kOpencv);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  EXPECT_EQ(capture->frames.size(), 2u);
  const std::string& matching = capture->frame_matching;
  EXPECT_NE(matching.find("1 of its 3 times dropped"), std::string::npos) << matching;
  EXPECT_NE(matching.find("camera \"cam10\", " + (src / "images" / "cam10.mkv").string()),
            std::string::npos)
      << matching;
}

// Cameras at different rates pair by time, not by index: three cameras at
// 10 fps and one at 20 fps give four frames, the fast camera's every
// other one, each frame of the dataset showing one instant in every
// camera (the subject moves from frame to frame).
TEST_F(CaptureFormats, VideosAtDifferentRatesPairByTimestamp) {
  const fs::path src = root_ / "src";
  fs::create_directories(src / "images");
  const size_t fast = 3;  // cameras_[3] is cam1, pod 0 in natural name order
  for (size_t i = 0; i < cameras_.size(); ++i) {
    const int rate = i == fast ? 20 : 10;
    cv::VideoWriter writer(
        (src / "images" / (name(i) + ".mkv")).string(), cv::VideoWriter::fourcc('F', 'F', 'V', '1'),
        rate, cv::Size(static_cast<int>(cameras_[i].width), static_cast<int>(cameras_[i].height)));
    ASSERT_TRUE(writer.isOpened());
    // Frame f of a 20 fps camera shows scene frame 30 + f / 2 (and odd
    // frames a later moment, 40 + f).
    for (int f = 0; f < (i == fast ? 8 : 4); ++f) {
      const uint64_t scene_frame = i != fast ? 30 + f : (f % 2 == 0 ? 30 + f / 2 : 40 + f);
      writer << toMat(scene_.render(cameras_[i], scene_frame).color);
    }
  }
  writeIntriExtri(src);
  auto capture = readCapture(src.string(), CaptureFormat::kOpencv);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  ASSERT_EQ(capture->frames.size(), 4u) << capture->frame_matching;
  EXPECT_NEAR(capture->fps, 10.0, 1e-6) << "the slowest camera's rate";
  EXPECT_NE(capture->frame_matching.find("timestamps"), std::string::npos)
      << capture->frame_matching;
  for (size_t f = 0; f < 4; ++f) {
    // Cameras are in natural name order: cam1 (the fast one) first.
    EXPECT_EQ(capture->frames[f].images[0],
              videoFrameName((src / "images" / "cam1.mkv").string(), 2 * f));
    EXPECT_EQ(capture->frames[f].images[1],
              videoFrameName((src / "images" / "cam2.mkv").string(), f));
  }
  auto summary = importCapture(*capture, (root_ / "out").string(), {});
  ASSERT_TRUE(summary.isOk()) << summary.status().toString();
  EXPECT_EQ(summary->frames, 4u);
}

// OpenCV's calibration sample: one file per camera, YAML or XML.
TEST_F(CaptureFormats, OpencvOneFilePerCamera) {
  const fs::path src = root_ / "src";
  writeImages(src / "images", ".png");
  writeMasks(src / "masks", ".png", true);
  for (size_t i = 0; i < cameras_.size(); ++i) {
    const Camera& c = cameras_[i];
    cv::FileStorage file((src / (name(i) + (i == 2 ? ".xml" : ".yml"))).string(),
                         cv::FileStorage::WRITE);
    file << "image_width" << static_cast<int>(c.width) << "image_height"
         << static_cast<int>(c.height);
    file << "camera_matrix" << opencvK(c);
    file << "distortion_coefficients" << cv::Mat::zeros(5, 1, CV_64F);
    file << "R" << rotationOf(c) << "T" << translationOf(c);
  }
  importAndMatch(src, CaptureFormat::kOpencv, 4);

  // A file that does not parse is named.
  std::ofstream(src / "cam2.yml") << "%YAML:1.0\ncamera_matrix: [1, 2\n";
  const std::string message = failure(src, CaptureFormat::kOpencv);
  EXPECT_NE(message.find((src / "cam2.yml").string()), std::string::npos) << message;
}

// P = K [R | t] comes back whatever P's scale and sign, with skew kept.
TEST_F(CaptureFormats, AProjectionMatrixDecomposesWithAnyScaleAndSkew) {
  Camera truth = cameras_[1];  // skew 3.5
  truth.cy += 7.0;
  for (double scale : {1.0, -1.0, 0.004, -250.0}) {
    const auto p = projectionOf(truth, scale);
    auto got = cameraFromProjection(p, "P");
    ASSERT_TRUE(got.isOk()) << got.status().toString();
    EXPECT_NEAR(got->fx, truth.fx, 1e-7) << scale;
    EXPECT_NEAR(got->fy, truth.fy, 1e-7) << scale;
    EXPECT_NEAR(got->skew, truth.skew, 1e-7) << scale;
    EXPECT_NEAR(got->cx, truth.cx - 0.5, 1e-7) << scale;
    EXPECT_NEAR(got->cy, truth.cy - 0.5, 1e-7) << scale;
    EXPECT_NEAR(glm::determinant(got->rotation), 1.0, 1e-9) << scale;
    for (int col = 0; col < 3; ++col) {
      for (int row = 0; row < 3; ++row)
        EXPECT_NEAR(got->rotation[col][row], truth.rotation[col][row], 1e-9) << scale;
    }
    EXPECT_LT(glm::length(got->translation - truth.translation), 1e-9) << scale;
  }
  std::array<double, 12> singular = projectionOf(truth, 1.0);
  for (int col = 0; col < 4; ++col) singular[8 + col] = 2 * singular[4 + col];  // row 3 = 2 row 2
  auto refused = cameraFromProjection(singular, "cam.pa");
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find("cam.pa: the projection matrix's left 3x3 is singular"),
            std::string::npos)
      << refused.status().message();
  std::array<double, 12> not_finite = projectionOf(truth, 1.0);
  not_finite[5] = std::nan("");
  EXPECT_FALSE(cameraFromProjection(not_finite, "cam.pa").isOk());
}

// The ETH course's .pa files and DTU's pos_NNN.txt: one matrix per image,
// some with a negative scale.
TEST_F(CaptureFormats, ProjectionMatricesPerImage) {
  const fs::path src = root_ / "src";
  writeImages(src, ".png");
  writeMasks(src / "masks", ".png", false);
  const double scales[4] = {1.0, -1.0, 0.01, -3.0};
  for (size_t i = 0; i < cameras_.size(); ++i) {
    std::ofstream file(src / (name(i) + ".pa"));
    const auto p = projectionOf(cameras_[i], scales[i]);
    for (int row = 0; row < 3; ++row) {
      file << std::setprecision(17) << p[4 * row] << " " << p[4 * row + 1] << " " << p[4 * row + 2]
           << " " << p[4 * row + 3] << "\n";
    }
  }
  importAndMatch(src, CaptureFormat::kProjections, 4);

  // DTU names: pos_NNN.txt beside rect_NNN_3_r5000.png, with PMVS's
  // CONTOUR line; the same cameras come back.
  const fs::path dtu = root_ / "dtu";
  fs::create_directories(dtu / "images");
  for (size_t i = 0; i < cameras_.size(); ++i) {
    std::ostringstream stem;
    stem << std::setw(3) << std::setfill('0') << i + 1;
    fs::copy_file(src / (name(i) + ".png"),
                  dtu / "images" / ("rect_" + stem.str() + "_3_r5000.png"));
    std::ofstream file(dtu / ("pos_" + stem.str() + ".txt"));
    file << "CONTOUR\n";
    const auto p = projectionOf(cameras_[i], 1.0);
    for (double v : p) file << std::setprecision(17) << v << " ";
  }
  auto capture = readCapture(dtu.string(), CaptureFormat::kProjections);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  ASSERT_EQ(capture->cameras.size(), 4u);
  for (size_t k = 0; k < 4; ++k) {
    const Camera& got = capture->cameras[k].camera;
    const Camera& truth = cameras_[k];  // pos_001 is cameras_[0], and so on
    EXPECT_EQ(capture->cameras[k].name, "pos_00" + std::to_string(k + 1));
    EXPECT_NEAR(got.cx, truth.cx, 1e-6);
    EXPECT_NEAR(got.skew, truth.skew, 1e-6);
    EXPECT_LT(glm::length(got.center() - truth.center()), 1e-6);
  }

  // A value that is not a number is named with its line.
  std::ofstream(src / "cam10.pa") << "1 0 0 0\n0 1 0 0\n0 0 nan 1\n";
  std::string message = failure(src, CaptureFormat::kProjections);
  EXPECT_NE(message.find((src / "cam10.pa").string() + ":3: 'nan' is not a finite number"),
            std::string::npos)
      << message;
  std::ofstream(src / "cam10.pa") << "1 2 3 0\n2 4 6 0\n0 0 1 1\n";
  message = failure(src, CaptureFormat::kProjections);
  EXPECT_NE(message.find("cam10.pa: the projection matrix's left 3x3 is singular"),
            std::string::npos)
      << message;
}

// Middlebury multi-view: <name>_par.txt, K R t per image, images beside.
TEST_F(CaptureFormats, MiddleburyParameterFile) {
  const fs::path src = root_ / "src";
  dropSkew();  // Middlebury's K has none; the reader would keep it
  writeImages(src, ".png");
  writeMasks(src / "masks", ".png", false);
  std::ofstream par(src / "scene_par.txt");
  par << cameras_.size() << "\n" << std::setprecision(17);
  for (size_t i = 0; i < cameras_.size(); ++i) {
    const Camera& c = cameras_[i];
    par << name(i) << ".png " << c.fx << " 0 " << c.cx - 0.5 << " 0 " << c.fy << " " << c.cy - 0.5
        << " 0 0 1";
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 3; ++col) par << " " << c.rotation[col][row];
    }
    par << " " << c.translation.x << " " << c.translation.y << " " << c.translation.z << "\n";
  }
  par.close();
  importAndMatch(src, CaptureFormat::kMiddlebury, 4, ".png");

  std::ofstream(src / "scene_par.txt") << "5\ncam1.png 1 0 0 0 1 0 0 0 1\n";
  const std::string message = failure(src, CaptureFormat::kMiddlebury);
  EXPECT_NE(message.find("declares 5 images and lists 1"), std::string::npos) << message;
}

// CMU Panoptic: calibration_<sequence>.json; only the cameras whose images
// are present are kept (its VGA cameras usually are not).
TEST_F(CaptureFormats, PanopticCalibrationKeepsTheCamerasWithImages) {
  const fs::path src = root_ / "src";
  writeSequences(src / "hdImgs", src / "masks", 1, "");
  nlohmann::json j;
  j["calibDataSource"] = "synthetic";
  for (size_t i = 0; i < cameras_.size(); ++i) {
    const Camera& c = cameras_[i];
    nlohmann::json cam;
    cam["name"] = name(i);
    cam["type"] = "hd";
    cam["resolution"] = {c.width, c.height};
    cam["K"] = {{c.fx, c.skew, c.cx - 0.5}, {0, c.fy, c.cy - 0.5}, {0, 0, 1}};
    cam["distCoef"] = {0, 0, 0, 0, 0};
    nlohmann::json r = nlohmann::json::array();
    for (int row = 0; row < 3; ++row)
      r.push_back({c.rotation[0][row], c.rotation[1][row], c.rotation[2][row]});
    cam["R"] = r;
    cam["t"] = {{c.translation.x}, {c.translation.y}, {c.translation.z}};
    j["cameras"].push_back(cam);
  }
  nlohmann::json vga = j["cameras"][0];
  vga["name"] = "01_01";
  vga["type"] = "vga";
  j["cameras"].push_back(vga);
  std::ofstream(src / "calibration_synthetic.json") << j.dump(1);
  importAndMatch(src, CaptureFormat::kPanoptic, 4);

  j["cameras"][3]["R"][1][1] = "x";
  std::ofstream(src / "calibration_synthetic.json") << j.dump(1);
  const std::string message = failure(src, CaptureFormat::kPanoptic);
  EXPECT_NE(message.find("cameras[3].R: expected 9 numbers"), std::string::npos) << message;
}

}  // namespace
}  // namespace holofuse::dataset
