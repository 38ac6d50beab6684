// Importing real captures (the formats themselves: test_capture_formats):
// distortion is undone, names sorted naturally, masks read as stored or
// segmented when missing, a camera apart from the rest named; bad input
// is named and leaves nothing behind.
#include <cmath>
#include <fstream>
#include <opencv2/videoio.hpp>

#include "dataset/capture_formats.h"
#include "dataset/import.h"
#include "dataset/inspection.h"
#include "image/image_io.h"
#include "import_fixture.h"
#include "scene/scene_library.h"

namespace holofuse::dataset {
namespace {

class ImportTest : public SyntheticCapture {};

TEST_F(ImportTest, NaturalNameOrder) {
  EXPECT_TRUE(naturalLess("cam2", "cam10"));
  EXPECT_FALSE(naturalLess("cam10", "cam2"));
  EXPECT_TRUE(naturalLess("a01b", "a1c"));
  EXPECT_TRUE(naturalLess("img9.png", "img10.png"));
  EXPECT_FALSE(naturalLess("x", "x"));
}

// Lens distortion is undone: images taken through a distorting lens import
// to what the pinhole camera sees.
TEST_F(ImportTest, RadialDistortionIsUndone) {
  const fs::path src = root_ / "src";
  fs::create_directories(src / "images");
  fs::create_directories(src / "masks");
  const std::vector<double> distortion = {-0.25, 0.08, 0.001, -0.002, 0.0};
  nlohmann::json j = holofuseJson(".png", true);
  for (size_t i = 0; i < cameras_.size(); ++i) {
    Camera lens = cameras_[i];
    lens.distortion = distortion;
    // The distorted picture: each of its pixels looks where the lens bends
    // it, found by inverting the distortion numerically.
    cv::Mat map_x(static_cast<int>(lens.height), static_cast<int>(lens.width), CV_32FC1);
    cv::Mat map_y(map_x.size(), CV_32FC1);
    for (uint32_t y = 0; y < lens.height; ++y) {
      for (uint32_t x = 0; x < lens.width; ++x) {
        // Undistort by fixed-point iteration in normalised coordinates.
        const double yd = (y + 0.5 - lens.cy) / lens.fy,
                     xd = (x + 0.5 - lens.cx - lens.skew * yd) / lens.fx;
        double xu = xd, yu = yd;
        for (int it = 0; it < 50; ++it) {
          const double r2 = xu * xu + yu * yu;
          const double radial = 1 + r2 * (distortion[0] + r2 * distortion[1]);
          const double dx = 2 * distortion[2] * xu * yu + distortion[3] * (r2 + 2 * xu * xu);
          const double dy = distortion[2] * (r2 + 2 * yu * yu) + 2 * distortion[3] * xu * yu;
          xu = (xd - dx) / radial;
          yu = (yd - dy) / radial;
        }
        map_x.at<float>(static_cast<int>(y), static_cast<int>(x)) =
            static_cast<float>(lens.fx * xu + lens.skew * yu + lens.cx - 0.5);
        map_y.at<float>(static_cast<int>(y), static_cast<int>(x)) =
            static_cast<float>(lens.fy * yu + lens.cy - 0.5);
      }
    }
    cv::Mat color, mask;
    cv::remap(toMat(views_[i].color), color, map_x, map_y, cv::INTER_LINEAR);
    cv::remap(toMat(views_[i].mask), mask, map_x, map_y, cv::INTER_NEAREST);
    cv::imwrite((src / "images" / (name(i) + ".png")).string(), color);
    cv::imwrite((src / "masks" / (name(i) + ".png")).string(), mask);
    j["cameras"][i]["distortion"] = distortion;
  }
  std::ofstream(src / "capture.json") << j.dump(2);
  auto capture = readCapture(src.string(), CaptureFormat::kHolofuse);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  // Without undoing it the masks would be off by several pixels at the
  // edges; undone, they match the pinhole truth but for resampling.
  auto summary = importCapture(*capture, (root_ / "out").string(), {});
  ASSERT_TRUE(summary.isOk()) << summary.status().toString();
  expectDatasetMatches(root_ / "out", 0.985);  // measured 0.992-0.995; 0.96 when not undone
  // The calibration that goes out has no distortion left.
  auto dataset = Dataset::open((root_ / "out").string());
  auto frame = dataset->readFrame(*dataset->cameras().begin()->second.calibration);
  protocol::Calibration calibration;
  ASSERT_TRUE(protocol::decodeFrame(*frame, calibration).isOk());
  for (double k : calibration.distortion) EXPECT_EQ(k, 0.0);
}

// No masks: a background plate when the source has one, brightness
// otherwise (the subject on black).
TEST_F(ImportTest, MissingMasksAreSegmented) {
  const fs::path src = root_ / "src";
  fs::create_directories(src / "images");
  fs::create_directories(src / "plates");
  nlohmann::json j = holofuseJson(".png", false);
  for (size_t i = 0; i < cameras_.size(); ++i) {
    if (i % 2 == 0) {
      cv::imwrite((src / "images" / (name(i) + ".png")).string(), toMat(views_[i].color));
      cv::imwrite((src / "plates" / (name(i) + ".png")).string(),
                  toMat(scene_.backgroundPlate(cameras_[i])));
      j["cameras"][i]["background"] = "plates/" + name(i) + ".png";
    } else {
      cv::Mat on_black = toMat(views_[i].color);
      on_black.setTo(cv::Scalar(0, 0, 0), toMat(views_[i].mask) == 0);
      cv::imwrite((src / "images" / (name(i) + ".png")).string(), on_black);
    }
  }
  std::ofstream(src / "capture.json") << j.dump(2);
  auto capture = readCapture(src.string(), CaptureFormat::kHolofuse);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  // Dark clothes on black: Otsu's threshold would cut them; a low fixed
  // threshold keeps them (the documented knob).
  ImportOptions options;
  options.threshold = 0.03;
  auto summary = importCapture(*capture, (root_ / "out").string(), options);
  ASSERT_TRUE(summary.isOk()) << summary.status().toString();
  EXPECT_EQ(summary->masks_segmented, 4u);
  expectDatasetMatches(root_ / "out", 0.9);
}

// The studio, imported as a real rig comes (pictures and an empty-room
// plate, no masks): a checkerboard set down after the plate differs from
// the plate as the subject does, and one camera's segmented mask keeps it.
// The rig's agreement cuts it, as no other camera sees anything there
// inside the capture volume; the subject's masks stay, frame after frame.
TEST_F(ImportTest, TheRigCutsWhatOnlyOneCameraSees) {
  scene::SceneOptions options = scene::findScene("studio")->scene;
  ASSERT_TRUE(options.late_prop);
  const scene::SyntheticScene studio(options);
  const std::vector<uint64_t> frame_ids = {30, 31, 32};
  const fs::path src = root_ / "src";
  fs::create_directories(src / "images");
  fs::create_directories(src / "plates");
  nlohmann::json j = holofuseJson(".png", false);
  j["frames"] = nlohmann::json::array();
  std::vector<std::vector<Image8>> truth(cameras_.size());
  for (const uint64_t f : frame_ids) {
    nlohmann::json frame;
    for (size_t i = 0; i < cameras_.size(); ++i) {
      const auto view = studio.render(cameras_[i], f);
      truth[i].push_back(view.mask);
      const std::string file = "images/" + name(i) + "_" + std::to_string(f) + ".png";
      ASSERT_TRUE(cv::imwrite((src / file).string(), toMat(view.color)));
      frame["images"][name(i)] = file;
    }
    j["frames"].push_back(frame);
  }
  for (size_t i = 0; i < cameras_.size(); ++i) {
    ASSERT_TRUE(cv::imwrite((src / "plates" / (name(i) + ".png")).string(),
                            toMat(studio.backgroundPlate(cameras_[i]))));
    j["cameras"][i]["background"] = "plates/" + name(i) + ".png";
  }
  std::ofstream(src / "capture.json") << j.dump(2);
  auto capture = readCapture(src.string(), CaptureFormat::kHolofuse);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  // Each camera's worst mask over the frames, against the truth.
  auto worstIoU = [&](const fs::path& out) {
    std::vector<double> worst(cameras_.size(), 1.0);
    auto dataset = Dataset::open(out.string());
    EXPECT_TRUE(dataset.isOk());
    const size_t source_of[4] = {3, 0, 1, 2};  // pod id -> index in cameras_
    for (const auto& [id, cam] : dataset->cameras()) {
      auto calibration = dataset->readFrame(*cam.calibration);
      protocol::Calibration c;
      EXPECT_TRUE(protocol::decodeFrame(*calibration, c).isOk());
      EXPECT_EQ(cam.frames.size(), frame_ids.size());
      for (size_t f = 0; f < cam.frames.size(); ++f) {
        auto pod = dataset->readFrame(cam.frames[f]);
        auto images = decodePodImages(*pod, fromCalibration(c));
        EXPECT_TRUE(images.isOk());
        const size_t i = source_of[id];
        worst[i] = std::min(worst[i], maskIoU(images->mask, truth[i][f]));
      }
    }
    return worst;
  };
  ImportOptions alone;
  alone.rig_agreement = false;
  auto unagreed = importCapture(*capture, (root_ / "alone").string(), alone);
  ASSERT_TRUE(unagreed.isOk()) << unagreed.status().toString();
  auto agreed = importCapture(*capture, (root_ / "agreed").string(), {});
  ASSERT_TRUE(agreed.isOk()) << agreed.status().toString();
  const std::vector<double> before = worstIoU(root_ / "alone"), after = worstIoU(root_ / "agreed");
  size_t fooled = 0;
  for (size_t i = 0; i < cameras_.size(); ++i) {
    fooled += before[i] < 0.9;
    EXPECT_GE(after[i], 0.95) << "camera " << name(i) << " (alone " << before[i] << ")";
    const size_t pod = (i + 1) % 4;  // cameras_[i] is pod (i + 1) mod 4 (natural name order)
    EXPECT_EQ(agreed->agreement_pixels_cut[pod] > 0, before[i] < 0.9) << "camera " << name(i);
    EXPECT_EQ(unagreed->agreement_pixels_cut[pod], 0u);
  }
  EXPECT_GE(fooled, 1u) << "the board should fool a camera that sees it";
  const std::string text = agreementText(*agreed);
  EXPECT_NE(text.find("the other cameras' hull does not explain"), std::string::npos) << text;
}

// A plate video of the empty room under lights that flicker, with sensor
// noise, is learnt as a background model: the masks come out as the truth.
// A plate video too short to learn from, and a plate of the wrong size,
// are refused naming the camera; a camera whose picture is its plate (it
// sees only background) and one whose plate is another picture are
// imported with a warning naming them.
TEST_F(ImportTest, PlatesAreLearntAndTheirMistakesNamed) {
  const fs::path src = root_ / "src";
  writeImages(src / "images", ".png");
  fs::create_directories(src / "plates");
  cv::RNG rng(3);
  auto writePlateVideo = [&](size_t i, int frames) {
    const fs::path file = src / "plates" / (name(i) + ".mkv");
    cv::VideoWriter writer(file.string(), cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 15,
                           cv::Size(160, 120));
    ASSERT_TRUE(writer.isOpened());
    const cv::Mat plate = toMat(scene_.backgroundPlate(cameras_[i]));
    for (int f = 0; f < frames; ++f) {
      cv::Mat noise(plate.size(), CV_16SC3), frame;
      rng.fill(noise, cv::RNG::UNIFORM, cv::Scalar::all(-3), cv::Scalar::all(4));
      plate.convertTo(frame, CV_16SC3, 0.92 + 0.04 * f);  // the lights' gain
      frame += noise;
      frame.convertTo(frame, CV_8UC3);
      writer.write(frame);
    }
  };
  nlohmann::json j = holofuseJson(".png", false);
  for (size_t i = 0; i < cameras_.size(); ++i) {
    writePlateVideo(i, 5);
    j["cameras"][i]["background"] = "plates/" + name(i) + ".mkv";
  }
  std::ofstream(src / "capture.json") << j.dump(2);
  auto capture = readCapture(src.string(), CaptureFormat::kHolofuse);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  auto summary = importCapture(*capture, (root_ / "out").string(), {});
  ASSERT_TRUE(summary.isOk()) << summary.status().toString();
  EXPECT_EQ(summary->masks_segmented, 4u);
  EXPECT_TRUE(summary->warnings.empty()) << summary->warnings.front();
  expectDatasetMatches(root_ / "out", 0.95);
  fs::remove_all(root_ / "out");

  // Two frames are not enough to learn from.
  writePlateVideo(2, 2);
  auto refused = importCapture(*capture, (root_ / "out").string(), {});
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find(
                "the plate of camera \"cam11\" is a video of 2 frames; a plate video needs at "
                "least 3"),
            std::string::npos)
      << refused.status().message();
  EXPECT_FALSE(fs::exists(root_ / "out"));
  writePlateVideo(2, 5);
  // The capture's cameras are in natural name order, not the fixture's.
  auto cameraNamed = [&](const std::string& wanted) -> CaptureCamera& {
    for (CaptureCamera& c : capture->cameras)
      if (c.name == wanted) return c;
    ADD_FAILURE() << wanted;
    return capture->cameras.front();
  };
  // A still of another size.
  cv::imwrite((src / "plates" / "small.png").string(), cv::Mat(50, 60, CV_8UC3));
  cameraNamed("cam10").background = (src / "plates" / "small.png").string();
  refused = importCapture(*capture, (root_ / "out").string(), {});
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find(
                "the plate of camera \"cam10\": " + (src / "plates" / "small.png").string() +
                ": the plate is 60x50, the calibration of camera"),
            std::string::npos)
      << refused.status().message();
  // Camera cam10's plate is a red wall; cam2's picture is its own plate.
  cv::imwrite((src / "plates" / "red.png").string(),
              cv::Mat(120, 160, CV_8UC3, cv::Scalar(0, 0, 200)));
  cameraNamed("cam10").background = (src / "plates" / "red.png").string();
  cv::imwrite((src / "images" / "cam2.png").string(), toMat(scene_.backgroundPlate(cameras_[0])));
  summary = importCapture(*capture, (root_ / "out").string(), {});
  ASSERT_TRUE(summary.isOk()) << summary.status().toString();
  ASSERT_EQ(summary->warnings.size(), 2u);
  std::string warnings = summary->warnings[0] + "\n" + summary->warnings[1];
  EXPECT_NE(warnings.find("camera \"cam2\": its first frame's mask is empty"), std::string::npos)
      << warnings;
  EXPECT_NE(warnings.find("camera \"cam10\": 100% of its first frame differs from its plate"),
            std::string::npos)
      << warnings;
}

