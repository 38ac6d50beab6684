// The client's picture writer: pictures written off the render path,
// whole or not at all, a full queue dropping pictures (counted) without
// holding up whoever submits, and everything queued written before it stops.
#include <gtest/gtest.h>

#include <filesystem>
#include <vector>

#include "image/image_io.h"
#include "integration/process_harness.h"
#include "render_client/picture_writer.h"

namespace holofuse::render {
namespace {

namespace fs = std::filesystem;

Image8 numbered(uint32_t side, uint8_t number) {
  Image8 picture(side, side, 3);
  for (size_t i = 0; i < picture.pixels.size(); ++i)
    picture.pixels[i] = static_cast<uint8_t>(i * 7 + number * 31);  // PNG cannot shrink it much
  return picture;
}

TEST(PictureWriter, AFullQueueDropsPicturesAndWhatWasQueuedIsWrittenWhole) {
  const fs::path dir = test::freshDir("picture_writer");
  constexpr int kSubmitted = 40;
  size_t accepted = 0;
  {
    // One picture queued at a time, each a 512x512 PNG (milliseconds to
    // encode), submitted back to back (moved in, microseconds apart): at
    // most the one being written and the one queued get through at first.
    std::vector<Image8> pictures;
    for (int i = 0; i < kSubmitted; ++i) pictures.push_back(numbered(512, static_cast<uint8_t>(i)));
    PictureWriter writer(1);
    for (int i = 0; i < kSubmitted; ++i) {
      const fs::path path = dir / ("frame_" + std::to_string(i) + ".png");
      accepted += writer.submit(std::move(pictures[i]), path);
    }
    writer.flush();
    EXPECT_EQ(writer.written(), accepted);
    EXPECT_EQ(writer.dropped(), kSubmitted - accepted);
    EXPECT_GE(writer.dropped(), 1u) << "a queue of one cannot hold forty pictures";
    EXPECT_EQ(writer.failed(), 0u);
    // Queued after the flush and not flushed: the destructor writes it.
    ASSERT_TRUE(writer.submit(numbered(64, 200), dir / "last.png"));
  }
  size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    EXPECT_EQ(name.find(".partial"), std::string::npos) << name << ": left half written";
    if (name == "last.png") continue;
    ++files;
    const int i = std::stoi(name.substr(6));
    const auto back = readImage(entry.path().string());
    ASSERT_TRUE(back.isOk()) << back.status().toString();
    EXPECT_EQ(back->pixels, numbered(512, static_cast<uint8_t>(i)).pixels) << name;
  }
  EXPECT_EQ(files, accepted);
  const auto last = readImage((dir / "last.png").string());
  ASSERT_TRUE(last.isOk()) << "written before the writer stopped: " << last.status().toString();
  EXPECT_EQ(last->pixels, numbered(64, 200).pixels);
  fs::remove_all(dir);
}

TEST(PictureWriter, AFailedWriteIsCountedAndTheNextIsWritten) {
  const fs::path dir = test::freshDir("picture_writer_fail");
  PictureWriter writer(4);
  ASSERT_TRUE(writer.submit(numbered(32, 1), dir / "missing" / "a.png"));
  ASSERT_TRUE(writer.submit(numbered(32, 2), dir / "b.png"));
  writer.flush();
  EXPECT_EQ(writer.failed(), 1u) << "no such folder";
  EXPECT_EQ(writer.written(), 1u);
  EXPECT_TRUE(fs::exists(dir / "b.png"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace holofuse::render
