// Foreground segmentation against a background model learned from a plate
// (the empty room, one still or the frames of a plate video), robust to
// what a real room does between the plate and the frame, and the feather
// map (distance to the silhouette border, paper 004).
#pragma once

#include <cstdint>
#include <vector>

#include "base/status.h"
#include "image/image.h"

namespace holofuse {

struct SegmentationOptions {
  // The sensor's noise, grey levels (one standard deviation), under every
  // threshold; a plate of several frames measures it per pixel instead,
  // never below this.
  double noise = 2.0;
  // How far a pixel's colour may leave the line from black through the
  // plate's colour (chromaticity distortion), as a share of its
  // brightness, and still be the background: a shadow or a change of
  // light moves a colour along that line, a subject off it.
  double chroma = 0.12;
  // Brightness against the plate after the frame's gain: darker than
  // shadow_darkest is too dark for a cast shadow; brighter than brighter
  // is more light than the room has. Between, on the line, background.
  double shadow_darkest = 0.3;
  double brighter = 1.25;
  // Estimate the frame's gain (lights that flicker, auto exposure) from
  // the pixels that are surely background, and undo it.
  bool follow_gain = true;
  // Temporal consistency, hysteresis over time: against the previous
  // frame's mask, a pixel keeps its side unless the evidence is clear. The
  // subject's pixels stay the subject above `hold` times the limit, the
  // background's become the subject only above the limit over `hold`, so
  // that pixels near the line do not flip from frame to frame with noise.
  double hold = 0.8;
  int cleanup_radius = 1;  // morphological open then close, square of 2r+1
};

// What one segmentation saw, for the pod's report and eval.
struct SegmentationStats {
  double gain = 1.0;           // the frame's brightness against the plate's
  uint64_t shadow_pixels = 0;  // darker than the plate on its colour line: background
  uint64_t foreground_pixels = 0;
};

// The background a camera sees: per pixel, the plate's mean colour and how
// much it varies. Segmenting a frame, a pixel is background when its
// colour lies on the line from black through the plate's colour (within
// the noise and `chroma`) and its brightness along that line, after the
// frame's gain, is between shadow_darkest and brighter (Horprasert,
// Harwood and Davis 1999: brightness and chromaticity distortion, which
// tells a cast shadow from a subject by its unchanged chromaticity).
class BackgroundModel {
 public:
  BackgroundModel() = default;
  // A still plate (RGB): its colour, and options.noise as its spread. A
  // still is a model, so call sites that hold a plate pass it as one.
  BackgroundModel(const Image8& plate, const SegmentationOptions& options = {});  // NOLINT
  // The frames of a plate video (RGB, one size): per-pixel mean and
  // standard deviation. An error names what is wrong with them (none, or
  // sizes that differ, or not RGB).
  static StatusOr<BackgroundModel> fromFrames(const std::vector<Image8>& frames,
                                              const SegmentationOptions& options = {});

  uint32_t width() const { return width_; }
  uint32_t height() const { return height_; }
  bool empty() const { return width_ == 0; }

  // Mask (255 foreground, 0 background) of an RGB frame of the model's
  // size (a contract: std::invalid_argument otherwise; untrusted frames
  // are checked by their readers). Opening removes isolated noise pixels,
  // closing fills pinholes. `previous`, the camera's mask of the frame
  // before (same size), holds its subject's pixels (options.hold).
  Image8 segment(const Image8& frame, SegmentationStats* stats = nullptr,
                 const Image8* previous = nullptr) const;

 private:
  uint32_t width_ = 0, height_ = 0;
  SegmentationOptions options_;
  std::vector<float> mean_;   // RGB per pixel
  std::vector<float> noise_;  // per pixel, grey levels
};

// Mask of frame against plate (both RGB, same size): BackgroundModel(plate,
// options).segment(frame).
Image8 segmentForeground(const Image8& frame, const Image8& plate,
                         const SegmentationOptions& options = {});

// Euclidean distance in pixels from each foreground pixel to the nearest
// background pixel, clamped to 255; 0 on the background. Blending uses it to
// fade a camera out towards its silhouette border.
Image8 featherMap(const Image8& mask);

}  // namespace holofuse
