// Foreground segmentation by background subtraction against a known plate,
// and the feather map (distance to the silhouette border, paper 004).
#pragma once

#include "common/image.h"

namespace holofuse {

struct SegmentationOptions {
  // Sum of absolute channel differences to count as foreground. The
  // synthetic pods' sensor noise (+-2 per channel) sums to at most 6, while
  // the shaded back of the subject differs from the dark backdrop by as
  // little as 24: at 36, stripes of the back were cut out of the mask and
  // carved tunnels through the hull that the opposite camera saw through.
  int threshold = 15;
  int cleanup_radius = 1;  // morphological open then close, square of 2r+1
};

// Mask (255 foreground, 0 background) of frame against plate (both RGB,
// same size). Opening removes isolated noise pixels, closing fills pinholes.
Image8 segmentForeground(const Image8& frame, const Image8& plate,
                         const SegmentationOptions& options = {});

// Euclidean distance in pixels from each foreground pixel to the nearest
// background pixel, clamped to 255; 0 on the background. Blending uses it to
// fade a camera out towards its silhouette border.
Image8 featherMap(const Image8& mask);

}  // namespace holofuse
