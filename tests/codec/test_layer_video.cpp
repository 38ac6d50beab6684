// Texture layers as video (codec/layer_video.h): a stream's frames come
// back close to what went in, frames after the first cost less when the
// picture stays put, and a receiver that missed a frame says so by name
// and recovers at the next key frame.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "base/process.h"
#include "codec/layer_video.h"
#include "codec/layer_video_file.h"

namespace holofuse {
namespace {

// An atlas-like picture: smooth patches of colour with detail, shifted by
// `shift` texels (the surface moving a little between frames).
Image8 patches(uint32_t width, uint32_t height, int shift) {
  Image8 image(width, height, 3);
  for (uint32_t y = 0; y < height; ++y) {
    for (uint32_t x = 0; x < width; ++x) {
      const double u = static_cast<double>(static_cast<int>(x) + shift), v = y;
      uint8_t* p = image.at(x, y);
      const int patch = static_cast<int>(u / 24) + 7 * static_cast<int>(v / 24);
      p[0] = static_cast<uint8_t>(80 + 60 * std::sin(u * 0.11) + (patch * 37) % 50);
      p[1] = static_cast<uint8_t>(120 + 50 * std::cos(v * 0.07 + u * 0.03));
      p[2] = static_cast<uint8_t>(60 + (patch * 53) % 120);
    }
  }
  return image;
}

double psnr(const Image8& a, const Image8& b) {
  double sum = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    const double d = static_cast<double>(a.pixels[i]) - b.pixels[i];
    sum += d * d;
  }
  const double mse = sum / static_cast<double>(a.pixels.size());
  return mse == 0 ? 99.0 : 10.0 * std::log10(255.0 * 255.0 / mse);
}

class LayerVideo : public ::testing::TestWithParam<protocol::Codec> {};

TEST_P(LayerVideo, FramesComeBackCloseAndStillPicturesCostLessAfterTheKeyFrame) {
  LayerVideoOptions options;
  options.codec = GetParam();
  LayerVideoEncoder encoder(options);
  LayerVideoDecoder decoder;
  // 200 is not a multiple of 16: the coded picture is larger, the plane not.
  constexpr uint32_t kWidth = 200, kHeight = 120;
  std::vector<size_t> bytes;
  for (int frame = 0; frame < 4; ++frame) {
    const Image8 source = patches(kWidth, kHeight, frame);
    std::vector<uint8_t> storage;
    auto plane = encoder.encode(source, false, storage);
    ASSERT_TRUE(plane.isOk()) << plane.status().toString();
    EXPECT_EQ(plane->codec, options.codec);
    EXPECT_EQ(plane->width, kWidth);
    EXPECT_EQ(plane->raw_size, kWidth * kHeight * 3);
    bytes.push_back(plane->data.size());
    auto decoded = decoder.decode(*plane);
    ASSERT_TRUE(decoded.isOk()) << decoded.status().toString();
    ASSERT_EQ(decoded->width, kWidth);
    ASSERT_EQ(decoded->height, kHeight);
    EXPECT_GT(psnr(source, *decoded), 32.0) << "frame " << frame;
  }
  EXPECT_EQ(encoder.keyFrames(), 1u);
  for (size_t f = 1; f < bytes.size(); ++f)
    EXPECT_LT(bytes[f] * 2, bytes[0]) << "frame " << f << " against the key frame";
  // Far below the raw picture, far below what LZ4 gets from such detail.
  EXPECT_LT(bytes[0] * 8, size_t{kWidth} * kHeight * 3);
}

// By a target bitrate: a noisy moving picture's frames average near the
// target a frame at the streams' 30 frames a second, a lower target costs fewer
// bytes for a worse picture, and a new target is taken at a key frame.
TEST_P(LayerVideo, ATargetBitrateHoldsTheStreamNearItsBytesAFrame) {
  constexpr uint32_t kWidth = 256, kHeight = 160;
  constexpr int kFrames = 40;
  struct Run {
    double bytes_a_frame = 0, psnr = 0;
  };
  // Sensor noise fresh every frame: no target is more than the picture
  // needs, so the rate control, not the picture, sets the bytes.
  auto noisy = [&](int frame) {
    Image8 image = patches(kWidth, kHeight, 3 * frame);
    uint32_t state = 2463534242u + static_cast<uint32_t>(frame);
    for (uint8_t& value : image.pixels) {
      state ^= state << 13, state ^= state >> 17, state ^= state << 5;  // xorshift32
      value = static_cast<uint8_t>(std::min(255u, value + state % 12));
    }
    return image;
  };
  auto run = [&](int kbps) {
    LayerVideoOptions options;
    options.codec = GetParam();
    options.kbps = kbps;
    LayerVideoEncoder encoder(options);
    LayerVideoDecoder decoder;
    Run result;
    for (int frame = 0; frame < kFrames; ++frame) {
      const Image8 source = noisy(frame);
      std::vector<uint8_t> storage;
      auto plane = encoder.encode(source, false, storage);
      EXPECT_TRUE(plane.isOk()) << plane.status().toString();
      if (!plane.isOk()) return result;
      auto decoded = decoder.decode(*plane);
      EXPECT_TRUE(decoded.isOk()) << decoded.status().toString();
      if (!decoded.isOk()) return result;
      result.bytes_a_frame += static_cast<double>(plane->data.size()) / kFrames;
      result.psnr += psnr(source, *decoded) / kFrames;
    }
    return result;
  };
  const Run high = run(2400), low = run(600);
  const double high_target = 2400 * 1000.0 / 8 / LayerVideoOptions::kFrameRate;  // 10 000 B
  EXPECT_GT(high.bytes_a_frame, 0.6 * high_target);
  EXPECT_LT(high.bytes_a_frame, 1.3 * high_target);
  EXPECT_LT(low.bytes_a_frame, 1.3 * high_target / 4);
  EXPECT_LT(low.bytes_a_frame, 0.5 * high.bytes_a_frame);
  EXPECT_LT(low.psnr, high.psnr);
  // A new target waits for the key frame, and the stream goes on.
  LayerVideoOptions options;
  options.codec = GetParam();
  options.kbps = 2400;
  LayerVideoEncoder encoder(options);
  LayerVideoDecoder decoder;
  std::vector<uint8_t> storage;
  for (int frame = 0; frame < 4; ++frame) {
    if (frame == 2) encoder.setKbps(600);
    auto plane = encoder.encode(patches(kWidth, kHeight, frame), frame == 3, storage);
    ASSERT_TRUE(plane.isOk()) << plane.status().toString();
    ASSERT_TRUE(decoder.decode(*plane).isOk()) << "frame " << frame;
    EXPECT_EQ(encoder.kbps(), frame < 3 ? 2400 : 600) << "frame " << frame;
  }
  EXPECT_EQ(encoder.keyFrames(), 2u);
}

TEST_P(LayerVideo, AReceiverThatMissedAFrameWaitsForTheNextKeyFrame) {
  LayerVideoOptions options;
  options.codec = GetParam();
  LayerVideoEncoder encoder(options);
  LayerVideoDecoder decoder;
  std::vector<std::vector<uint8_t>> storage(5);
  std::vector<protocol::Plane> planes;
  for (int frame = 0; frame < 4; ++frame) {
    auto plane = encoder.encode(patches(64, 48, frame), false, storage[frame]);
    ASSERT_TRUE(plane.isOk()) << plane.status().toString();
    planes.push_back(*plane);
  }
  ASSERT_TRUE(decoder.decode(planes[0]).isOk());
  // Frame 1 lost on the way: 2 follows a gap.
  auto after_gap = decoder.decode(planes[2]);
  ASSERT_FALSE(after_gap.isOk());
  EXPECT_EQ(after_gap.status().code(), StatusCode::kUnexpectedMessage);
  EXPECT_NE(after_gap.status().message().find("frame 2 after 0 is not a key frame"),
            std::string::npos)
      << after_gap.status().message();
  // Still broken: 3 follows 2, but 2 never decoded.
  EXPECT_FALSE(decoder.decode(planes[3]).isOk());
  // The sender asked for a key frame (a receiver missed one): decoding resumes.
  auto key = encoder.encode(patches(64, 48, 4), true, storage[4]);
  ASSERT_TRUE(key.isOk()) << key.status().toString();
  auto resumed = decoder.decode(*key);
  ASSERT_TRUE(resumed.isOk()) << resumed.status().toString();
  EXPECT_GT(psnr(patches(64, 48, 4), *resumed), 30.0);
  EXPECT_EQ(encoder.keyFrames(), 2u);
}

TEST_P(LayerVideo, ANewSizeStartsTheStreamAgainAtAKeyFrame) {
  LayerVideoOptions options;
  options.codec = GetParam();
  LayerVideoEncoder encoder(options);
  LayerVideoDecoder decoder;
  std::vector<uint8_t> first, second;
  auto small = encoder.encode(patches(64, 64, 0), false, first);
  ASSERT_TRUE(small.isOk());
  ASSERT_TRUE(decoder.decode(*small).isOk());
  auto large = encoder.encode(patches(128, 96, 1), false, second);
  ASSERT_TRUE(large.isOk()) << large.status().toString();
  EXPECT_EQ(encoder.keyFrames(), 2u);
  auto decoded = decoder.decode(*large);
  ASSERT_TRUE(decoded.isOk()) << decoded.status().toString();
  EXPECT_EQ(decoded->width, 128u);
  EXPECT_EQ(decoded->height, 96u);
}

TEST_P(LayerVideo, CorruptOrShortFramesAreRefusedByName) {
  LayerVideoOptions options;
  options.codec = GetParam();
  LayerVideoEncoder encoder(options);
  std::vector<uint8_t> storage;
  auto plane = encoder.encode(patches(64, 48, 0), false, storage);
  ASSERT_TRUE(plane.isOk());
  {
    LayerVideoDecoder decoder;
    protocol::Plane shortened = *plane;
    shortened.data = shortened.data.first(3);
    auto decoded = decoder.decode(shortened);
    ASSERT_FALSE(decoded.isOk());
    EXPECT_NE(decoded.status().message().find("holds no frame"), std::string::npos);
  }
  {
    // A key frame's header over bytes that are no bitstream: an error,
    // never a picture of garbage.
    LayerVideoDecoder decoder;
    std::vector<uint8_t> junk(storage.begin(), storage.begin() + 5);
    junk.resize(64, 0);
    protocol::Plane bad = *plane;
    bad.data = junk;
    auto decoded = decoder.decode(bad);
    ASSERT_FALSE(decoded.isOk());
    EXPECT_NE(decoded.status().message().find("frame 0"), std::string::npos)
        << decoded.status().message();
  }
  {
    // A stream whose pictures are larger than its receiver takes: refused
    // before decoding, and a declared picture past the cap never decodes.
    LayerVideoDecoder small(32);
    auto decoded = small.decode(*plane);
    ASSERT_FALSE(decoded.isOk());
    EXPECT_EQ(decoded.status().code(), StatusCode::kTooLarge);
    EXPECT_NE(decoded.status().message().find("above the stream's 32"), std::string::npos)
        << decoded.status().message();
    protocol::Plane claimed = *plane;
    claimed.width = 16;
    claimed.height = 16;
    claimed.raw_size = 16 * 16 * 3;
    EXPECT_FALSE(small.decode(claimed).isOk()) << "a 64x48 picture in a 32-texel stream";
  }
  {
    // A plane larger than the coded picture it carries.
    LayerVideoDecoder decoder;
    protocol::Plane larger = *plane;
    larger.width = 640;
    larger.raw_size = 640 * 48 * 3;
    auto decoded = decoder.decode(larger);
    ASSERT_FALSE(decoded.isOk());
    EXPECT_NE(decoded.status().message().find("smaller than its plane"), std::string::npos)
        << decoded.status().message();
  }
}

// What ffprobe says of a file's video stream ("" where it cannot run).
nlohmann::json probe(const std::string& path) {
  const FinishedProcess probed =
      runToEnd({"/usr/bin/ffprobe", "-v", "error", "-count_frames", "-show_entries",
                "stream=codec_name,width,height,nb_read_frames", "-of", "json", path},
               60000);
  if (probed.exit_code != 0) return {};
  return nlohmann::json::parse(probed.output, nullptr, false);
}

// --record-layers: each layer's stream as the client got it, a file that
// ffprobe (a tool nobody here wrote) reads frame by frame; a part begins at
// a key frame, and a frame missed ends it until the next key frame.
TEST_P(LayerVideo, RecordedLayersAreVideoFilesFfprobeReads) {
  if (::access("/usr/bin/ffprobe", X_OK) != 0)
    GTEST_SKIP() << "ffprobe (Debian's ffmpeg) is not installed: ./holofuse deps installs it";
  const std::string dir = (std::filesystem::temp_directory_path() /
                           ("holofuse_layer_files_" + layerVideoCodecName(GetParam()) + "_" +
                            std::to_string(::getpid())))
                              .string();
  std::filesystem::remove_all(dir);
  LayerVideoOptions options;
  options.codec = GetParam();
  LayerVideoEncoder steady(options), broken(options);
  LayerVideoRecorder recorder(dir);
  constexpr uint32_t kWidth = 200, kHeight = 120;
  for (int frame = 0; frame < 6; ++frame) {
    std::vector<uint8_t> storage, other;
    auto plane = steady.encode(patches(kWidth, kHeight, frame), false, storage);
    ASSERT_TRUE(plane.isOk()) << plane.status().toString();
    ASSERT_TRUE(recorder.add(0, *plane, 40.0 * frame).isOk());
    // Layer 1 misses its frame 2: frames 3 and 4 are not written, frame 5
    // (a key frame) begins its second part.
    auto second = broken.encode(patches(kWidth, kHeight, -frame), frame == 5, other);
    ASSERT_TRUE(second.isOk()) << second.status().toString();
    if (frame != 2) {
      ASSERT_TRUE(recorder.add(1, *second, 40.0 * frame).isOk());
    }
  }
  const auto written = recorder.finish();
  ASSERT_TRUE(written.isOk()) << written.status().toString();
  const std::string ext = GetParam() == protocol::Codec::kAv1 ? ".ivf" : ".ts";
  ASSERT_EQ(*written,
            (std::vector<std::string>{dir + "/layer0_part0" + ext, dir + "/layer1_part0" + ext,
                                      dir + "/layer1_part1" + ext}));
  const std::vector<int> frames = {6, 2, 1};
  for (size_t f = 0; f < written->size(); ++f) {
    const nlohmann::json said = probe((*written)[f]);
    ASSERT_TRUE(said.is_object() && said.contains("streams") && said["streams"].size() == 1)
        << (*written)[f] << ": " << said.dump();
    const nlohmann::json& stream = said["streams"][0];
    EXPECT_EQ(stream["codec_name"], layerVideoCodecName(GetParam())) << stream.dump();
    // The coded picture, whose top-left corner is the layer (its sides
    // rounded up to the codec's blocks).
    EXPECT_GE(stream["width"].get<int>(), static_cast<int>(kWidth)) << stream.dump();
    EXPECT_LT(stream["width"].get<int>(), static_cast<int>(kWidth) + 64) << stream.dump();
    EXPECT_GE(stream["height"].get<int>(), static_cast<int>(kHeight)) << stream.dump();
    EXPECT_LT(stream["height"].get<int>(), static_cast<int>(kHeight) + 64) << stream.dump();
    EXPECT_EQ(stream["nb_read_frames"], std::to_string(frames[f])) << (*written)[f];
  }
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

// A CRF past the codec's worst (a deeper layer's, --layer-video-crf-step)
// codes at the worst: the same bytes as the worst itself, fewer than a
// middling quality.
TEST_P(LayerVideo, ACrfPastTheWorstCodesAtTheWorst) {
  const int worst = GetParam() == protocol::Codec::kAv1 ? 63 : 51;
  auto keyFrameBytes = [&](int crf) {
    LayerVideoOptions options;
    options.codec = GetParam();
    options.crf = crf;
    LayerVideoEncoder encoder(options);
    std::vector<uint8_t> storage;
    auto plane = encoder.encode(patches(128, 96, 0), false, storage);
    EXPECT_TRUE(plane.isOk()) << plane.status().toString();
    return plane.isOk() ? std::vector<uint8_t>(plane->data.begin(), plane->data.end())
                        : std::vector<uint8_t>{};
  };
  const std::vector<uint8_t> at_worst = keyFrameBytes(worst);
  ASSERT_FALSE(at_worst.empty());
  EXPECT_EQ(keyFrameBytes(worst + 9), at_worst);
  EXPECT_LT(at_worst.size(), keyFrameBytes(worst / 2).size());
}

INSTANTIATE_TEST_SUITE_P(Codecs, LayerVideo,
                         ::testing::Values(protocol::Codec::kH264, protocol::Codec::kHevc,
                                           protocol::Codec::kAv1),
                         [](const auto& info) { return layerVideoCodecName(info.param); });

}  // namespace
}  // namespace holofuse
