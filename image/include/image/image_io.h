// Image files through OpenImageIO: every picture the import reads and
// every picture eval, the dataset tools and the client write. The format
// follows the file name's extension (PNG, JPEG, TIFF, OpenEXR and whatever
// else the installed OpenImageIO reads).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "base/status.h"
#include "image/image.h"

namespace holofuse {

// An image file's pixels as display values in [0, 1], channels interleaved
// in the file's order (R, G, B, A; or grey), whatever the stored depth:
// 1, 8 or 16 bits, half or float. A file that says its colour is linear
// (OpenEXR's convention) is encoded to sRGB first, so values compare with
// an 8-bit PNG's; alpha is left as stored. Values outside [0, 1] (an HDR
// highlight) and non-finite values are clamped and zeroed.
struct ImageValues {
  uint32_t width = 0, height = 0, channels = 0;
  std::vector<float> values;  // width * height * channels
  std::string format;         // what the file is: "png", "openexr", "tiff", "jpeg", ...
  uint32_t bits = 0;          // bits per stored channel
};
StatusOr<ImageValues> readImageValues(const std::string& path);

// Width and height from the file's header, without decoding its pixels.
StatusOr<std::pair<uint32_t, uint32_t>> readImageSize(const std::string& path);

// An image file as 8-bit (rounded from readImageValues), channels as stored.
// An error names the path and what is wrong with the file.
StatusOr<Image8> readImage(const std::string& path);

// Writes grey, RGB or RGBA in the format the extension names (PNG
// compressed for speed, JPEG at quality 95, 8-bit TIFF; OpenEXR as half
// linear half floats, as EXR readers expect). Fails with a message naming the path when the file
// cannot be written. Leaves image untouched.
Status writeImage(const std::string& path, const Image8& image);

// The image as PNG bytes (a file's worth, in memory): what a glTF binary
// embeds.
StatusOr<std::vector<uint8_t>> encodePng(const Image8& image);

// Float data (not colour: errors, weights, depths) as 32-bit floats with
// one named channel per value of a pixel, in a format that keeps them
// (OpenEXR, TIFF). values holds width * height * channel_names.size().
Status writeFloatImage(const std::string& path, uint32_t width, uint32_t height,
                       const std::vector<std::string>& channel_names,
                       const std::vector<float>& values);

}  // namespace holofuse