// Masks as they are stored: saved through a video or JPEG step they carry
// faint noise in the background and soft values in the subject, as 8-bit
// RGB or 16-bit grey. Each is binarised at half its range, so that no
// camera comes out as almost all foreground, and none is flagged.
TEST_F(ImportTest, NoisyAndSixteenBitMasksKeepTheirShape) {
  const fs::path src = root_ / "src";
  writeImages(src / "images", ".png");
  fs::create_directories(src / "masks");
  cv::RNG rng(7);
  for (size_t i = 0; i < cameras_.size(); ++i) {
    const cv::Mat truth = toMat(views_[i].mask);
    const fs::path file = src / "masks" / (name(i) + ".png");
    if (i == 2) {  // 16-bit grey: the subject at 60000 of 65535, the rest at 900
      cv::Mat deep(truth.size(), CV_16UC1, cv::Scalar(900));
      deep.setTo(cv::Scalar(60000), truth != 0);
      ASSERT_TRUE(cv::imwrite(file.string(), deep));
      continue;
    }
    cv::Mat noisy(truth.size(), CV_8UC3);
    rng.fill(noisy, cv::RNG::UNIFORM, cv::Scalar::all(0), cv::Scalar::all(40));
    cv::Mat subject(truth.size(), CV_8UC3);
    rng.fill(subject, cv::RNG::UNIFORM, cv::Scalar::all(200), cv::Scalar::all(256));
    subject.copyTo(noisy, truth != 0);
    ASSERT_TRUE(cv::imwrite(file.string(), noisy));
  }
  std::ofstream(src / "capture.json") << holofuseJson(".png", true).dump(2);
  auto capture = readCapture(src.string(), CaptureFormat::kHolofuse);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  auto summary = importCapture(*capture, (root_ / "out").string(), {});
  ASSERT_TRUE(summary.isOk()) << summary.status().toString();
  expectDatasetMatches(root_ / "out", 0.999);
  ASSERT_EQ(summary->health.size(), 4u);
  for (size_t c = 0; c < 4; ++c) {
    EXPECT_EQ(summary->health[c].concern, "") << summary->camera_names[c];
    EXPECT_GT(summary->health[c].agreement, 0.8) << summary->camera_names[c];
    EXPECT_LT(summary->health[c].coverage, 0.5) << summary->camera_names[c];
  }
}

