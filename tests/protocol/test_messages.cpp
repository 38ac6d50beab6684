// Round trips, truncation, caps, checksums, forward compatibility and the
// golden byte vectors of every minor of protocol v1.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "message_samples.h"
#include "protocol/crc32c.h"
#include "protocol/frame.h"
#include "protocol/messages.h"

namespace holofuse::protocol {
namespace {

using testing::allSamples;

Frame decodeOne(std::span<const uint8_t> bytes, Status* status = nullptr) {
  StreamDecoder decoder;
  decoder.feed(bytes);
  if (status != nullptr) *status = decoder.status();
  return decoder.hasFrame() ? decoder.takeFrame() : Frame{};
}

Bytes withFixedCrc(Bytes bytes) {
  uint32_t crc = crc32c(0, bytes.data(), kHeaderSize - 4);
  crc = crc32c(crc, bytes.data() + kHeaderSize, bytes.size() - kHeaderSize);
  for (int i = 0; i < 4; ++i) bytes[kHeaderSize - 4 + i] = static_cast<uint8_t>(crc >> (8 * i));
  return bytes;
}

TEST(Crc32c, MatchesTheStandardCheckValue) {
  const std::string check = "123456789";
  const auto* data = reinterpret_cast<const uint8_t*>(check.data());
  EXPECT_EQ(crc32c(0, data, check.size()), 0xE3069283u);
  EXPECT_EQ(crc32cPortable(0, data, check.size()), 0xE3069283u);
}

TEST(Crc32c, FastPathEqualsPortableAtEveryLengthAndAlignment) {
  std::vector<uint8_t> data(300);
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<uint8_t>(i * 31 + 7);
  for (size_t offset = 0; offset < 9; ++offset) {
    for (size_t n = 0; n + offset <= data.size(); n += 13) {
      ASSERT_EQ(crc32c(0, data.data() + offset, n), crc32cPortable(0, data.data() + offset, n))
          << offset << " " << n;
    }
  }
  // Long inputs take the three-stream path: every length around its block
  // boundaries, at odd alignments, must still agree.
  std::vector<uint8_t> big(20000);
  for (size_t i = 0; i < big.size(); ++i) big[i] = static_cast<uint8_t>((i * 2654435761u) >> 13);
  for (size_t n : {6143u, 6144u, 6145u, 12287u, 12288u, 18432u, 12345u, 19990u}) {
    for (size_t offset : {0u, 3u}) {
      ASSERT_EQ(crc32c(0, big.data() + offset, n), crc32cPortable(0, big.data() + offset, n)) << n;
    }
  }
  // Continuing a CRC equals computing it at once.
  EXPECT_EQ(crc32c(crc32c(0, data.data(), 100), data.data() + 100, 200),
            crc32c(0, data.data(), 300));
}

TEST(Messages, EveryTypeRoundTrips) {
  {
    Hello m;
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(testing::sampleHello(), 1)), m).isOk());
    EXPECT_EQ(m.id, 3u);
    EXPECT_EQ(m.nonce, 0x1122334455667788ull);
    EXPECT_EQ(m.name, "pod-3");
    EXPECT_EQ(m.capabilities, 5u);
  }
  {
    HelloAck m;
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(testing::sampleHelloAck(), 1)), m).isOk());
    EXPECT_EQ(m.session_id, 42u);
    EXPECT_EQ(m.server_time_ns, 987654321u);
  }
  {
    Calibration m;
    const Calibration in = testing::sampleCalibration();
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(in, 1)), m).isOk());
    EXPECT_EQ(m.fx, in.fx);
    EXPECT_EQ(m.skew, in.skew);
    EXPECT_EQ(m.distortion, in.distortion);
    EXPECT_EQ(m.rotation, in.rotation);
    EXPECT_EQ(m.translation, in.translation);
  }
  {
    const auto bytes = encodeFrame(testing::samplePodFrame(), 1);
    const Frame frame = decodeOne(bytes);
    PodFrame m;
    ASSERT_TRUE(decodeFrame(frame, m).isOk());
    const PodFrame in = testing::samplePodFrame();
    EXPECT_EQ(m.frame_id, in.frame_id);
    EXPECT_EQ(m.offset_x, 8u);
    EXPECT_EQ(m.stamps, in.stamps);
    ASSERT_EQ(m.planes.size(), 2u);
    EXPECT_TRUE(std::equal(m.planes[0].data.begin(), m.planes[0].data.end(),
                           in.planes[0].data.begin(), in.planes[0].data.end()));
    EXPECT_EQ(m.planes[1].format, PixelFormat::kGray8);
  }
  {
    MeshFrame m;
    const MeshFrame in = testing::sampleMeshFrame();
    const Frame frame = decodeOne(encodeFrame(in, 1));
    ASSERT_TRUE(decodeFrame(frame, m).isOk());
    EXPECT_EQ(m.bounds_max, in.bounds_max);
    EXPECT_EQ(m.triangle_count, 12u);
    EXPECT_TRUE(std::equal(m.mesh.begin(), m.mesh.end(), in.mesh.begin(), in.mesh.end()));
  }
  {
    TextureBundle m;
    const Frame frame = decodeOne(encodeFrame(testing::sampleTextureBundle(), 1));
    ASSERT_TRUE(decodeFrame(frame, m).isOk());
    ASSERT_EQ(m.images.size(), 2u);
    EXPECT_EQ(m.images[1].camera_id, 3u);
    ASSERT_EQ(m.images[1].planes.size(), 2u);
    EXPECT_EQ(m.images[1].planes[1].kind, PlaneKind::kFeather)
        << "since 1.2, each pod's feather map";
    EXPECT_FALSE(m.layers.has_value()) << "images, no layers";
  }
  {
    // Since 1.5: layers in place of images; a 1.4 reader of the same bytes
    // skips them, a 1.4 encoding has none.
    TextureBundle m;
    const TextureBundle in = testing::sampleLayeredBundle();
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(in, 1)), m).isOk());
    EXPECT_TRUE(m.images.empty());
    ASSERT_TRUE(m.layers.has_value());
    EXPECT_EQ(m.layers->texels, 64u);
    EXPECT_EQ(m.layers->lattice, in.layers->lattice);
    EXPECT_EQ(m.layers->square_count, 5u);
    EXPECT_TRUE(std::equal(m.layers->slots.begin(), m.layers->slots.end(), in.layers->slots.begin(),
                           in.layers->slots.end()));
    EXPECT_EQ(m.layers->camera_ids, in.layers->camera_ids);
    ASSERT_EQ(m.layers->layers.size(), 2u);
    EXPECT_EQ(m.layers->layers[1][1].kind, PlaneKind::kCamera);
    TextureBundle old;
    const Frame as_1_4 = decodeOne(encodeFrame(in, 1, 0, 4));
    ASSERT_TRUE(decodeFrame(as_1_4, old).isOk());
    EXPECT_FALSE(old.layers.has_value());
    // Layers past the cap are refused by name.
    Frame frame = decodeOne(encodeFrame(in, 1));
    TextureBundle probe;
    // The layer count follows the (empty) images: frame id, stamps, image count.
    const size_t at = 8 + 2 + 20 * in.stamps.size() + 1;
    frame.bytes[kHeaderSize + at] = static_cast<uint8_t>(kMaxLayers + 1);
    const Status status = decodeFrame(frame, probe);
    EXPECT_EQ(status.code(), StatusCode::kTooLarge);
    EXPECT_NE(status.toString().find("texture_bundle.layer_count"), std::string::npos)
        << status.toString();
  }
  {
    // Since 1.12 the layers say which way their charts face; before, every
    // chart faced its triangles' own normals, and a 1.11 reading says so.
    TextureBundle in = testing::sampleLayeredBundle();
    for (const bool around : {true, false}) {
      in.layers->charts_face_surface_around = around;
      TextureBundle m;
      ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(in, 1)), m).isOk());
      EXPECT_EQ(m.layers->charts_face_surface_around, around);
      EXPECT_EQ(m.layers->texel_metres, in.layers->texel_metres) << "the fields after it in place";
      ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(in, 1, 0, 11)), m).isOk());
      EXPECT_FALSE(m.layers->charts_face_surface_around);
      EXPECT_EQ(m.layers->texel_metres, in.layers->texel_metres);
    }
    // Another value is refused by name: frame id, stamps, image count,
    // layer count, texels, squares per side, square texels, lattice, chart cells.
    Frame frame = decodeOne(encodeFrame(in, 1));
    const size_t at = 8 + 2 + 20 * in.stamps.size() + 1 + 1 + 4 + 4 + 4 + 12 + 1;
    ASSERT_EQ(frame.bytes[kHeaderSize + at], 0);
    frame.bytes[kHeaderSize + at] = 2;
    TextureBundle probe;
    const Status status = decodeFrame(frame, probe);
    EXPECT_EQ(status.code(), StatusCode::kMalformed);
    EXPECT_NE(status.toString().find("texture_bundle.chart_facing"), std::string::npos)
        << status.toString();
  }
  {
    // Since 1.6: a layer's colour may be a video frame; a 1.5 reader has no
    // such codec and refuses the plane by name.
    TextureBundle m;
    const TextureBundle in = testing::sampleLayerVideoBundle();
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(in, 1)), m).isOk());
    ASSERT_TRUE(m.layers.has_value());
    EXPECT_EQ(m.layers->layers[0][0].codec, Codec::kH264);
    EXPECT_EQ(m.layers->layers[0][1].codec, Codec::kRaw);
    TextureBundle old;
    const Status status = decodeFrame(decodeOne(encodeFrame(in, 1, 0, 5)), old);
    EXPECT_EQ(status.code(), StatusCode::kMalformed);
    EXPECT_NE(status.toString().find("unknown codec 3"), std::string::npos) << status.toString();
    // Since 1.11 a camera plane may be Zstandard; a 1.10 reader refuses it.
    const TextureBundle zstd = testing::sampleZstdCameraPlanesBundle();
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(zstd, 1)), m).isOk());
    EXPECT_EQ(m.layers->layers[1][1].codec, Codec::kZstd);
    const Status before = decodeFrame(decodeOne(encodeFrame(zstd, 1, 0, 10)), old);
    EXPECT_EQ(before.code(), StatusCode::kMalformed);
    EXPECT_NE(before.toString().find("unknown codec 6"), std::string::npos) << before.toString();
    // Images never carry video, whatever the minor.
    TextureBundle images = testing::sampleTextureBundle();
    images.images[0].planes[0].codec = Codec::kH264;
    EXPECT_FALSE(decodeFrame(decodeOne(encodeFrame(images, 1)), old).isOk());
  }
  {
    // Since 1.7: a mesh may come as half floats through LZ4 (codec 2); a
    // 1.6 reader has no such codec and refuses the frame by name.
    MeshFrame in = testing::sampleMeshFrame();
    in.codec = MeshCodec::kFp16Lz4;
    MeshFrame m;
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(in, 1)), m).isOk());
    EXPECT_EQ(m.codec, MeshCodec::kFp16Lz4);
    const Status status = decodeFrame(decodeOne(encodeFrame(in, 1, 0, 6)), m);
    EXPECT_EQ(status.code(), StatusCode::kMalformed);
    EXPECT_NE(status.toString().find("unknown mesh codec 2 in a 1.6 frame"), std::string::npos)
        << status.toString();
    in.codec = static_cast<MeshCodec>(3);
    EXPECT_FALSE(decodeFrame(decodeOne(encodeFrame(in, 1)), m).isOk()) << "no codec 3 in 1.7";
  }
  {
    Stats m;
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(testing::sampleStats(), 1)), m).isOk());
    EXPECT_EQ(m.cameras_present, 0xBu);
    EXPECT_EQ(m.note, "proceeded without camera(s) 2");
    EXPECT_EQ(m.pod_arrivals, testing::sampleStats().pod_arrivals);
  }
  {
    Heartbeat h;
    Bye b;
    ErrorMessage e;
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(Heartbeat{777}, 1)), h).isOk());
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(Bye{"done"}, 1)), b).isOk());
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(ErrorMessage{3, "x"}, 1)), e).isOk());
    EXPECT_EQ(h.send_time_ns, 777u);
    EXPECT_EQ(b.reason, "done");
    EXPECT_EQ(e.code, 3u);
  }
  {
    const FrameRequest in{5'000'000'022, kCapabilityLayers};
    FrameRequest m;
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(in, 1)), m).isOk());
    EXPECT_EQ(m, in);
    // A request of 1.9 states no layers: the reader says none, not "none wanted".
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(in, 1, 0, 9)), m).isOk());
    EXPECT_EQ(m.frames_through, in.frames_through);
    EXPECT_FALSE(m.layer_capabilities.has_value());
    // One of 1.10 without them is truncated.
    FrameBuilder builder(MessageType::kFrameRequest, 1);
    builder.setMinor(10);
    writePayload(builder.writer(), in, 9);
    const Frame truncated = decodeOne(std::move(builder).finish());
    EXPECT_EQ(decodeFrame(truncated, m).code(), StatusCode::kTruncated);
  }
  {
    const ClockProbe in{ProbeStep::kReply, 11, 5'000'000'022, 5'000'000'031};
    ClockProbe m;
    ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(in, 1)), m).isOk());
    EXPECT_EQ(m, in);
    // A step other than request or reply is refused by name.
    Bytes bad = encodeFrame(in, 1);
    bad[kHeaderSize] = 3;
    const Status status = decodeFrame(decodeOne(withFixedCrc(bad)), m);
    EXPECT_EQ(status.code(), StatusCode::kMalformed);
    EXPECT_NE(status.toString().find("clock_probe.step"), std::string::npos) << status.toString();
  }
}

