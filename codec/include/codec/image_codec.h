// Image planes to and from their wire form (protocol Plane): raw, LZ4, or
// LZ4 over planar channels with a horizontal byte delta (PLATFORM.md: the
// pre-filter raises LZ4's ratio on camera images); Zstandard for texture
// layers' camera planes.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "config/settings.h"
#include "image/image.h"
#include "protocol/messages.h"

namespace holofuse {

// LZ4HC's levels: 0 is LZ4's fast mode (at its acceleration); 1 to 12 the
// high-compression encoder, slower and smaller. Both write the same LZ4
// block format, so decoders and the wire's codec ids do not change.
inline constexpr int kMaxLz4HcLevel = 12;

// Zstandard's level for a plane of codec kZstd. On eval's clean scene a
// layer's camera plane (528x528, runs of one camera index): 14.1 KB in
// 2 ms, where LZ4 HC 6 took 23.6 KB in 4 ms; level 15 saves 12% more
// for 22 ms.
inline constexpr int kPlaneZstdLevel = 9;

// Encodes image as a plane of the given kind. The plane's data points into
// storage, which must outlive it. acceleration is LZ4's fast mode's (1 =
// default), used when hc_level is 0.
protocol::Plane encodePlane(const Image8& image, protocol::PlaneKind kind, protocol::Codec codec,
                            std::vector<uint8_t>& storage, int acceleration = 1, int hc_level = 0);

// The colour codecs' names on command lines and in reports: raw, lz4,
// lz4-delta (planar with the horizontal delta).
const std::vector<std::string>& imageCodecNames();
std::string imageCodecName(protocol::Codec codec);
std::optional<protocol::Codec> imageCodecFromName(const std::string& name);

// The image encoding settings of whoever encodes images (the pods, the
// server): the colour codec under codec_flag, codec(settings) its field,
// and the LZ4 settings, S's lz4_acceleration and lz4_hc_level.
template <typename S, typename CodecField>
std::vector<Setting<S>> imageEncodingSettings(const std::string& codec_flag,
                                              const std::string& codec_help, CodecField codec) {
  return {choiceSetting<S>(
              codec_flag, codec_help, imageCodecNames(),
              [=](S& s, const std::string& name) { codec(s) = *imageCodecFromName(name); },
              [=](const S& s) { return imageCodecName(codec(const_cast<S&>(s))); }),
          numberSetting<S>("--lz4-acceleration",
                           "LZ4 acceleration (1 = default; higher: faster, larger)", 1, 65537,
                           [](S& s) -> int& { return s.lz4_acceleration; }),
          numberSetting<S>(
              "--lz4-hc-level",
              "LZ4HC level: 0 = LZ4's fast mode (at --lz4-acceleration), 1-12 slower and smaller",
              0, kMaxLz4HcLevel, [](S& s) -> int& { return s.lz4_hc_level; })};
}

// Decodes a plane from untrusted bytes. Safe on any input: the declared
// size is capped and checked, LZ4 runs in its safe mode, and any mismatch is
// an error naming the plane.
StatusOr<Image8> decodePlane(const protocol::Plane& plane);

}  // namespace holofuse