// Pictures as cameras and tools store them, through OpenImageIO: 16-bit
// PNG and TIFF, linear float OpenEXR and JPEG colour; 1-bit PNG, 16-bit
// TIFF and float EXR masks. Each imports as its 8-bit self: colour within
// a grey level of the file's own decoded values (EXR's linear light
// encoded back to sRGB), and every mask exact.
TEST_F(ImportTest, PicturesOfAnyDepthAndFormatImportAsTheirEightBitSelves) {
  const fs::path src = root_ / "src";
  fs::create_directories(src / "images");
  fs::create_directories(src / "masks");
  const std::string image_ext[4] = {".png", ".tif", ".exr", ".jpg"};
  const std::string mask_ext[4] = {".png", ".tif", ".exr", ".png"};
  auto linear = [](uint8_t v) {  // sRGB's decoding (IEC 61966-2-1)
    const double e = v / 255.0;
    return static_cast<float>(e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4));
  };
  nlohmann::json j = holofuseJson(".png", true);
  for (size_t i = 0; i < cameras_.size(); ++i) {
    const Image8& color = views_[i].color;
    const Image8& mask = views_[i].mask;
    const fs::path image_file = src / "images" / (name(i) + image_ext[i]);
    const fs::path mask_file = src / "masks" / (name(i) + mask_ext[i]);
    j["frames"][0]["images"][name(i)] = "images/" + image_file.filename().string();
    j["frames"][0]["masks"][name(i)] = "masks/" + mask_file.filename().string();
    const cv::Mat eight = toMat(color);
    if (i == 0 || i == 1) {  // 16 bits a channel, written by OpenCV
      cv::Mat deep;
      eight.convertTo(deep, CV_16U, 257.0);
      ASSERT_TRUE(cv::imwrite(image_file.string(), deep));
    } else if (i == 2) {
      std::vector<float> values(color.pixels.size());
      for (size_t k = 0; k < values.size(); ++k) values[k] = linear(color.pixels[k]);
      ASSERT_TRUE(
          writeFloatImage(image_file.string(), color.width, color.height, {"R", "G", "B"}, values)
              .isOk());
    } else {
      ASSERT_TRUE(cv::imwrite(image_file.string(), eight, {cv::IMWRITE_JPEG_QUALITY, 97}));
    }
    const cv::Mat truth = toMat(mask);
    if (i == 0) {
      ASSERT_TRUE(cv::imwrite(mask_file.string(), truth, {cv::IMWRITE_PNG_BILEVEL, 1}));
    } else if (i == 1) {
      cv::Mat deep;
      truth.convertTo(deep, CV_16U, 257.0);
      ASSERT_TRUE(cv::imwrite(mask_file.string(), deep));
    } else if (i == 2) {
      std::vector<float> values(mask.pixels.size());
      for (size_t k = 0; k < values.size(); ++k) values[k] = mask.pixels[k] ? 0.8f : 0.02f;
      ASSERT_TRUE(
          writeFloatImage(mask_file.string(), mask.width, mask.height, {"Y"}, values).isOk());
    } else {
      ASSERT_TRUE(cv::imwrite(mask_file.string(), truth));
    }
  }
  std::ofstream(src / "capture.json") << j.dump(2);
  auto capture = readCapture(src.string(), CaptureFormat::kHolofuse);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  auto summary = importCapture(*capture, (root_ / "out").string(), {});
  ASSERT_TRUE(summary.isOk()) << summary.status().toString();
  expectDatasetMatches(root_ / "out", 0.999);
  auto dataset = Dataset::open((root_ / "out").string());
  ASSERT_TRUE(dataset.isOk());
  const size_t source_of[4] = {3, 0, 1, 2};  // pod id -> index in cameras_, as in the fixture
  for (const auto& [id, cam] : dataset->cameras()) {
    const size_t i = source_of[id];
    auto pod = dataset->readFrame(cam.frames[0]);
    ASSERT_TRUE(pod.isOk());
    auto images = decodePodImages(*pod, cameras_[i]);
    ASSERT_TRUE(images.isOk()) << images.status().toString();
    // JPEG's own loss is the file's: compare with what OpenCV decodes of it.
    Image8 expected = views_[i].color;
    if (image_ext[i] == ".jpg") {
      cv::Mat decoded = cv::imread((src / "images" / (name(i) + ".jpg")).string());
      cv::cvtColor(decoded, decoded, cv::COLOR_BGR2RGB);
      std::copy(decoded.datastart, decoded.dataend, expected.pixels.begin());
    }
    int largest = 0;
    size_t count = 0;
    for (size_t p = 0; p < images->mask.pixels.size(); ++p) {
      if (!images->mask.pixels[p] || !views_[i].mask.pixels[p]) continue;
      for (size_t c = 0; c < 3; ++c) {
        largest = std::max(largest,
                           std::abs(images->color.pixels[p * 3 + c] - expected.pixels[p * 3 + c]));
        ++count;
      }
    }
    ASSERT_GT(count, 0u) << image_ext[i];
    EXPECT_LE(largest, 1) << image_ext[i] << ": the import adds no loss of its own";
  }
}