// A stage's time adds up its finished stamps only: a fan-out stamp still
// open (end 0) or a clock gone backwards adds nothing, other stages nothing.
TEST(Messages, StampedMsAddsTheFinishedStampsOfOneStage) {
  const uint16_t decode = static_cast<uint16_t>(Stage::kDecode);
  const std::vector<StageStamp> stamps = {{decode, 1, 1'000'000, 3'500'000},
                                          {decode, 2, 10'000'000, 11'000'000},
                                          {decode, 3, 5'000'000, 0},
                                          {decode, 4, 9'000'000, 8'000'000},
                                          {static_cast<uint16_t>(Stage::kHull), 0, 0, 7'000'000}};
  EXPECT_DOUBLE_EQ(stampedMs(stamps, Stage::kDecode), 3.5);
  EXPECT_DOUBLE_EQ(stampedMs(stamps, Stage::kHull), 7.0);
  EXPECT_DOUBLE_EQ(stampedMs(stamps, Stage::kRender), 0.0);
}

// Reports list the stages in the order a frame passes them: every known
// stage once, the pods' first and the written PNG last.
TEST(Messages, EveryStageHasItsPlaceInThePipelineOrder) {
  const std::vector<uint16_t>& order = stagesInPipelineOrder();
  std::vector<uint16_t> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  ASSERT_EQ(sorted.size(), size_t{kLastStage - kFirstStage + 1});
  for (uint16_t id = kFirstStage; id <= kLastStage; ++id) EXPECT_EQ(sorted[id - kFirstStage], id);
  EXPECT_EQ(stageName(order.front()), "pod_render");
  EXPECT_EQ(stageName(order.back()), "write");
  EXPECT_EQ(stageName(static_cast<uint16_t>(Stage::kServerDecode)), "server_decode");
  const auto at = [&](Stage s) {
    return std::find(order.begin(), order.end(), static_cast<uint16_t>(s)) - order.begin();
  };
  EXPECT_LT(at(Stage::kSend), at(Stage::kServerDecode));
  EXPECT_LT(at(Stage::kServerDecode), at(Stage::kSyncWait));
  EXPECT_LT(at(Stage::kHull), at(Stage::kRefine));
  EXPECT_LT(at(Stage::kRefine), at(Stage::kMeshEncode));
  EXPECT_EQ(stageName(static_cast<uint16_t>(Stage::kRefine)), "refine");
}

