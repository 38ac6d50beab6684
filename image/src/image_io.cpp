#include "image/image_io.h"

#include <OpenImageIO/color.h>
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>

namespace holofuse {

namespace {

// OpenImageIO keeps its last error per thread; take it, so that it does not
// leak into the next call's message.
std::string takeError(const OIIO::ImageInput* in) {
  std::string message = in && in->has_error() ? in->geterror() : OIIO::geterror();
  if (message.empty()) message = "not an image this build reads";
  while (!message.empty() && message.back() == '\n') message.pop_back();
  return message;
}

std::string takeError(const OIIO::ImageOutput* out) {
  std::string message = out && out->has_error() ? out->geterror() : OIIO::geterror();
  if (message.empty()) message = "the format refused the image";
  while (!message.empty() && message.back() == '\n') message.pop_back();
  return message;
}

bool isLinear(const OIIO::ImageSpec& spec) {
  const std::string space = spec.get_string_attribute("oiio:ColorSpace");
  return OIIO::Strutil::iequals(space, "linear") || OIIO::Strutil::iequals(space, "scene_linear") ||
         OIIO::Strutil::iequals(space, "lin_srgb");
}

// The colour channels (at most three, never alpha) from one colour space
// to another, by OpenImageIO's built-in transforms.
void convertColour(ImageValues& image, int alpha_channel, const char* from, const char* to) {
  static const OIIO::ColorConfig config;
  const auto processor = config.createColorProcessor(from, to);
  if (!processor) return;
  const int channels = static_cast<int>(image.channels);
  int colour = std::min(channels, 3);
  if (alpha_channel >= 0) colour = std::min(colour, alpha_channel);
  const auto stride = static_cast<OIIO::stride_t>(sizeof(float));
  for (int c = 0; c < colour; ++c) {
    processor->apply(image.values.data() + c, static_cast<int>(image.width),
                     static_cast<int>(image.height), 1, stride, stride * channels,
                     stride * channels * static_cast<OIIO::stride_t>(image.width));
  }
}

Status checkImage8(const std::string& path, const Image8& image) {
  if (image.empty() || (image.channels != 1 && image.channels != 3 && image.channels != 4) ||
      image.pixels.size() != static_cast<size_t>(image.width) * image.height * image.channels) {
    return {StatusCode::kMalformed,
            path + ": cannot write an image with " + std::to_string(image.channels) + " channels"};
  }
  return Status::ok();
}

Status writePixels(const std::string& path, const OIIO::ImageSpec& spec, OIIO::TypeDesc given,
                   const void* pixels) {
  auto out = OIIO::ImageOutput::create(path);
  if (!out) return {StatusCode::kIoError, path + ": " + takeError(out.get())};
  if (!out->open(path, spec) || !out->write_image(given, pixels) || !out->close())
    return {StatusCode::kIoError, path + ": " + takeError(out.get())};
  return Status::ok();
}

// An image is read from a regular file only: a name that leads to a device
// (/dev/zero), a FIFO or a folder would have a reader wait or fill memory
// for ever (a capture's calibration names its images; found by fuzzing).
Status regularFile(const std::string& path) {
  std::error_code error;
  const auto status = std::filesystem::status(path, error);
  if (error || !std::filesystem::exists(status))
    return Status(StatusCode::kIoError, path + ": no such file");
  if (!std::filesystem::is_regular_file(status))
    return Status(StatusCode::kIoError, path + ": not a regular file");
  return Status::ok();
}

}  // namespace

StatusOr<ImageValues> readImageValues(const std::string& path) {
  HOLOFUSE_RETURN_IF_ERROR(regularFile(path));
  // Alpha as stored: ours is coverage, or a mask beside straight colour,
  // never to be multiplied in by the reader.
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) return Status(StatusCode::kIoError, path + ": " + takeError(in.get()));
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || spec.depth != 1)
    return Status(StatusCode::kMalformed, path + ": not a two-dimensional image");
  ImageValues image;
  image.width = static_cast<uint32_t>(spec.width);
  image.height = static_cast<uint32_t>(spec.height);
  image.channels = static_cast<uint32_t>(spec.nchannels);
  image.format = in->format_name();
  image.bits = static_cast<uint32_t>(
      spec.get_int_attribute("oiio:BitsPerSample", static_cast<int>(spec.format.size() * 8)));
  image.values.resize(static_cast<size_t>(image.width) * image.height * image.channels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.values.data()))
    return Status(StatusCode::kMalformed, path + ": " + takeError(in.get()));
  if (isLinear(spec)) convertColour(image, spec.alpha_channel, "linear", "sRGB");
  for (float& v : image.values) v = std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f;
  return image;
}

