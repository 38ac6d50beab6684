// The viewer's live panel: its figures from the client's frame records,
// and its drawing over the picture the window shows.
#include <gtest/gtest.h>

#include <vector>

#include "protocol/messages.h"
#include "render_client/live_panel.h"

namespace holofuse::render {
namespace {

using protocol::Stage;

// A frame written at `written_ms`, `bytes` from the server, 100 ms end to
// end: the hull 0-40 ms after capture, the render 50-90, waiting between.
report::FrameRecord frameAt(double written_ms, uint64_t bytes) {
  report::FrameRecord f;
  f.capture_time_ns = 1'000'000'000;
  f.written_local_ns = static_cast<uint64_t>(written_ms * 1e6);
  f.end_to_end_ms = 100;
  f.client_bytes = bytes;
  f.timeline = {{static_cast<uint16_t>(Stage::kHull), 0, 1'000'000'000, 1'040'000'000},
                {static_cast<uint16_t>(Stage::kRender), 0, 1'050'000'000, 1'090'000'000}};
  return f;
}

TEST(LivePanel, FiguresCoverTheLastFramesOnly) {
  std::vector<report::FrameRecord> frames;
  // Ten slow frames, then 31 at 20 fps of 125,000 bytes (20 Mbit/s).
  for (int k = 0; k < 10; ++k) frames.push_back(frameAt(1000.0 * k, 1'000'000));
  for (int k = 0; k < 31; ++k) frames.push_back(frameAt(20000 + 50.0 * k, 125'000));
  frames.back().end_to_end_ms = 120;
  frames.back().timeline[1].end_ns = 1'110'000'000;  // the render took 60 ms
  const PanelFigures f = panelFigures(frames, 30, "montage4d");
  EXPECT_EQ(f.title, "montage4d");
  EXPECT_EQ(f.frames, 30u);
  EXPECT_NEAR(f.fps, 20.0, 1e-9);
  EXPECT_NEAR(f.link_mbit_s, 20.0, 1e-9);
  EXPECT_EQ(f.end_to_end_ms, 120);
  EXPECT_EQ(f.end_to_end_p50_ms, 100);
  // The latest frame's stages in pipeline order, "waiting" last; they
  // add up to its end to end.
  ASSERT_EQ(f.stages.size(), 3u);
  EXPECT_EQ(f.stages[0].name, "hull");
  EXPECT_DOUBLE_EQ(f.stages[0].ms, 40);
  EXPECT_EQ(f.stages[1].name, "render");
  EXPECT_DOUBLE_EQ(f.stages[1].ms, 60);
  EXPECT_EQ(f.stages[2].name, "waiting");
  EXPECT_DOUBLE_EQ(f.stages[2].ms, 20);
  EXPECT_NE(f.stages[0].slot, f.stages[1].slot) << "a colour per stage";
}

TEST(LivePanel, DrawsInTheTopLeftCornerAndNothingWithoutFrames) {
  Image8 picture(320, 240, 4);
  std::fill(picture.pixels.begin(), picture.pixels.end(), 200);
  const Image8 before = picture;
  drawPanel(picture, panelFigures({}, 30, "normal"));
  EXPECT_TRUE(picture.pixels == before.pixels) << "no frames, no panel";

  std::vector<report::FrameRecord> frames;
  for (int k = 0; k < 5; ++k) frames.push_back(frameAt(50.0 * k, 125'000));
  drawPanel(picture, panelFigures(frames, 30, "normal"));
  size_t changed_top = 0, changed_bottom = 0;
  for (size_t y = 0; y < picture.height; ++y) {
    for (size_t x = 0; x < picture.width; ++x) {
      const size_t at = 4 * (y * picture.width + x);
      const bool changed = picture.pixels[at] != 200 || picture.pixels[at + 1] != 200;
      (y < picture.height / 2 ? changed_top : changed_bottom) += changed;
    }
  }
  EXPECT_GT(changed_top, 5000u) << "the panel's box, text and bar";
  EXPECT_EQ(changed_bottom, 0u) << "the subject below stays in view";
}

// A new mode fades in: from the old picture at 0 to the new one at 1.
TEST(ModeFade, MixesFromTheOldPictureToTheNew) {
  Image8 from(4, 2, 4), to(4, 2, 4);
  std::fill(from.pixels.begin(), from.pixels.end(), 0);
  std::fill(to.pixels.begin(), to.pixels.end(), 200);
  EXPECT_TRUE(crossFade(from, to, 0.0).pixels == from.pixels);
  EXPECT_TRUE(crossFade(from, to, 1.0).pixels == to.pixels);
  EXPECT_TRUE(crossFade(from, to, 7.0).pixels == to.pixels) << "past the fade: the new picture";
  const Image8 half = crossFade(from, to, 0.25);
  for (uint8_t v : half.pixels) EXPECT_EQ(v, 50);
  // No picture before (the first mode switch), or another size: no fade.
  EXPECT_TRUE(crossFade(Image8{}, to, 0.5).pixels == to.pixels);
  EXPECT_TRUE(crossFade(Image8(2, 2, 4), to, 0.5).pixels == to.pixels);
}

}  // namespace
}  // namespace holofuse::render