TEST(Messages, DecodingTheWrongTypeIsAnError) {
  Hello m;
  const Status s = decodeFrame(decodeOne(encodeFrame(Bye{"x"}, 1)), m);
  EXPECT_EQ(s.code(), StatusCode::kUnexpectedMessage);
}

// Every strict prefix of every valid frame leaves the stream decoder waiting
// (no frame, no crash), and every strict prefix of every payload fails to
// decode with kTruncated naming a field.
TEST(Messages, EveryTruncationFailsCleanly) {
  for (const auto& sample : allSamples()) {
    for (size_t n = 0; n < sample.frame.size(); ++n) {
      StreamDecoder decoder;
      decoder.feed(std::span<const uint8_t>(sample.frame.data(), n));
      EXPECT_FALSE(decoder.hasFrame()) << sample.name << " prefix " << n;
      EXPECT_TRUE(decoder.status().isOk()) << sample.name << " prefix " << n;
    }
    const Frame frame = decodeOne(sample.frame);
    const auto payload = frame.payload();
    for (size_t n = 0; n < payload.size(); ++n) {
      Frame cut = frame;
      cut.bytes.resize(kHeaderSize + n);
      Status s;
      switch (static_cast<MessageType>(frame.header.type)) {
        case MessageType::kHello: {
          Hello m;
          s = decodeFrame(cut, m);
          break;
        }
        case MessageType::kHelloAck: {
          HelloAck m;
          s = decodeFrame(cut, m);
          break;
        }
        case MessageType::kCalibration: {
          Calibration m;
          s = decodeFrame(cut, m);
          break;
        }
        case MessageType::kPodFrame: {
          PodFrame m;
          s = decodeFrame(cut, m);
          break;
        }
        case MessageType::kMeshFrame: {
          MeshFrame m;
          s = decodeFrame(cut, m);
          break;
        }
        case MessageType::kTextureBundle: {
          TextureBundle m;
          s = decodeFrame(cut, m);
          break;
        }
        case MessageType::kHeartbeat: {
          Heartbeat m;
          s = decodeFrame(cut, m);
          break;
        }
        case MessageType::kStats: {
          Stats m;
          s = decodeFrame(cut, m);
          break;
        }
        case MessageType::kBye: {
          Bye m;
          s = decodeFrame(cut, m);
          break;
        }
        case MessageType::kError: {
          ErrorMessage m;
          s = decodeFrame(cut, m);
          break;
        }
        case MessageType::kAuth: {
          Auth m;
          s = decodeFrame(cut, m);
          break;
        }
        case MessageType::kClockProbe: {
          ClockProbe m;
          s = decodeFrame(cut, m);
          break;
        }
        case MessageType::kFrameRequest: {
          FrameRequest m;
          s = decodeFrame(cut, m);
          break;
        }
        default:
          FAIL();
      }
      ASSERT_FALSE(s.isOk()) << sample.name << " payload prefix " << n;
      EXPECT_NE(s.message().find("field '"), std::string::npos) << s.message();
    }
  }
}

