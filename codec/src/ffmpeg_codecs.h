// What the layer video's encoder, decoder and file writer share of FFmpeg:
// the codecs by protocol id, and FFmpeg's errors as text. Internal to
// holofuse_codec.
#pragma once
#include <string>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavutil/error.h>
}

#include "protocol/messages.h"

namespace holofuse::ffmpeg {

struct CodecInfo {
  protocol::Codec codec;
  const char* name;
  const char* encoder;
  AVCodecID id;
};

inline constexpr CodecInfo kCodecs[] = {
    {protocol::Codec::kH264, "h264", "libx264", AV_CODEC_ID_H264},
    {protocol::Codec::kHevc, "hevc", "libx265", AV_CODEC_ID_HEVC},
    {protocol::Codec::kAv1, "av1", "libaom-av1", AV_CODEC_ID_AV1},
};

// kH264, kHevc or kAv1; nullptr for any other codec.
inline const CodecInfo* infoOf(protocol::Codec codec) {
  for (const CodecInfo& info : kCodecs)
    if (info.codec == codec) return &info;
  return nullptr;
}

inline std::string avError(int code) {
  char text[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(code, text, sizeof text);
  return text;
}

}  // namespace holofuse::ffmpeg