// A camera whose mask is wrong is named, with why and what to do, in the
// import's summary and in `dataset info` (its tile marked); left out with
// --exclude-cameras, the rest import clean.
TEST_F(ImportTest, ACameraApartFromTheRestIsNamedAndCanBeLeftOut) {
  const fs::path src = root_ / "src";
  writeImages(src / "images", ".png");
  writeMasks(src / "masks", ".png", false);
  // cam10 (pod 2): a disc in a corner, which carves away what the others
  // see; cam11 (pod 3): all foreground, which carves nothing.
  cv::Mat disc = cv::Mat::zeros(static_cast<int>(cameras_[1].height),
                                static_cast<int>(cameras_[1].width), CV_8UC1);
  cv::circle(disc, cv::Point(12, 12), 8, cv::Scalar(255), cv::FILLED);
  ASSERT_TRUE(cv::imwrite((src / "masks" / "cam10.png").string(), disc));
  const cv::Mat full(disc.size(), CV_8UC1, cv::Scalar(255));
  ASSERT_TRUE(cv::imwrite((src / "masks" / "cam11.png").string(), full));
  std::ofstream(src / "capture.json") << holofuseJson(".png", true).dump(2);
  auto capture = readCapture(src.string(), CaptureFormat::kHolofuse);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  auto summary = importCapture(*capture, (root_ / "out").string(), {});
  ASSERT_TRUE(summary.isOk()) << summary.status().toString();
  ASSERT_EQ(summary->camera_names, (std::vector<std::string>{"cam1", "cam2", "cam10", "cam11"}));
  EXPECT_EQ(summary->health[0].concern, "");
  EXPECT_EQ(summary->health[1].concern, "");
  EXPECT_NE(summary->health[2].concern.find("carves away what the others see"), std::string::npos)
      << summary->health[2].concern;
  EXPECT_NE(summary->health[3].concern.find("covers 100% of the frame"), std::string::npos)
      << summary->health[3].concern;
  const std::string text =
      cameraHealthText(summary->camera_names, summary->health, "./holofuse dataset info out");
  EXPECT_NE(text.find("CHECK camera 2 \"cam10\""), std::string::npos) << text;
  EXPECT_NE(text.find("--exclude-cameras cam10"), std::string::npos) << text;
  EXPECT_EQ(text.find("CHECK camera 0"), std::string::npos) << text;

  auto info = describeDataset((root_ / "out").string(), (root_ / "sheet.png").string());
  ASSERT_TRUE(info.isOk()) << info.status().toString();
  EXPECT_NE(info->cameras[2].health.concern, "");
  EXPECT_NE(info->text.find("CHECK camera 3 \"cam11\""), std::string::npos) << info->text;
  EXPECT_TRUE(fs::exists(root_ / "sheet.png"));

  ImportOptions options;
  options.exclude_cameras = {"cam10", "cam11"};
  auto kept = importCapture(*capture, (root_ / "kept").string(), options);
  ASSERT_TRUE(kept.isOk()) << kept.status().toString();
  EXPECT_EQ(kept->cameras, 2u);
  EXPECT_EQ(kept->camera_names, (std::vector<std::string>{"cam1", "cam2"}));
  for (const CameraHealth& h : kept->health) EXPECT_EQ(h.concern, "");
  auto dataset = Dataset::open((root_ / "kept").string());
  ASSERT_TRUE(dataset.isOk());
  EXPECT_EQ(dataset->cameras().size(), 2u);

  options.exclude_cameras = {"cam99"};
  auto unknown = importCapture(*capture, (root_ / "unknown").string(), options);
  ASSERT_FALSE(unknown.isOk());
  EXPECT_NE(unknown.status().message().find("no camera named \"cam99\""), std::string::npos)
      << unknown.status().message();
  EXPECT_NE(unknown.status().message().find("cam10"), std::string::npos) << "lists those it has";
  EXPECT_FALSE(fs::exists(root_ / "unknown"));
}