TEST(Framing, WrongMagicIsRejectedWithItsOffset) {
  auto bytes = encodeFrame(Heartbeat{1}, 0);
  bytes[0] = 'X';
  Status s;
  decodeOne(bytes, &s);
  EXPECT_EQ(s.code(), StatusCode::kBadMagic);
  EXPECT_NE(s.message().find("offset 0"), std::string::npos);
}

TEST(Framing, NewerMajorIsRefused) {
  auto bytes = encodeFrame(Heartbeat{1}, 0);
  bytes[4] = kVersionMajor + 1;
  Status s;
  decodeOne(withFixedCrc(bytes), &s);
  EXPECT_EQ(s.code(), StatusCode::kUnsupportedVersion);
  EXPECT_NE(s.message().find("major"), std::string::npos);
}

TEST(Framing, AHeaderClaimingFourGigabytesIsRejectedBeforeAllocation) {
  auto bytes = encodeFrame(Heartbeat{1}, 0);
  for (int i = 0; i < 4; ++i) bytes[12 + i] = 0xFF;
  bytes.resize(kHeaderSize);  // nothing follows: a decoder that allocated would wait
  Status s;
  decodeOne(bytes, &s);
  EXPECT_EQ(s.code(), StatusCode::kTooLarge);
  EXPECT_NE(s.message().find("payload_length"), std::string::npos);
  EXPECT_NE(s.message().find("4294967295"), std::string::npos);
}

