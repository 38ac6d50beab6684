// Image files through OpenImageIO: what other tools read back, every
// format the extension names, float data kept as written, and the
// caller's image untouched.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "image/image_io.h"

namespace holofuse {
namespace {

namespace fs = std::filesystem;

Image8 gradient(uint32_t channels) {
  Image8 image(7, 5, channels);
  for (uint32_t y = 0; y < image.height; ++y) {
    for (uint32_t x = 0; x < image.width; ++x) {
      for (uint32_t c = 0; c < channels; ++c)
        image.at(x, y)[c] = static_cast<uint8_t>(40 * c + 9 * x + y);
    }
  }
  return image;
}

// Saving the same image twice must not change it: the eval writes the true
// image once per mode and compares the next mode against it.
TEST(WriteImage, LeavesTheImageAndWritesItsChannelsInOrder) {
  const fs::path dir = fs::temp_directory_path() / ("holofuse_png_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (uint32_t channels : {1u, 3u, 4u}) {
    const Image8 original = gradient(channels);
    Image8 image = original;
    const std::string path = (dir / ("image" + std::to_string(channels) + ".png")).string();
    ASSERT_TRUE(writeImage(path, image).isOk());
    EXPECT_EQ(image.pixels, original.pixels) << channels << " channels, after one write";
    ASSERT_TRUE(writeImage(path, image).isOk());
    EXPECT_EQ(image.pixels, original.pixels) << channels << " channels, after two";
    const cv::Mat read = cv::imread(path, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(read.channels(), static_cast<int>(channels));
    ASSERT_EQ(read.cols, 7);
    ASSERT_EQ(read.rows, 5);
    // OpenCV reads blue first: channel c of ours is channel (2 - c) of its.
    for (uint32_t c = 0; c < channels; ++c) {
      const uint32_t theirs = (channels >= 3 && c < 3) ? 2 - c : c;
      EXPECT_EQ(read.ptr<uint8_t>(3)[4 * channels + theirs], original.at(4, 3)[c])
          << channels << " channels, " << c;
    }
  }
  EXPECT_FALSE(writeImage((dir / "missing" / "x.png").string(), gradient(3)).isOk());
  fs::remove_all(dir);
}

// The live judge reads the client's frames back: every channel count comes
// back as it was written, and a file that is not a picture is named.
TEST(ReadImage, ReturnsWhatWriteImageWroteAndNamesABadFile) {
  const fs::path dir = fs::temp_directory_path() / ("holofuse_png_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (uint32_t channels : {1u, 3u, 4u}) {
    const Image8 original = gradient(channels);
    const std::string path = (dir / ("image" + std::to_string(channels) + ".png")).string();
    ASSERT_TRUE(writeImage(path, original).isOk());
    const auto read = readImage(path);
    ASSERT_TRUE(read.isOk()) << read.status().message();
    EXPECT_EQ(read->channels, channels);
    EXPECT_EQ(read->width, original.width);
    EXPECT_EQ(read->height, original.height);
    EXPECT_EQ(read->pixels, original.pixels) << channels << " channels";
  }
  const fs::path garbage = dir / "garbage.png";
  { std::ofstream(garbage) << "not a picture"; }
  const auto bad = readImage(garbage.string());
  ASSERT_FALSE(bad.isOk());
  EXPECT_NE(bad.status().message().find(garbage.string()), std::string::npos)
      << bad.status().message();
  EXPECT_FALSE(readImage((dir / "missing.png").string()).isOk());
  fs::remove_all(dir);
}

// The extension picks the format: TIFF and OpenEXR come back exact (EXR's
// half floats hold every 8-bit level), JPEG within its loss; and OpenCV,
// another reader, agrees on the TIFF.
TEST(WriteImage, EveryFormatTheExtensionNamesComesBack) {
  const fs::path dir =
      fs::temp_directory_path() / ("holofuse_formats_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const Image8 original = gradient(3);
  for (const std::string ext : {".png", ".tif", ".exr", ".jpg"}) {
    const std::string path = (dir / ("image" + ext)).string();
    ASSERT_TRUE(writeImage(path, original).isOk()) << ext;
    const auto read = readImage(path);
    ASSERT_TRUE(read.isOk()) << read.status().message();
    ASSERT_EQ(read->pixels.size(), original.pixels.size()) << ext;
    int largest = 0;
    for (size_t i = 0; i < original.pixels.size(); ++i)
      largest = std::max(largest, std::abs(read->pixels[i] - original.pixels[i]));
    EXPECT_LE(largest, ext == ".jpg" ? 12 : 0) << ext;
  }
  const cv::Mat tiff = cv::imread((dir / "image.tif").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(tiff.channels(), 3);
  EXPECT_EQ(tiff.ptr<uint8_t>(3)[4 * 3 + 2], original.at(4, 3)[0]) << "red, OpenCV blue-first";
  const auto unknown = writeImage((dir / "image.nosuchformat").string(), original);
  ASSERT_FALSE(unknown.isOk());
  EXPECT_NE(unknown.message().find("image.nosuchformat"), std::string::npos) << unknown.message();
  fs::remove_all(dir);
}

// Float data keeps its values (negative, above one) and its channel names,
// as another program opening the EXR sees them; a size that does not add
// up is refused by name.
TEST(WriteFloatImage, KeepsValuesAndChannelNames) {
  const fs::path dir = fs::temp_directory_path() / ("holofuse_float_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "weights.exr").string();
  std::vector<float> values(4 * 3 * 2);
  for (size_t i = 0; i < values.size(); ++i) values[i] = -1.5f + 0.37f * static_cast<float>(i);
  ASSERT_TRUE(writeFloatImage(path, 4, 3, {"camera0", "camera7"}, values).isOk());
  auto in = OIIO::ImageInput::open(path);
  ASSERT_TRUE(in);
  const OIIO::ImageSpec& spec = in->spec();
  EXPECT_EQ(spec.width, 4);
  EXPECT_EQ(spec.height, 3);
  EXPECT_EQ(spec.channelnames, (std::vector<std::string>{"camera0", "camera7"}));
  EXPECT_EQ(spec.format, OIIO::TypeDesc::FLOAT);
  std::vector<float> read(values.size());
  ASSERT_TRUE(in->read_image(0, 0, 0, 2, OIIO::TypeDesc::FLOAT, read.data()));
  EXPECT_EQ(read, values);
  const auto wrong = writeFloatImage(path, 4, 3, {"a", "b", "c"}, values);
  ASSERT_FALSE(wrong.isOk());
  EXPECT_NE(wrong.message().find("weights.exr"), std::string::npos) << wrong.message();
  fs::remove_all(dir);
}

TEST(ImageRects, ForegroundRectCropAndPlaceRoundTrip) {
  Image8 mask(40, 30, 1, 0);
  for (uint32_t y = 10; y < 14; ++y) {
    for (uint32_t x = 20; x < 25; ++x) *mask.at(x, y) = 255;
  }
  const PixelRect tight = foregroundRect(mask);
  EXPECT_EQ(tight.x, 20u);
  EXPECT_EQ(tight.y, 10u);
  EXPECT_EQ(tight.width, 5u);
  EXPECT_EQ(tight.height, 4u);
  const PixelRect grown = foregroundRect(mask, 30);  // clipped to the image
  EXPECT_EQ(grown.x, 0u);
  EXPECT_EQ(grown.width, 40u);
  EXPECT_EQ(grown.height, 30u);
  EXPECT_TRUE(foregroundRect(Image8(8, 8, 1, 0)).empty());
  Image8 colour(40, 30, 3);
  for (size_t i = 0; i < colour.pixels.size(); ++i) colour.pixels[i] = static_cast<uint8_t>(i * 7);
  const PixelRect r = foregroundRect(mask, 2);
  const Image8 back = placeInFrame(cropImage(colour, r), r.x, r.y, 40, 30);
  for (uint32_t y = 0; y < 30; ++y) {
    for (uint32_t x = 0; x < 40; ++x) {
      const bool in = x >= r.x && x < r.x + r.width && y >= r.y && y < r.y + r.height;
      for (int c = 0; c < 3; ++c)
        ASSERT_EQ(back.at(x, y)[c], in ? colour.at(x, y)[c] : 0) << x << "," << y;
    }
  }
  EXPECT_THROW(cropImage(colour, {38, 0, 5, 5}), std::invalid_argument);
  EXPECT_FALSE(cropFits(0xFFFFFFF0u, 0, 96, 72, 96, 72)) << "no 32-bit wrap-around";
  EXPECT_TRUE(cropFits(16, 8, 80, 64, 96, 72));
}

}  // namespace
}  // namespace holofuse
