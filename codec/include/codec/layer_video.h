// Texture layers as video (Volino and Hilton 2016, section 4: layers whose
// texture domain stays put from frame to frame code well as video). One
// stream per layer index through Debian's FFmpeg libraries (libx264,
// libx265, libaom encoders; FFmpeg's own decoders), tuned for latency: no
// B-frames, no look-ahead, one packet out per frame in.
//
// On the wire a stream's frame is a colour plane of codec kH264, kHevc or
// kAv1 (protocol 1.6) whose data is a 5-byte header, the stream's sequence
// number (u32, little endian) and flags (u8, bit 0: a key frame), then the
// codec's bitstream (Annex B for H.264 and HEVC, OBUs for AV1). The coded
// picture may be larger than the plane (sides rounded up); the plane's
// width x height is its top-left corner.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "base/status.h"
#include "image/image.h"
#include "protocol/messages.h"

namespace holofuse {

struct LayerVideoOptions {
  static constexpr int kFrameRate = 30;
  static constexpr int kBufferFrames = 4;
  protocol::Codec codec = protocol::Codec::kH264;  // kH264, kHevc or kAv1
  // Constant quality: lower is better and larger (0..51; AV1 0..63; a
  // larger value is the codec's worst). 12 in
  // 4:4:4 keeps eval's clean scene 0.05 dB from LZ4 layers at 39% of their
  // bytes (docs/atlas.md).
  int crf = 12;
  // Rate control by a target bitrate instead, where above 0: kilobits a
  // second at the streams' clock of 30 frames a second (kFrameRate), with
  // a buffer of kBufferFrames frames' worth, so that no frame (a key frame
  // included) takes longer than that to send at the target rate. HEVC
  // takes it as a ceiling over crf (x265's own ABR misses, see start()).
  int kbps = 0;
  int key_interval = 60;    // frames between key frames at most
  bool full_chroma = true;  // 4:4:4: 4:2:0 bleeds colour across chart borders
  bool operator==(const LayerVideoOptions&) const = default;
};

// Video codecs by name on command lines and in reports: h264, hevc, av1.
const std::vector<std::string>& layerVideoCodecNames();
std::string layerVideoCodecName(protocol::Codec codec);
std::optional<protocol::Codec> layerVideoCodecFromName(const std::string& name);
bool isVideoCodec(protocol::Codec codec);

// A stream's frame as sent: its sequence number, whether it is a key
// frame, and the codec's bitstream (the plane's data after the header).
struct LayerVideoPacket {
  uint32_t sequence = 0;
  bool key_frame = false;
  std::span<const uint8_t> bitstream;
};
StatusOr<LayerVideoPacket> layerVideoPacket(const protocol::Plane& plane);

// One layer's stream on the sending side. A frame of another size than the
// last starts the stream again at a key frame.
class LayerVideoEncoder {
 public:
  explicit LayerVideoEncoder(const LayerVideoOptions& options);
  ~LayerVideoEncoder();
  LayerVideoEncoder(const LayerVideoEncoder&) = delete;
  LayerVideoEncoder& operator=(const LayerVideoEncoder&) = delete;

  // The RGB image as the stream's next frame, a key frame when key_frame
  // (a receiver joined or missed one), the interval is up or the size
  // changed: a plane of kind kColor whose data lies in storage.
  StatusOr<protocol::Plane> encode(const Image8& rgb, bool key_frame,
                                   std::vector<uint8_t>& storage);
  uint64_t keyFrames() const { return key_frames_; }
  // A new target bitrate (LayerVideoOptions::kbps), taken at the next key
  // frame: the stream starts again there, which a receiver cannot tell
  // from any other key frame.
  void setKbps(int kbps) { next_kbps_ = kbps; }
  int kbps() const { return options_.kbps; }

 private:
  struct Codec;
  Status start(uint32_t coded_width, uint32_t coded_height);
  LayerVideoOptions options_;
  std::unique_ptr<Codec> codec_;
  uint32_t sequence_ = 0;
  int next_kbps_ = 0;
  int since_key_ = 0;
  uint64_t key_frames_ = 0;
};

// One layer's stream on the receiving side: decodes planes in stream
// order. A plane that follows a gap in the sequence (a frame this side
// never got) is refused until the next key frame, by name, and so is a
// bitstream the decoder rejects; the stream then waits for a key frame.
class LayerVideoDecoder {
 public:
  // max_side: the largest plane side a stream may carry; a bitstream that
  // declares a larger picture is refused before the decoder allocates it.
  explicit LayerVideoDecoder(uint32_t max_side = 4096);
  ~LayerVideoDecoder();
  LayerVideoDecoder(const LayerVideoDecoder&) = delete;
  LayerVideoDecoder& operator=(const LayerVideoDecoder&) = delete;

  StatusOr<Image8> decode(const protocol::Plane& plane);

 private:
  struct Codec;
  std::unique_ptr<Codec> codec_;
  std::optional<uint32_t> last_sequence_;
  uint32_t max_side_;
};

}  // namespace holofuse