TEST(Framing, ReservedBitsMustBeZero) {
  auto bytes = encodeFrame(Heartbeat{1}, 0);
  bytes[10] = 1;
  Status s;
  decodeOne(withFixedCrc(bytes), &s);
  EXPECT_EQ(s.code(), StatusCode::kReservedNonZero);
  bytes = encodeFrame(Heartbeat{1}, 0);
  bytes[9] = 0x80;
  decodeOne(withFixedCrc(bytes), &s);
  EXPECT_EQ(s.code(), StatusCode::kReservedNonZero);
}

TEST(Framing, CorruptedPayloadOrChecksumFailsTheCrc) {
  for (size_t at : {size_t{kHeaderSize}, size_t{kHeaderSize + 5}, size_t{24}}) {
    auto bytes = encodeFrame(testing::sampleStats(), 0);
    bytes[at] ^= 0x01;
    Status s;
    decodeOne(bytes, &s);
    EXPECT_EQ(s.code(), StatusCode::kBadChecksum) << at;
  }
}

TEST(Framing, UnknownMessageTypeIsDeliveredForSkippingAndTheStreamGoesOn) {
  FrameBuilder builder(static_cast<MessageType>(999), 0);
  builder.buffer().insert(builder.buffer().end(), {1, 2, 3});
  auto unknown = std::move(builder).finish();
  auto bye = encodeFrame(Bye{"after"}, 1);
  StreamDecoder decoder;
  decoder.feed(unknown);
  decoder.feed(bye);
  ASSERT_TRUE(decoder.status().isOk());
  ASSERT_TRUE(decoder.hasFrame());
  EXPECT_EQ(decoder.takeFrame().header.type, 999);
  ASSERT_TRUE(decoder.hasFrame());
  Bye m;
  ASSERT_TRUE(decodeFrame(decoder.takeFrame(), m).isOk());
  EXPECT_EQ(m.reason, "after");
  EXPECT_STREQ(messageTypeName(999), "unknown");
}

// Reads as Connection does: into writableSpan until it is empty (a header
// waits for the frames before it to be taken) or the bytes run out.
size_t readAvailable(StreamDecoder& decoder, std::span<const uint8_t> stream, size_t from) {
  while (from < stream.size() && decoder.status().isOk()) {
    const auto into = decoder.writableSpan();
    if (into.empty()) break;
    const size_t n = std::min(into.size(), stream.size() - from);
    std::memcpy(into.data(), stream.data() + from, n);
    decoder.commit(n);
    from += n;
  }
  return from;
}

