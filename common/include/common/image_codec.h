// Image planes to and from their wire form (protocol Plane): raw, LZ4, or
// LZ4 over planar channels with a horizontal byte delta (PLATFORM.md: the
// pre-filter raises LZ4's ratio on camera images).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "base/status.h"
#include "common/image.h"
#include "protocol/messages.h"

namespace holofuse {

// LZ4HC's levels: 0 is LZ4's fast mode (at its acceleration); 1 to 12 the
// high-compression encoder, slower and smaller. Both write the same LZ4
// block format, so decoders and the wire's codec ids do not change.
inline constexpr int kMaxLz4HcLevel = 12;

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

// Decodes a plane from untrusted bytes. Safe on any input: the declared
// size is capped and checked, LZ4 runs in its safe mode, and any mismatch is
// an error naming the plane.
StatusOr<Image8> decodePlane(const protocol::Plane& plane);

}  // namespace holofuse
