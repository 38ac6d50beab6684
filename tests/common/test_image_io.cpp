// PNG output: what other tools read back, and the caller's image untouched.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "common/image_io.h"

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
TEST(WritePng, LeavesTheImageAndWritesItsChannelsInOrder) {
  const fs::path dir = fs::temp_directory_path() / ("holofuse_png_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (uint32_t channels : {1u, 3u, 4u}) {
    const Image8 original = gradient(channels);
    Image8 image = original;
    const std::string path = (dir / ("image" + std::to_string(channels) + ".png")).string();
    ASSERT_TRUE(writePng(path, image).isOk());
    EXPECT_EQ(image.pixels, original.pixels) << channels << " channels, after one write";
    ASSERT_TRUE(writePng(path, image).isOk());
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
  EXPECT_FALSE(writePng((dir / "missing" / "x.png").string(), gradient(3)).isOk());
  fs::remove_all(dir);
}

// The live judge reads the client's frames back: every channel count comes
// back as it was written, and a file that is not a picture is named.
TEST(ReadPng, ReturnsWhatWritePngWroteAndNamesABadFile) {
  const fs::path dir = fs::temp_directory_path() / ("holofuse_png_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (uint32_t channels : {1u, 3u, 4u}) {
    const Image8 original = gradient(channels);
    const std::string path = (dir / ("image" + std::to_string(channels) + ".png")).string();
    ASSERT_TRUE(writePng(path, original).isOk());
    const auto read = readPng(path);
    ASSERT_TRUE(read.isOk()) << read.status().message();
    EXPECT_EQ(read->channels, channels);
    EXPECT_EQ(read->width, original.width);
    EXPECT_EQ(read->height, original.height);
    EXPECT_EQ(read->pixels, original.pixels) << channels << " channels";
  }
  const fs::path garbage = dir / "garbage.png";
  { std::ofstream(garbage) << "not a picture"; }
  const auto bad = readPng(garbage.string());
  ASSERT_FALSE(bad.isOk());
  EXPECT_NE(bad.status().message().find(garbage.string()), std::string::npos)
      << bad.status().message();
  EXPECT_FALSE(readPng((dir / "missing.png").string()).isOk());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace holofuse