TEST(Framing, AHeaderAboveItsCapWaitsForTheFramesBeforeItThatMayRaiseIt) {
  // A pod writes its Calibration and its first PodFrame at once; the
  // server raises the PodFrame's cap only when it handles the Calibration.
  Bytes stream = encodeFrame(testing::sampleCalibration(), 0);
  const size_t calibration_bytes = stream.size();
  PodFrame large = testing::samplePodFrame();
  large.stamps.resize(64);  // above the Calibration's size
  const Bytes pod = encodeFrame(large, 1);
  stream.insert(stream.end(), pod.begin(), pod.end());
  const auto cap = static_cast<uint32_t>(calibration_bytes - kHeaderSize);
  ASSERT_LT(cap, pod.size() - kHeaderSize);

  for (const bool raised : {true, false}) {
    StreamDecoder decoder(cap);
    size_t read = readAvailable(decoder, stream, 0);
    ASSERT_TRUE(decoder.status().isOk()) << decoder.status().toString();
    EXPECT_EQ(read, calibration_bytes + kHeaderSize);  // the PodFrame's payload is not read
    ASSERT_TRUE(decoder.hasFrame());
    EXPECT_EQ(decoder.takeFrame().header.type, static_cast<uint16_t>(MessageType::kCalibration));
    if (raised) decoder.setTypeCap(static_cast<uint16_t>(MessageType::kPodFrame), 1u << 20);
    read = readAvailable(decoder, stream, read);
    if (!raised) {
      EXPECT_EQ(decoder.status().code(), StatusCode::kTooLarge);
      EXPECT_NE(decoder.status().message().find("payload_length"), std::string::npos);
      EXPECT_FALSE(decoder.hasFrame());
      continue;
    }
    ASSERT_TRUE(decoder.status().isOk()) << decoder.status().toString();
    EXPECT_EQ(read, stream.size());
    ASSERT_TRUE(decoder.hasFrame());
    PodFrame back;
    EXPECT_TRUE(decodeFrame(decoder.takeFrame(), back).isOk());
  }
}

TEST(Framing, UnknownTrailingFieldsOfAKnownTypeAreSkipped) {
  // A future minor appends fields: a 1.1 reader reads what it knows.
  FrameBuilder builder(MessageType::kStats, 0);
  WireWriter w(builder.buffer());
  writePayload(w, testing::sampleStats(), 1);
  w.u64(0xDEADBEEF);
  w.str("a field from minor 2");
  builder.setMinor(1);
  const auto bytes = std::move(builder).finish();
  Stats m;
  ASSERT_TRUE(decodeFrame(decodeOne(bytes), m).isOk());
  EXPECT_EQ(m.pod_bytes, 65536u);
  EXPECT_EQ(m.note, "proceeded without camera(s) 2");
  ASSERT_TRUE(m.pod_arrivals.has_value());
  ASSERT_EQ(m.pod_arrivals->size(), 3u);
  EXPECT_EQ((*m.pod_arrivals)[1].jitter_us, 2250u);
  EXPECT_EQ((*m.pod_arrivals)[1].clock_uncertainty_ns, 0u) << "no clocks before 1.8";
}

