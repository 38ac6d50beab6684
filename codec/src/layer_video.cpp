#include "codec/layer_video.h"

#include <algorithm>
#include <cstring>
#include <mutex>

#include "ffmpeg_codecs.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavutil/error.h>
#include <libavutil/log.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>
}

namespace holofuse {
namespace {

constexpr size_t kHeaderBytes = 5;  // sequence (u32) and flags (u8)
constexpr uint8_t kKeyFrameFlag = 1;

void quietLibraries() {
  // The encoders' banners and notes are not the loop's output, and every
  // failure comes back as a Status naming the frame.
  static std::once_flag once;
  std::call_once(once, [] { av_log_set_level(AV_LOG_FATAL); });
}

using ffmpeg::avError;
using ffmpeg::CodecInfo;
using ffmpeg::infoOf;
using ffmpeg::kCodecs;

struct ContextDeleter {
  void operator()(AVCodecContext* c) const { avcodec_free_context(&c); }
};
struct FrameDeleter {
  void operator()(AVFrame* f) const { av_frame_free(&f); }
};
struct PacketDeleter {
  void operator()(AVPacket* p) const { av_packet_free(&p); }
};
struct ScaleDeleter {
  void operator()(SwsContext* s) const { sws_freeContext(s); }
};
using ContextPtr = std::unique_ptr<AVCodecContext, ContextDeleter>;
using FramePtr = std::unique_ptr<AVFrame, FrameDeleter>;
using PacketPtr = std::unique_ptr<AVPacket, PacketDeleter>;
using ScalePtr = std::unique_ptr<SwsContext, ScaleDeleter>;

uint32_t roundUp16(uint32_t side) { return (side + 15u) & ~15u; }

}  // namespace

const std::vector<std::string>& layerVideoCodecNames() {
  static const std::vector<std::string> names = {"h264", "hevc", "av1"};
  return names;
}

std::string layerVideoCodecName(protocol::Codec codec) {
  const CodecInfo* info = infoOf(codec);
  return info != nullptr ? info->name : "none";
}

std::optional<protocol::Codec> layerVideoCodecFromName(const std::string& name) {
  for (const CodecInfo& info : kCodecs)
    if (name == info.name) return info.codec;
  return std::nullopt;
}

bool isVideoCodec(protocol::Codec codec) { return infoOf(codec) != nullptr; }

struct LayerVideoEncoder::Codec {
  ContextPtr context;
  FramePtr frame;
  PacketPtr packet;
  ScalePtr scale;
  std::vector<uint8_t> padded;  // the RGB image at the coded size
  uint32_t width = 0, height = 0;
};

LayerVideoEncoder::LayerVideoEncoder(const LayerVideoOptions& options)
    : options_(options), next_kbps_(options.kbps) {
  quietLibraries();
}
LayerVideoEncoder::~LayerVideoEncoder() = default;

Status LayerVideoEncoder::start(uint32_t width, uint32_t height) {
  const CodecInfo* info = infoOf(options_.codec);
  if (info == nullptr) return Status(StatusCode::kMalformed, "layer video: not a video codec");
  const AVCodec* encoder = avcodec_find_encoder_by_name(info->encoder);
  if (encoder == nullptr)
    return Status(StatusCode::kIoError,
                  std::string("layer video: this FFmpeg has no ") + info->encoder + " encoder");
  auto codec = std::make_unique<Codec>();
  codec->context.reset(avcodec_alloc_context3(encoder));
  AVCodecContext* c = codec->context.get();
  c->width = static_cast<int>(roundUp16(width));
  c->height = static_cast<int>(roundUp16(height));
  c->pix_fmt = options_.full_chroma ? AV_PIX_FMT_YUV444P : AV_PIX_FMT_YUV420P;
  c->time_base = {1, LayerVideoOptions::kFrameRate};
  c->framerate = {LayerVideoOptions::kFrameRate, 1};
  c->gop_size = std::max(options_.key_interval, 1);
  c->max_b_frames = 0;  // a frame out per frame in: B-frames would wait for the next
  c->thread_count = 0;
  // A CRF past the codec's worst is its worst: x264 caps it itself, x265
  // and libaom code such a value at some other quality.
  const int worst = options_.codec == protocol::Codec::kAv1 ? 63 : 51;
  const std::string crf = std::to_string(std::clamp(options_.crf, 0, worst));
  const bool by_rate = options_.kbps > 0;
  if (by_rate) {
    // The maximum rate is the target: a frame over its share drains the
    // buffer, and the coder spends less on the frames after it.
    c->bit_rate = int64_t{options_.kbps} * 1000;
    c->rc_max_rate = c->bit_rate;
    c->rc_buffer_size = static_cast<int>(c->bit_rate * LayerVideoOptions::kBufferFrames /
                                         LayerVideoOptions::kFrameRate);
  }
  switch (options_.codec) {
    case protocol::Codec::kH264:
    case protocol::Codec::kHevc:
      // x264 and x265 take the same names for these.
      av_opt_set(c->priv_data, "preset", "veryfast", 0);
      av_opt_set(c->priv_data, "tune", "zerolatency", 0);
      // x265's ABR without look-ahead missed its target by 3x either way
      // (a noisy moving picture at 600 and 2400 kbps): HEVC keeps its
      // constant quality under the target as a ceiling (capped CRF).
      if (!by_rate || options_.codec == protocol::Codec::kHevc)
        av_opt_set(c->priv_data, "crf", crf.c_str(), 0);
      av_opt_set(c->priv_data, "forced-idr", "1", 0);
      if (options_.codec == protocol::Codec::kHevc) {
        av_opt_set(c->priv_data, "x265-params", "log-level=error", 0);
      } else {
        // Predicted frames at the key frame's quality: every frame is shown
        // once, as it comes, so none should be worse than another.
        av_opt_set(c->priv_data, "x264-params", "ipratio=1.0", 0);
      }
      break;
    default:
      // AV1 through libaom's real-time mode: SVT-AV1 (Debian 12's 1.4)
      // holds frames back in its pipeline whatever its look-ahead.
      av_opt_set(c->priv_data, "usage", "realtime", 0);
      av_opt_set(c->priv_data, "cpu-used", "8", 0);
      av_opt_set(c->priv_data, "lag-in-frames", "0", 0);
      if (!by_rate) {
        av_opt_set(c->priv_data, "crf", crf.c_str(), 0);
        c->bit_rate = 0;  // constant quality
      }
      break;
  }
  if (const int error = avcodec_open2(c, encoder, nullptr); error < 0)
    return Status(StatusCode::kIoError, std::string("layer video: ") + info->encoder + " refused " +
                                            std::to_string(c->width) + "x" +
                                            std::to_string(c->height) + ": " + avError(error));
  codec->frame.reset(av_frame_alloc());
  codec->frame->format = c->pix_fmt;
  codec->frame->width = c->width;
  codec->frame->height = c->height;
  if (av_frame_get_buffer(codec->frame.get(), 0) < 0)
    return Status(StatusCode::kIoError, "layer video: no memory for a frame");
  codec->packet.reset(av_packet_alloc());
  codec->scale.reset(sws_getContext(c->width, c->height, AV_PIX_FMT_RGB24, c->width, c->height,
                                    c->pix_fmt, SWS_POINT, nullptr, nullptr, nullptr));
  codec->padded.assign(size_t{3} * c->width * c->height, 0);
  codec->width = width;
  codec->height = height;
  codec_ = std::move(codec);
  return Status::ok();
}

StatusOr<protocol::Plane> LayerVideoEncoder::encode(const Image8& rgb, bool key_frame,
                                                    std::vector<uint8_t>& storage) {
  if (rgb.channels != 3 || rgb.width == 0 || rgb.height == 0)
    return Status(StatusCode::kMalformed, "layer video: the frame is not an RGB image");
  key_frame = key_frame || (codec_ && since_key_ + 1 >= codec_->context->gop_size);
  if (next_kbps_ != options_.kbps && (key_frame || !codec_)) {
    options_.kbps = next_kbps_;
    codec_.reset();
  }
  if (!codec_ || codec_->width != rgb.width || codec_->height != rgb.height) {
    HOLOFUSE_RETURN_IF_ERROR(start(rgb.width, rgb.height));
    key_frame = true;
  }
  Codec& codec = *codec_;
  AVCodecContext* c = codec.context.get();
  const size_t row = size_t{3} * rgb.width, coded_row = size_t{3} * c->width;
  for (uint32_t y = 0; y < rgb.height; ++y)
    std::memcpy(codec.padded.data() + y * coded_row, rgb.pixels.data() + y * row, row);
  if (av_frame_make_writable(codec.frame.get()) < 0)
    return Status(StatusCode::kIoError, "layer video: the frame stays busy");
  const uint8_t* source[1] = {codec.padded.data()};
  const int source_stride[1] = {static_cast<int>(coded_row)};
  sws_scale(codec.scale.get(), source, source_stride, 0, c->height, codec.frame->data,
            codec.frame->linesize);
  codec.frame->pts = sequence_;
  codec.frame->pict_type = key_frame ? AV_PICTURE_TYPE_I : AV_PICTURE_TYPE_NONE;
  if (const int error = avcodec_send_frame(c, codec.frame.get()); error < 0)
    return Status(StatusCode::kIoError, "layer video: encoding frame " + std::to_string(sequence_) +
                                            ": " + avError(error));
  if (const int error = avcodec_receive_packet(c, codec.packet.get()); error < 0)
    return Status(StatusCode::kIoError, "layer video: frame " + std::to_string(sequence_) +
                                            " gave no packet (" + avError(error) +
                                            "); the encoder must not hold frames back");
  const bool key = (codec.packet->flags & AV_PKT_FLAG_KEY) != 0;
  storage.resize(kHeaderBytes + static_cast<size_t>(codec.packet->size));
  for (int b = 0; b < 4; ++b) storage[b] = static_cast<uint8_t>(sequence_ >> (8 * b));
  storage[4] = key ? kKeyFrameFlag : 0;
  std::memcpy(storage.data() + kHeaderBytes, codec.packet->data,
              static_cast<size_t>(codec.packet->size));
  av_packet_unref(codec.packet.get());
  since_key_ = key ? 0 : since_key_ + 1;
  key_frames_ += key;
  ++sequence_;
  protocol::Plane plane;
  plane.kind = protocol::PlaneKind::kColor;
  plane.codec = options_.codec;
  plane.format = protocol::PixelFormat::kRgb8;
  plane.width = rgb.width;
  plane.height = rgb.height;
  plane.raw_size = static_cast<uint32_t>(rgb.pixels.size());
  plane.data = storage;
  return plane;
}

struct LayerVideoDecoder::Codec {
  protocol::Codec codec{};
  ContextPtr context;
  FramePtr frame;
  PacketPtr packet;
  ScalePtr scale;
  int scale_width = 0, scale_height = 0, scale_format = -1;
};

LayerVideoDecoder::LayerVideoDecoder(uint32_t max_side) : max_side_(max_side) { quietLibraries(); }
LayerVideoDecoder::~LayerVideoDecoder() = default;

StatusOr<LayerVideoPacket> layerVideoPacket(const protocol::Plane& plane) {
  if (infoOf(plane.codec) == nullptr)
    return Status(StatusCode::kMalformed, "layer video: not a video plane");
  if (plane.data.size() <= kHeaderBytes)
    return Status(
        StatusCode::kTruncated,
        "layer video: a plane of " + std::to_string(plane.data.size()) + " bytes holds no frame");
  LayerVideoPacket packet;
  for (int b = 0; b < 4; ++b) packet.sequence |= uint32_t{plane.data[b]} << (8 * b);
  packet.key_frame = (plane.data[4] & kKeyFrameFlag) != 0;
  packet.bitstream = plane.data.subspan(kHeaderBytes);
  return packet;
}

StatusOr<Image8> LayerVideoDecoder::decode(const protocol::Plane& plane) {
  const CodecInfo* info = infoOf(plane.codec);
  if (info == nullptr) return Status(StatusCode::kMalformed, "layer video: not a video plane");
  if (plane.width > max_side_ || plane.height > max_side_)
    return Status(StatusCode::kTooLarge, "layer video: a " + std::to_string(plane.width) + "x" +
                                             std::to_string(plane.height) +
                                             " plane, above the stream's " +
                                             std::to_string(max_side_) + " a side");
  HOLOFUSE_ASSIGN_OR_RETURN(const LayerVideoPacket packet, layerVideoPacket(plane));
  const uint32_t sequence = packet.sequence;
  const bool key = packet.key_frame;
  if (!key && (!last_sequence_ || sequence != *last_sequence_ + 1)) {
    const std::string after =
        last_sequence_ ? "after " + std::to_string(*last_sequence_) : "as the first";
    last_sequence_.reset();  // the stream stays broken until a key frame
    return Status(StatusCode::kUnexpectedMessage, "layer video: frame " + std::to_string(sequence) +
                                                      " " + after +
                                                      " is not a key frame; waiting for one");
  }
  if (!codec_ || codec_->codec != plane.codec) {
    const AVCodec* decoder = avcodec_find_decoder(info->id);
    if (decoder == nullptr)
      return Status(StatusCode::kIoError,
                    std::string("layer video: this FFmpeg has no ") + info->name + " decoder");
    auto codec = std::make_unique<Codec>();
    codec->codec = plane.codec;
    codec->context.reset(avcodec_alloc_context3(decoder));
    codec->context->thread_type = FF_THREAD_SLICE;  // frame threads would hold frames back
    codec->context->flags |= AV_CODEC_FLAG_LOW_DELAY;
    // A hostile stream's header may declare any size: the coded picture is
    // the plane rounded up to 16 texels a side at most (the encoder's).
    const int64_t side = roundUp16(max_side_);
    codec->context->max_pixels = side * side;
    if (const int error = avcodec_open2(codec->context.get(), decoder, nullptr); error < 0)
      return Status(StatusCode::kIoError, std::string("layer video: the ") + info->name +
                                              " decoder did not open: " + avError(error));
    codec->frame.reset(av_frame_alloc());
    codec->packet.reset(av_packet_alloc());
    codec_ = std::move(codec);
  }
  Codec& codec = *codec_;
  AVCodecContext* c = codec.context.get();
  last_sequence_.reset();
  const auto failed = [&](const std::string& what) {
    avcodec_flush_buffers(c);
    return Status(StatusCode::kMalformed, "layer video: frame " + std::to_string(sequence) + " " +
                                              what + "; waiting for a key frame");
  };
  const std::span<const uint8_t> bitstream = packet.bitstream;
  // The decoder reads past the end by up to its padding: a padded copy.
  std::vector<uint8_t> padded(bitstream.size() + AV_INPUT_BUFFER_PADDING_SIZE, 0);
  std::memcpy(padded.data(), bitstream.data(), bitstream.size());
  codec.packet->data = padded.data();
  codec.packet->size = static_cast<int>(bitstream.size());
  const int sent = avcodec_send_packet(c, codec.packet.get());
  codec.packet->data = nullptr;
  codec.packet->size = 0;
  if (sent < 0) return failed("was refused by the decoder: " + avError(sent));
  if (const int error = avcodec_receive_frame(c, codec.frame.get()); error < 0)
    return failed("gave no picture: " + avError(error));
  const AVFrame& frame = *codec.frame;
  if (frame.width < static_cast<int>(plane.width) ||
      frame.height < static_cast<int>(plane.height)) {
    const std::string size = std::to_string(frame.width) + "x" + std::to_string(frame.height);
    av_frame_unref(codec.frame.get());
    return failed("is " + size + ", smaller than its plane's " + std::to_string(plane.width) + "x" +
                  std::to_string(plane.height));
  }
  if (!codec.scale || codec.scale_width != frame.width || codec.scale_height != frame.height ||
      codec.scale_format != frame.format) {
    codec.scale.reset(sws_getContext(
        frame.width, frame.height, static_cast<AVPixelFormat>(frame.format), frame.width,
        frame.height, AV_PIX_FMT_RGB24, SWS_POINT, nullptr, nullptr, nullptr));
    codec.scale_width = frame.width;
    codec.scale_height = frame.height;
    codec.scale_format = frame.format;
  }
  if (!codec.scale) {
    av_frame_unref(codec.frame.get());
    return failed("has a pixel format this build cannot convert");
  }
  Image8 whole(static_cast<uint32_t>(frame.width), static_cast<uint32_t>(frame.height), 3);
  uint8_t* target[1] = {whole.pixels.data()};
  const int target_stride[1] = {frame.width * 3};
  sws_scale(codec.scale.get(), frame.data, frame.linesize, 0, frame.height, target, target_stride);
  av_frame_unref(codec.frame.get());
  last_sequence_ = sequence;
  if (whole.width == plane.width && whole.height == plane.height) return whole;
  return cropImage(whole, {0, 0, plane.width, plane.height});
}

}  // namespace holofuse
