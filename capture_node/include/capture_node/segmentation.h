// Foreground segmentation by background subtraction against a known plate,
// and the feather map (distance to the silhouette border, paper 004).
#pragma once

#include "common/image.h"

namespace holofuse::capture {

struct SegmentationOptions {
  int threshold = 36;        // sum of absolute channel differences to count as foreground
  int cleanup_radius = 1;    // morphological open then close, square of 2r+1
};

// Mask (255 foreground, 0 background) of frame against plate (both RGB,
// same size). Opening removes isolated noise pixels, closing fills pinholes.
Image8 segmentForeground(const Image8& frame, const Image8& plate, const SegmentationOptions& options = {});

// Euclidean distance in pixels from each foreground pixel to the nearest
// background pixel, clamped to 255; 0 on the background. Blending uses it to
// fade a camera out towards its silhouette border.
Image8 featherMap(const Image8& mask);

}  // namespace holofuse::capture