// 1.1 appended each pod's arrivals to Stats. A 1.0 Stats has none (not an
// empty list), and a list that is cut short or too long is refused by name.
TEST(Framing, StatsCarriesPodArrivalsSinceMinor1) {
  Stats v1_0 = testing::sampleStats();
  v1_0.pod_arrivals.reset();
  const Frame old_frame = decodeOne(encodeFrame(v1_0, 0, 0, 0));
  EXPECT_EQ(old_frame.header.minor, 0);
  Stats m;
  ASSERT_TRUE(decodeFrame(old_frame, m).isOk());
  EXPECT_FALSE(m.pod_arrivals.has_value());
  EXPECT_EQ(m.note, v1_0.note);
  EXPECT_EQ(encodeFrame(testing::sampleStats(), 0, 0, 0), encodeFrame(v1_0, 0, 0, 0))
      << "a 1.0 encoding leaves the arrivals out whether or not the message has them";

  // 1.1's fields under a 1.0 header: a reader takes what 1.0 has and
  // skips the rest, as a 1.0 reader would.
  FrameBuilder relabelled(MessageType::kStats, 0);
  writePayload(relabelled.writer(), testing::sampleStats(), 1);
  relabelled.setMinor(0);
  ASSERT_TRUE(decodeFrame(decodeOne(std::move(relabelled).finish()), m).isOk());
  EXPECT_FALSE(m.pod_arrivals.has_value());
  EXPECT_EQ(m.pod_bytes, 65536u);

  Stats none = testing::sampleStats();
  none.pod_arrivals.emplace();
  ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(none, 0)), m).isOk());
  ASSERT_TRUE(m.pod_arrivals.has_value()) << "no pod yet is an empty list, not a 1.0 Stats";
  EXPECT_TRUE(m.pod_arrivals->empty());

  auto payloadWith = [](uint16_t count, int pods) {
    FrameBuilder builder(MessageType::kStats, 0);
    builder.setMinor(2);  // 1.1 and 1.2: at most 64 pods, no camera count after them
    writePayload(builder.writer(), testing::sampleStats(), 0);  // the 1.0 fields
    builder.writer().u16(count);
    for (int k = 0; k < pods; ++k) {
      builder.writer().u16(static_cast<uint16_t>(k));
      builder.writer().u64(10);
      builder.writer().u32(500);
    }
    return std::move(builder).finish();
  };
  Status s = decodeFrame(decodeOne(payloadWith(3, 2)), m);
  EXPECT_EQ(s.code(), StatusCode::kTruncated) << s.toString();
  EXPECT_NE(s.message().find("stats.pod_arrivals"), std::string::npos) << s.toString();
  s = decodeFrame(decodeOne(payloadWith(65, 0)), m);
  EXPECT_EQ(s.code(), StatusCode::kTooLarge) << s.toString();
  EXPECT_NE(s.message().find("stats.pod_arrivals.count"), std::string::npos) << s.toString();
  ASSERT_TRUE(decodeFrame(decodeOne(payloadWith(2, 2)), m).isOk());
  EXPECT_EQ(m.pod_arrivals->at(1), (PodArrivals{1, 10, 500}));
}

// 1.3 takes every camera a loop serves: bundles and Stats' arrivals of up
// to 128, and Stats counts the cameras present past its 64 bits. A peer of
// 1.2 gets the first 64, as it can read them.
TEST(Framing, MinorThreeCarriesUpTo128Cameras) {
  Stats many = testing::sampleStats();
  many.pod_arrivals.emplace();
  for (uint16_t pod = 0; pod < kMaxCameras; ++pod) many.pod_arrivals->push_back({pod, 7, 100});
  many.cameras_present_count = kMaxCameras;
  Stats m;
  ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(many, 0)), m).isOk());
  EXPECT_EQ(m.pod_arrivals->size(), size_t{kMaxCameras});
  EXPECT_EQ(m.cameras_present_count, kMaxCameras);
  ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(many, 0, 0, 2)), m).isOk());
  EXPECT_EQ(m.pod_arrivals->size(), kMaxCamerasBefore13);
  EXPECT_FALSE(m.cameras_present_count.has_value());

  TextureBundle bundle;
  bundle.frame_id = 9;
  for (uint32_t camera = 0; camera < 100; ++camera) {
    BundleImage image;
    image.camera_id = camera;
    image.planes = testing::samplePodFrame().planes;
    bundle.images.push_back(image);
  }
  TextureBundle back;
  ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(bundle, 0)), back).isOk());
  ASSERT_EQ(back.images.size(), 100u);
  EXPECT_EQ(back.images[99].camera_id, 99u);
  ASSERT_TRUE(decodeFrame(decodeOne(encodeFrame(bundle, 0, 0, 2)), back).isOk());
  EXPECT_EQ(back.images.size(), kMaxCamerasBefore13);
  // A 1.2 header claiming more than 64 images is refused by name.
  FrameBuilder claimed(MessageType::kTextureBundle, 0);
  claimed.setMinor(2);
  writePayload(claimed.writer(), bundle, 3);
  const Status s = decodeFrame(decodeOne(std::move(claimed).finish()), back);
  EXPECT_EQ(s.code(), StatusCode::kTooLarge) << s.toString();
  EXPECT_NE(s.message().find("texture_bundle.image_count"), std::string::npos) << s.toString();
}

TEST(Framing, ByteByByteFeedingGivesTheSameFrames) {
  Bytes stream;
  for (const auto& s : allSamples()) stream.insert(stream.end(), s.frame.begin(), s.frame.end());
  StreamDecoder decoder;
  size_t frames = 0;
  for (uint8_t b : stream) {
    decoder.feed(std::span<const uint8_t>(&b, 1));
    while (decoder.hasFrame()) {
      decoder.takeFrame();
      ++frames;
    }
  }
  EXPECT_TRUE(decoder.status().isOk());
  EXPECT_EQ(frames, allSamples().size());
  EXPECT_EQ(decoder.bytesConsumed(), stream.size());
}

