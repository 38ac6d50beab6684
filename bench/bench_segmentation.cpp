// The pods' segmenter against the library made for the job, OpenCV's
// background subtractors (MOG2 and KNN, shadow detection on), on the
// studio: a floor that takes the subject's shadow, lights that flicker 12%
// from frame to frame, a checkerboard set down after the plate. Each
// learns the empty room from the same plate video (the lights flickering,
// the sensor's noise), then classifies the same frames with its model
// frozen, as a pod does once the subject has walked in. Scored against the
// true masks: IoU per camera (mean, and the worst camera's worst frame),
// the share of the true shadow taken for the subject, and ms per frame;
// then ours with hysteresis over the frames and with the rig's agreement.
//   bench_segmentation [frames] [WxH]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/background_segm.hpp>
#include <string>
#include <vector>

#include "bench_timing.h"
#include "config/command_line.h"
#include "hull/mask_agreement.h"
#include "image/opencv_image.h"
#include "metrics/image_metrics.h"
#include "scene/scene_library.h"
#include "scene/synthetic_scene.h"
#include "segmentation/segmentation.h"

using namespace holofuse;
using bench::Clock;

namespace {

constexpr int kPlateFrames = 30;

// The empty room as a camera films it before the subject enters: the
// plate at each frame's light, with the sensor's noise.
std::vector<Image8> plateVideo(const scene::SyntheticScene& scene, const Camera& camera) {
  const Image8 plate = scene.backgroundPlate(camera);
  std::vector<Image8> frames;
  cv::RNG rng(camera.id + 11);
  const double noise = scene.options().noise_amplitude;
  for (int f = 0; f < kPlateFrames; ++f) {
    Image8 frame = plate;
    const double gain = scene.lightGain(1000 + static_cast<uint64_t>(f));
    for (uint8_t& v : frame.pixels) {
      const double value = v * gain + rng.uniform(-noise, noise);
      v = static_cast<uint8_t>(std::clamp(value + 0.5, 0.0, 255.0));
    }
    frames.push_back(std::move(frame));
  }
  return frames;
}

// A segmenter for one camera: learns the plate video, then masks frames
// in order (255 the subject).
struct Segmenter {
  std::string name;
  std::function<void(const std::vector<Image8>&)> learn;
  std::function<Image8(const Image8&)> segment;
};

// OpenCV's subtractor: trained on the plate video at its default rate,
// then frozen (learning rate 0); its shadows (127) count as background.
Segmenter opencvSubtractor(const std::string& name,
                           std::function<cv::Ptr<cv::BackgroundSubtractor>()> make) {
  auto subtractor = std::make_shared<cv::Ptr<cv::BackgroundSubtractor>>();
  return {name,
          [subtractor, make](const std::vector<Image8>& plate) {
            *subtractor = make();
            cv::Mat mask;
            for (const Image8& frame : plate) (*subtractor)->apply(wrapForReading(frame), mask);
          },
          [subtractor](const Image8& frame) {
            cv::Mat mask;
            (*subtractor)->apply(wrapForReading(frame), mask, 0.0);
            cv::threshold(mask, mask, 200, 255, cv::THRESH_BINARY);
            return fromMat(mask);
          }};
}

Segmenter ours(const std::string& name, bool hysteresis) {
  struct State {
    BackgroundModel model;
    Image8 previous;
  };
  auto state = std::make_shared<State>();
  return {name,
          [state](const std::vector<Image8>& plate) {
            state->model = *BackgroundModel::fromFrames(plate);
            state->previous = Image8();
          },
          [state, hysteresis](const Image8& frame) {
            Image8 mask = state->model.segment(
                frame, nullptr,
                hysteresis && !state->previous.empty() ? &state->previous : nullptr);
            state->previous = mask;
            return mask;
          }};
}

struct Score {
  std::vector<double> mean_iou;   // per camera, over its frames
  std::vector<double> worst_iou;  // per camera
  uint64_t shadow = 0, shadow_taken = 0;
  std::vector<double> ms;
};

void addFrame(Score& score, size_t camera, const Image8& mask, const scene::RenderedView& truth,
              size_t frames) {
  const double iou = metrics::maskIoU(mask, truth.mask);
  score.mean_iou[camera] += iou / static_cast<double>(frames);
  score.worst_iou[camera] = std::min(score.worst_iou[camera], iou);
  for (size_t p = 0; p < truth.shadow.pixels.size(); ++p) {
    if (!truth.shadow.pixels[p]) continue;
    ++score.shadow;
    score.shadow_taken += mask.pixels[p] != 0;
  }
}

void printRow(const std::string& name, const Score& s) {
  double mean = 0, worst = 1;
  for (size_t c = 0; c < s.mean_iou.size(); ++c) {
    mean += s.mean_iou[c] / static_cast<double>(s.mean_iou.size());
    worst = std::min(worst, s.worst_iou[c]);
  }
  const double taken =
      s.shadow ? 100.0 * static_cast<double>(s.shadow_taken) / static_cast<double>(s.shadow) : 0.0;
  char ms[32] = "-";
  if (!s.ms.empty()) std::snprintf(ms, sizeof(ms), "%.2f", bench::median(s.ms));
  std::printf("| %s | %.3f | %.3f | %.2f%% | %s |\n", name.c_str(), mean, worst, taken, ms);
}

}  // namespace