StatusOr<std::pair<uint32_t, uint32_t>> readImageSize(const std::string& path) {
  HOLOFUSE_RETURN_IF_ERROR(regularFile(path));
  auto in = OIIO::ImageInput::open(path);
  if (!in) return Status(StatusCode::kIoError, path + ": " + takeError(in.get()));
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0)
    return Status(StatusCode::kMalformed, path + ": not a two-dimensional image");
  return std::make_pair(static_cast<uint32_t>(spec.width), static_cast<uint32_t>(spec.height));
}

StatusOr<Image8> readImage(const std::string& path) {
  auto values = readImageValues(path);
  if (!values.isOk()) return values.status();
  Image8 image(values->width, values->height, values->channels);
  for (size_t i = 0; i < image.pixels.size(); ++i)
    image.pixels[i] = static_cast<uint8_t>(std::lround(values->values[i] * 255.0f));
  return image;
}

Status writeImage(const std::string& path, const Image8& image) {
  HOLOFUSE_RETURN_IF_ERROR(checkImage8(path, image));
  OIIO::ImageSpec spec(static_cast<int>(image.width), static_cast<int>(image.height),
                       static_cast<int>(image.channels), OIIO::TypeDesc::UINT8);
  if (image.channels == 4) {
    spec.alpha_channel = 3;
    spec.attribute("oiio:UnassociatedAlpha", 1);  // straight colour, as read
  }
  std::string extension = OIIO::Filesystem::extension(path, false);
  OIIO::Strutil::to_lower(extension);
  if (extension == "exr") {
    // EXR holds linear light (what readImageValues undoes): decode sRGB.
    ImageValues linear{image.width, image.height, image.channels, {}, "openexr", 16};
    linear.values.resize(image.pixels.size());
    for (size_t i = 0; i < image.pixels.size(); ++i) linear.values[i] = image.pixels[i] / 255.0f;
    convertColour(linear, image.channels == 4 ? 3 : -1, "sRGB", "linear");
    spec.set_format(OIIO::TypeDesc::HALF);
    spec.attribute("Compression", "zip");
    return writePixels(path, spec, OIIO::TypeDesc::FLOAT, linear.values.data());
  }
  if (extension == "png") spec.attribute("png:compressionLevel", 1);  // per frame: speed first
  if (extension == "jpg" || extension == "jpeg") spec.attribute("Compression", "jpeg:95");
  if (extension == "tif" || extension == "tiff") spec.attribute("Compression", "zip");
  return writePixels(path, spec, OIIO::TypeDesc::UINT8, image.pixels.data());
}

StatusOr<std::vector<uint8_t>> encodePng(const Image8& image) {
  HOLOFUSE_RETURN_IF_ERROR(checkImage8("png in memory", image));
  OIIO::ImageSpec spec(static_cast<int>(image.width), static_cast<int>(image.height),
                       static_cast<int>(image.channels), OIIO::TypeDesc::UINT8);
  if (image.channels == 4) {
    spec.alpha_channel = 3;
    spec.attribute("oiio:UnassociatedAlpha", 1);
  }
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput memory(bytes);
  const std::string name = "memory.png";  // names the format; nothing is written there
  auto out = OIIO::ImageOutput::create(name, &memory);
  if (!out) return Status(StatusCode::kIoError, "png in memory: " + takeError(out.get()));
  if (!out->open(name, spec) || !out->write_image(OIIO::TypeDesc::UINT8, image.pixels.data()) ||
      !out->close())
    return Status(StatusCode::kIoError, "png in memory: " + takeError(out.get()));
  return std::vector<uint8_t>(bytes.begin(), bytes.end());
}

Status writeFloatImage(const std::string& path, uint32_t width, uint32_t height,
                       const std::vector<std::string>& channel_names,
                       const std::vector<float>& values) {
  if (width == 0 || height == 0 || channel_names.empty() ||
      values.size() != static_cast<size_t>(width) * height * channel_names.size()) {
    return {StatusCode::kMalformed, path + ": " + std::to_string(values.size()) +
                                        " values do not make a " + std::to_string(width) + "x" +
                                        std::to_string(height) + " image of " +
                                        std::to_string(channel_names.size()) + " channels"};
  }
  OIIO::ImageSpec spec(static_cast<int>(width), static_cast<int>(height),
                       static_cast<int>(channel_names.size()), OIIO::TypeDesc::FLOAT);
  spec.channelnames = channel_names;
  spec.alpha_channel = -1;  // an "A" channel of data is not coverage
  spec.attribute("Compression", "zip");
  return writePixels(path, spec, OIIO::TypeDesc::FLOAT, values.data());
}

}  // namespace holofuse