TEST(Messages, HostileCountsAndSizesAreRejected) {
  // A plane whose raw size disagrees with width x height.
  PodFrame pod = testing::samplePodFrame();
  pod.planes[0].raw_size = 1;
  PodFrame out;
  EXPECT_EQ(decodeFrame(decodeOne(encodeFrame(pod, 0)), out).code(), StatusCode::kMalformed);
  // A stamp count far above what the payload holds.
  FrameBuilder builder(MessageType::kMeshFrame, 0);
  WireWriter w(builder.buffer());
  w.u64(1);
  w.u64(1);
  for (int i = 0; i < 6; ++i) w.f32(0);
  w.u32(0);
  w.u32(0);
  w.u8(1);
  w.u16(1000);  // 1000 stamps claimed, none present
  MeshFrame mesh;
  const Status s = decodeFrame(decodeOne(std::move(builder).finish()), mesh);
  EXPECT_EQ(s.code(), StatusCode::kTruncated);
  EXPECT_NE(s.message().find("stamps"), std::string::npos);
  // Sides so large that width * height * 3 wraps around 2^64 to a small
  // raw size: refused before any multiplication.
  PodFrame wrap = testing::samplePodFrame();
  wrap.planes[0].width = 4294903839u;
  wrap.planes[0].height = 1431676918u;
  wrap.planes[0].raw_size = 268112990u;
  const Status wrapped = decodeFrame(decodeOne(encodeFrame(wrap, 0)), out);
  EXPECT_EQ(wrapped.code(), StatusCode::kMalformed);
  EXPECT_NE(wrapped.message().find("outside 1..16384"), std::string::npos) << wrapped.message();
  // A calibration with a non-finite focal length.
  Calibration c = testing::sampleCalibration();
  c.fx = std::numeric_limits<double>::quiet_NaN();
  Calibration cout;
  EXPECT_EQ(decodeFrame(decodeOne(encodeFrame(c, 0)), cout).code(), StatusCode::kMalformed);
}

// Golden vectors lock the wire format: the bytes of each sample, as each
// minor spells it, must equal the file for its version.
// HOLOFUSE_REGENERATE_GOLDEN=1 writes missing or changed files (never
// deletes old versions).
TEST(Golden, EveryTypeMatchesItsVectorInEveryMinor) {
  const std::filesystem::path dir = HOLOFUSE_GOLDEN_DIR;
  const bool regenerate = std::getenv("HOLOFUSE_REGENERATE_GOLDEN") != nullptr;
  std::vector<std::pair<std::string, testing::Sample>> versions;
  for (uint8_t minor = 0; minor <= kVersionMinor; ++minor) {
    for (auto& sample : allSamples(minor))
      versions.emplace_back("1." + std::to_string(minor), std::move(sample));
  }
  for (const auto& [version, sample] : versions) {
    const auto path = dir / (sample.name + ".v" + version + ".bin");
    if (regenerate) {
      std::ofstream(path, std::ios::binary)
          .write(reinterpret_cast<const char*>(sample.frame.data()),
                 static_cast<std::streamsize>(sample.frame.size()));
    }
    std::ifstream in(path, std::ios::binary);
    ASSERT_TRUE(in) << "missing golden vector " << path;
    const Bytes golden((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(golden, sample.frame) << "wire format of " << sample.name << " changed";
  }
  // And the reader takes each minor's file as that minor's message.
  // Before 1.8 the arrivals carry no clocks: they read as not measured.
  std::vector<PodArrivals> without_clocks = *testing::sampleStats().pod_arrivals;
  for (auto& a : without_clocks) a.clock_offset_ns = 0, a.clock_uncertainty_ns = 0;
  for (const char* version : {"1.0", "1.1", "1.2", "1.3", "1.7", "1.8"}) {
    std::ifstream in(dir / ("stats.v" + std::string(version) + ".bin"), std::ios::binary);
    const Bytes bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    Stats m;
    ASSERT_TRUE(decodeFrame(decodeOne(bytes), m).isOk()) << version;
    EXPECT_EQ(m.note, testing::sampleStats().note) << version;
    if (std::string(version) == "1.0") {
      EXPECT_FALSE(m.pod_arrivals.has_value());
    } else if (std::string(version) == "1.8") {
      EXPECT_EQ(m.pod_arrivals, testing::sampleStats().pod_arrivals);
    } else {
      EXPECT_EQ(m.pod_arrivals, without_clocks) << version;
    }
    EXPECT_EQ(m.cameras_present_count.has_value(), std::string(version) != "1.0" &&
                                                       std::string(version) != "1.1" &&
                                                       std::string(version) != "1.2")
        << version;
  }
}

}  // namespace
}  // namespace holofuse::protocol