// Over a video, `dataset info` measures each camera's mask against the
// others' hull frame by frame and names the frames where one camera falls
// apart from the rest (someone walked past it, a light came on), and the
// camera that disagrees all along.
TEST_F(ImportTest, DatasetInfoNamesTheFramesWhereACameraGoesWrong) {
  const fs::path src = root_ / "src";
  writeImages(src / "images", ".png");
  writeMasks(src / "masks", ".png", false);
  // cam10's masks in the fourth and fifth frames: a blob in the corner.
  cv::Mat blob = cv::Mat::zeros(static_cast<int>(cameras_[1].height),
                                static_cast<int>(cameras_[1].width), CV_8UC1);
  cv::circle(blob, cv::Point(20, 20), 14, cv::Scalar(255), cv::FILLED);
  ASSERT_TRUE(cv::imwrite((src / "masks" / "cam10_bad.png").string(), blob));
  nlohmann::json j = holofuseJson(".png", true);
  const nlohmann::json frame = j["frames"][0];
  j["frames"] = nlohmann::json::array();
  for (int f = 0; f < 8; ++f) {
    nlohmann::json copy = frame;
    if (f == 3 || f == 4) copy["masks"]["cam10"] = "masks/cam10_bad.png";
    j["frames"].push_back(copy);
  }
  std::ofstream(src / "capture.json") << j.dump(2);
  auto capture = readCapture(src.string(), CaptureFormat::kHolofuse);
  ASSERT_TRUE(capture.isOk()) << capture.status().toString();
  ASSERT_TRUE(importCapture(*capture, (root_ / "out").string(), {}).isOk());
  auto info = describeDataset((root_ / "out").string(), (root_ / "sheet.png").string(), 0, 0);
  ASSERT_TRUE(info.isOk()) << info.status().toString();
  const HealthOverTime& health = info->health_over_time;
  ASSERT_EQ(health.frame_ids.size(), 8u);
  ASSERT_EQ(health.cameras.size(), 4u);
  // Pods in natural name order: cam1, cam2, cam10, cam11; frame ids from 1.
  EXPECT_EQ(health.cameras[2].bad_frames, (std::vector<uint64_t>{4, 5}));
  EXPECT_LT(health.cameras[2].min, 0.3);
  EXPECT_GT(health.cameras[2].median, 0.7);
  // The others' hulls with cam10 in them are empty in those frames: the
  // others score 0 there too, but are not the ones set apart.
  for (size_t c : {0, 1, 3}) {
    EXPECT_EQ(health.cameras[c].concern, "") << "camera " << c;
    EXPECT_GT(health.cameras[c].median, 0.7) << "camera " << c;
  }
  EXPECT_NE(info->text.find("CHECK camera 2 \"cam10\": its mask is set apart"), std::string::npos)
      << info->text;
  EXPECT_NE(info->text.find("frames 4, 5"), std::string::npos) << info->text;
}