int main(int argc, char** argv) {
  const int frames = argc > 1 ? std::max(2, std::atoi(argv[1])) : 24;
  unsigned width = 320, height = 240;
  if (argc > 2) {
    if (const std::string error = parseImageSize(argv[2], width, height); !error.empty()) {
      std::fprintf(stderr, "size %s\n", error.c_str());
      return 2;
    }
  }
  const scene::ScenePreset* studio = scene::findScene("studio");
  const scene::SyntheticScene scene(studio->scene);
  const auto rig = scene::SyntheticScene::cameraRig(studio->cameras, width, height);
  std::vector<Segmenter> segmenters = {
      // Their shadows as deep as ours may be (SegmentationOptions::
      // shadow_darkest): the studio's shadow keeps 40% of the light.
      opencvSubtractor("OpenCV MOG2 (shadow detection, down to 0.3)",
                       [] {
                         auto mog2 = cv::createBackgroundSubtractorMOG2(500, 16, true);
                         mog2->setShadowThreshold(SegmentationOptions{}.shadow_darkest);
                         return mog2;
                       }),
      opencvSubtractor("OpenCV KNN (shadow detection, down to 0.3)",
                       [] {
                         auto knn = cv::createBackgroundSubtractorKNN(500, 400, true);
                         knn->setShadowThreshold(SegmentationOptions{}.shadow_darkest);
                         return knn;
                       }),
      ours("ours: brightness and chromaticity, gain undone", false),
      ours("ours, with hysteresis over the frames", true)};
  std::vector<Score> scores(segmenters.size() + 1);
  for (Score& s : scores) {
    s.mean_iou.assign(rig.size(), 0.0);
    s.worst_iou.assign(rig.size(), 1.0);
  }
  std::fprintf(stderr,
               "[bench_segmentation] %zu cameras at %ux%u, %d frames each, plate video of %d "
               "frames\n",
               rig.size(), width, height, frames, kPlateFrames);
  // The frames, rendered once; the masks of the last segmenter (ours with
  // hysteresis) kept per frame for the rig's agreement.
  std::vector<std::vector<scene::RenderedView>> truth(rig.size());
  std::vector<std::vector<hull::HullView>> held(static_cast<size_t>(frames));
  for (size_t c = 0; c < rig.size(); ++c) {
    const std::vector<Image8> plate = plateVideo(scene, rig[c]);
    for (int f = 0; f < frames; ++f) truth[c].push_back(scene.render(rig[c], 10 + f));
    for (size_t k = 0; k < segmenters.size(); ++k) {
      segmenters[k].learn(plate);
      for (int f = 0; f < frames; ++f) {
        const auto t0 = Clock::now();
        const Image8 mask = segmenters[k].segment(truth[c][f].color);
        scores[k].ms.push_back(bench::ms(t0, Clock::now()));
        addFrame(scores[k], c, mask, truth[c][f], static_cast<size_t>(frames));
        if (k + 1 == segmenters.size()) held[f].push_back({rig[c], mask, featherMap(mask)});
      }
    }
    std::fprintf(stderr, "\r[bench_segmentation] camera %zu/%zu", c + 1, rig.size());
  }
  std::fprintf(stderr, "\n");
  Score& agreed = scores.back();
  for (int f = 0; f < frames; ++f) {
    const auto cut = hull::agreeAcrossCameras(held[f], hull::HullOptions{});
    for (size_t c = 0; c < rig.size(); ++c)
      addFrame(agreed, c, cut[c].mask, truth[c][f], static_cast<size_t>(frames));
  }
  std::printf(
      "| segmenter | mask IoU mean | worst camera, worst frame | shadow taken for the subject | "
      "ms per frame (median) |\n|---|---:|---:|---:|---:|\n");
  for (size_t k = 0; k < segmenters.size(); ++k) printRow(segmenters[k].name, scores[k]);
  printRow("ours, with hysteresis, then the rig's agreement (import)", agreed);
  return 0;
}
