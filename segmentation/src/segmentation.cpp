#include "segmentation/segmentation.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#include "image/opencv_image.h"

namespace holofuse {

namespace {

// A pixel's colour off the plate's line by noise alone: its two
// components across the line are normal with the noise's sigma, so the
// distance is Rayleigh, past 3.7 sigma once in a thousand pixels (the
// opening removes those).
constexpr float kNoiseSigmas = 3.7f;

// Plate colours darker than this (length of the RGB vector, grey levels)
// carry no usable chromaticity: there a pixel is judged by its distance
// alone.
constexpr float kDarkestLine = 24.0f;

// The frame's gain against a reference: the median of each pixel's
// brightness along the reference's colour (every 4th pixel, bright enough
// to have a colour). While the subject and its shadow cover less than half
// of the picture, that median is the background's: the lights' gain.
float medianGain(const uint8_t* frame, const std::vector<float>& reference, size_t pixels) {
  std::vector<float> ratios;
  ratios.reserve(pixels / 4 + 1);
  for (size_t p = 0; p < pixels; p += 4) {
    const float* m = &reference[3 * p];
    const float mm = m[0] * m[0] + m[1] * m[1] + m[2] * m[2];
    if (mm < kDarkestLine * kDarkestLine) continue;
    const uint8_t* c = frame + 3 * p;
    ratios.push_back((c[0] * m[0] + c[1] * m[1] + c[2] * m[2]) / mm);
  }
  if (ratios.empty()) return 1.0f;
  auto middle = ratios.begin() + static_cast<std::ptrdiff_t>(ratios.size() / 2);
  std::nth_element(ratios.begin(), middle, ratios.end());
  return *middle > 0 ? *middle : 1.0f;
}

}  // namespace

BackgroundModel::BackgroundModel(const Image8& plate, const SegmentationOptions& options)
    : width_(plate.width), height_(plate.height), options_(options) {
  mean_.assign(plate.pixels.begin(), plate.pixels.end());
  noise_.assign(static_cast<size_t>(width_) * height_, static_cast<float>(options.noise));
}

StatusOr<BackgroundModel> BackgroundModel::fromFrames(const std::vector<Image8>& frames,
                                                      const SegmentationOptions& options) {
  if (frames.empty()) return Status(StatusCode::kMalformed, "a plate needs at least one frame");
  const Image8& first = frames.front();
  for (size_t f = 0; f < frames.size(); ++f) {
    if (frames[f].channels != 3)
      return Status(StatusCode::kMalformed, "plate frame " + std::to_string(f) + " is not RGB (" +
                                                std::to_string(frames[f].channels) + " channels)");
    if (frames[f].width != first.width || frames[f].height != first.height)
      return Status(StatusCode::kMalformed,
                    "plate frame " + std::to_string(f) + " is " + std::to_string(frames[f].width) +
                        "x" + std::to_string(frames[f].height) + ", the first " +
                        std::to_string(first.width) + "x" + std::to_string(first.height));
  }
  BackgroundModel model(first, options);
  if (frames.size() == 1) return model;
  // Each frame brought to the first one's light (a plate video under
  // flickering lights), then the mean and spread per pixel.
  const size_t pixels = static_cast<size_t>(first.width) * first.height;
  const std::vector<float> reference(first.pixels.begin(), first.pixels.end());
  std::vector<double> sum(3 * pixels, 0.0), sum2(3 * pixels, 0.0);
  for (const Image8& frame : frames) {
    const float gain = medianGain(frame.pixels.data(), reference, pixels);
    for (size_t i = 0; i < 3 * pixels; ++i) {
      const double v = frame.pixels[i] / gain;
      sum[i] += v;
      sum2[i] += v * v;
    }
  }
  const double n = static_cast<double>(frames.size());
  for (size_t p = 0; p < pixels; ++p) {
    double variance = 0;
    for (int k = 0; k < 3; ++k) {
      const size_t i = 3 * p + static_cast<size_t>(k);
      const double mean = sum[i] / n;
      model.mean_[i] = static_cast<float>(mean);
      variance += std::max(0.0, sum2[i] / n - mean * mean) / 3.0;
    }
    model.noise_[p] = static_cast<float>(std::max(options.noise, std::sqrt(variance)));
  }
  return model;
}

Image8 BackgroundModel::segment(const Image8& frame, SegmentationStats* stats,
                                const Image8* previous) const {
  if (frame.width != width_ || frame.height != height_ || frame.channels != 3)
    throw std::invalid_argument("segment: a " + std::to_string(frame.width) + "x" +
                                std::to_string(frame.height) + " frame against a " +
                                std::to_string(width_) + "x" + std::to_string(height_) +
                                " background");
  if (previous != nullptr &&
      (previous->width != width_ || previous->height != height_ || previous->channels != 1))
    throw std::invalid_argument("segment: the previous mask is not the frame's size");
  const float hold = static_cast<float>(options_.hold);
  Image8 mask(frame.width, frame.height, 1);
  const size_t pixels = static_cast<size_t>(width_) * height_;
  const float gain = options_.follow_gain ? medianGain(frame.pixels.data(), mean_, pixels) : 1.0f;
  const float undo = 1.0f / gain;
  const float chroma = static_cast<float>(options_.chroma);
  const float darkest = static_cast<float>(options_.shadow_darkest);
  const float brighter = static_cast<float>(options_.brighter);
  uint64_t shadows = 0;
  for (size_t p = 0; p < pixels; ++p) {
    const float* m = &mean_[3 * p];
    const uint8_t* c = &frame.pixels[3 * p];
    const float i0 = c[0] * undo, i1 = c[1] * undo, i2 = c[2] * undo;
    // Hysteresis against the frame before: its side is kept unless clear.
    const float held = previous == nullptr ? 1.0f : previous->pixels[p] != 0 ? hold : 1.0f / hold;
    const float sigma = noise_[p];
    const float mm = m[0] * m[0] + m[1] * m[1] + m[2] * m[2];
    bool foreground;
    if (mm < kDarkestLine * kDarkestLine) {
      const float d0 = i0 - m[0], d1 = i1 - m[1], d2 = i2 - m[2];
      // 3 sigma a channel
      foreground = d0 * d0 + d1 * d1 + d2 * d2 > 27.0f * sigma * sigma * held * held;
    } else {
      const float alpha = (i0 * m[0] + i1 * m[1] + i2 * m[2]) / mm;
      const float e0 = i0 - alpha * m[0], e1 = i1 - alpha * m[1], e2 = i2 - alpha * m[2];
      const float off_line = std::sqrt(e0 * e0 + e1 * e1 + e2 * e2);
      const float line = std::sqrt(mm);
      const float limit = held * std::max(chroma * alpha * line, kNoiseSigmas * sigma);
      foreground = off_line > limit || alpha > brighter || alpha < darkest;
      if (!foreground && alpha < 1.0f - 3.0f * sigma / line) ++shadows;
    }
    mask.pixels[p] = foreground ? 255 : 0;
  }
  if (options_.cleanup_radius > 0) {
    const int k = 2 * options_.cleanup_radius + 1;
    const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k));
    cv::Mat out = wrap(mask);
    cv::morphologyEx(out, out, cv::MORPH_OPEN, kernel);
    cv::morphologyEx(out, out, cv::MORPH_CLOSE, kernel);
  }
  if (stats != nullptr) {
    stats->gain = gain;
    stats->shadow_pixels = shadows;
    stats->foreground_pixels =
        static_cast<uint64_t>(std::count(mask.pixels.begin(), mask.pixels.end(), uint8_t{255}));
  }
  return mask;
}

Image8 segmentForeground(const Image8& frame, const Image8& plate,
                         const SegmentationOptions& options) {
  return BackgroundModel(plate, options).segment(frame);
}

Image8 featherMap(const Image8& mask) {
  Image8 feather(mask.width, mask.height, 1);
  cv::Mat distance;
  cv::distanceTransform(wrapForReading(mask), distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  distance.convertTo(wrap(feather), CV_8U);  // saturates at 255
  return feather;
}

}  // namespace holofuse