TEST_F(ImportTest, BadInputIsNamedAndLeavesNoDataset) {
  const fs::path src = root_ / "src";
  writeImages(src / "images", ".png");
  const fs::path out = root_ / "out";
  auto importFails = [&](CaptureFormat format, const std::string& expected) {
    auto capture = readCapture(src.string(), format);
    std::string message;
    if (!capture.isOk()) {
      message = capture.status().message();
    } else {
      auto summary = importCapture(*capture, out.string(), {});
      ASSERT_FALSE(summary.isOk()) << "expected: " << expected;
      message = summary.status().message();
    }
    EXPECT_NE(message.find(expected), std::string::npos) << message;
    EXPECT_FALSE(fs::exists(out)) << "a half dataset was left behind for: " << expected;
    for (const auto& entry : fs::directory_iterator(root_)) {
      EXPECT_EQ(entry.path().filename().string().find("out.partial"), std::string::npos)
          << entry.path();
    }
  };
  // A JSON syntax error: file, line and column.
  std::ofstream(src / "capture.json")
      << "{\n  \"format\": \"holofuse-capture\",\n  \"version\": 1,\n  oops\n}\n";
  importFails(CaptureFormat::kHolofuse, (src / "capture.json").string() + ":4:");
  // A newer format version.
  nlohmann::json j = holofuseJson(".png", false);
  j["version"] = 7;
  std::ofstream(src / "capture.json") << j.dump();
  importFails(CaptureFormat::kHolofuse,
              "capture format version 7 is newer than this holofuse reads (1)");
  // A frame that lists fewer cameras than "cameras".
  j = holofuseJson(".png", false);
  j["frames"].push_back(j["frames"][0]);
  j["frames"][1]["images"].erase("cam10");
  std::ofstream(src / "capture.json") << j.dump();
  importFails(CaptureFormat::kHolofuse, "frames[1].images: has 3 cameras, \"cameras\" has 4");
  // Not a rotation.
  j = holofuseJson(".png", false);
  j["cameras"][2]["R"][0][0] = 3.0;
  std::ofstream(src / "capture.json") << j.dump();
  importFails(CaptureFormat::kHolofuse, "cameras[2]: R is not a rotation");
  // A missing image, a corrupt one, one of the wrong size.
  j = holofuseJson(".png", false);
  std::ofstream(src / "capture.json") << j.dump();
  fs::rename(src / "images" / "cam11.png", src / "images" / "moved.png");
  importFails(CaptureFormat::kHolofuse, (src / "images" / "cam11.png").string() +
                                            ": image of camera \"cam11\" in frame 0 is missing");
  std::ofstream(src / "images" / "cam11.png") << "this is not a PNG";
  importFails(CaptureFormat::kHolofuse,
              (src / "images" / "cam11.png").string() + ": cannot decode the image");
  cv::imwrite((src / "images" / "cam11.png").string(),
              cv::Mat(50, 60, CV_8UC3, cv::Scalar(1, 2, 3)));
  importFails(CaptureFormat::kHolofuse, "cam11.png: the image is 60x50, the calibration of camera");
  // COLMAP: a line that does not parse, an unknown camera, an unknown model.
  fs::create_directories(src / "sparse");
  std::ofstream(src / "sparse" / "cameras.txt") << "# comment\n1 PINHOLE 160 120 100 100 80 60\n";
  std::ofstream(src / "sparse" / "images.txt") << "# comment\n\n1 1 0 0 0 0 0 x 1 a.png\n";
  importFails(CaptureFormat::kColmap,
              (src / "sparse" / "images.txt").string() + ":3: value 8 'x' is not a number");
  std::ofstream(src / "sparse" / "images.txt") << "1 1 0 0 0 0 0 1 9 a.png\n";
  importFails(CaptureFormat::kColmap,
              (src / "sparse" / "images.txt").string() + ":1: CAMERA_ID 9 is not in");
  std::ofstream(src / "sparse" / "cameras.txt") << "1 FISHEYE_X 160 120 100 100 80 60\n";
  importFails(CaptureFormat::kColmap, (src / "sparse" / "cameras.txt").string() +
                                          ":1: camera model FISHEYE_X is not supported");
  // A corrupt image in a later frame: found after writing has begun, and
  // still nothing is left behind.
  j = holofuseJson(".png", false);
  j["frames"].push_back(j["frames"][0]);
  j["frames"][1]["images"]["cam10"] = "images/broken.png";
  std::ofstream(src / "capture.json") << j.dump();
  fs::rename(src / "images" / "moved.png", src / "images" / "cam11.png");
  std::ofstream(src / "images" / "broken.png") << "not an image either";
  importFails(CaptureFormat::kHolofuse,
              (src / "images" / "broken.png").string() + ": cannot decode the image");
  // A trailing slash names the same folder; the dataset lands there whole.
  {
    auto capture = readCapture(src.string(), CaptureFormat::kHolofuse);
    ASSERT_TRUE(capture.isOk());
    capture->frames.pop_back();
    auto summary = importCapture(*capture, out.string() + "/", {});
    ASSERT_TRUE(summary.isOk()) << summary.status().toString();
    EXPECT_TRUE(fs::exists(out / "pods.hfr"));
    for (const auto& entry : fs::directory_iterator(out)) {
      EXPECT_EQ(entry.path().filename().string().find("partial"), std::string::npos)
          << entry.path();
    }
    fs::remove_all(out);
  }
  // An output folder that holds something already.
  fs::create_directories(out);
  std::ofstream(out / "keep.txt") << "mine";
  auto capture = readCapture(src.string(), CaptureFormat::kHolofuse);
  ASSERT_TRUE(capture.isOk());
  auto refused = importCapture(*capture, out.string(), {});
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find("exists and is not empty"), std::string::npos);
  EXPECT_TRUE(fs::exists(out / "keep.txt"));
}

}  // namespace
}  // namespace holofuse::dataset
