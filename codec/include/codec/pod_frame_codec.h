// A pod's images as the PodFrame it sends (protocol/SPEC.md): colour, mask
// and feather map compressed as planes, cropped to the foreground. The
// synthetic pods and the importer of real captures both make their frames
// here, so a recorded frame is byte for byte what a pod would send.
#pragma once

#include <cstdint>
#include <vector>

#include "config/settings.h"
#include "image/image.h"
#include "protocol/frame.h"
#include "protocol/messages.h"

namespace holofuse {

// One frame's images, borrowed for the call.
struct PodPlanes {
  uint64_t frame_id = 0;
  uint64_t capture_time_ns = 0;
  const Image8* color = nullptr;    // RGB
  const Image8* mask = nullptr;     // 255 foreground
  const Image8* feather = nullptr;  // featherMap of the mask
};

constexpr int kFullFrame = -1;

// How a pod encodes its frames: the pod's settings, which eval and the
// launcher embed. With crop_margin >= 0 only the foreground's bounding
// rectangle grown by that many pixels is sent, with its offset (paper 004,
// Li, Magnor, Seidel 2004: model only what the scene requires); kFullFrame
// sends every pixel. lz4_acceleration and lz4_hc_level as in
// codec/image_codec.h.
struct PodEncoding {
  protocol::Codec color_codec = protocol::Codec::kLz4PlanarDelta;
  int crop_margin = 8;
  int lz4_acceleration = 1;  // LZ4's (1 = default; higher: faster, larger)
  int lz4_hc_level = 0;      // 0: LZ4's fast mode; 1-12: LZ4HC
};

// The pods' flags of PodEncoding (config/settings.h).
const std::vector<Setting<PodEncoding>>& podEncodingFlags();

// Compresses the planes into a PodFrame ready to send (the compressed
// planes are owned by the frame), appending the pod_encode stage to stamps,
// which the frame carries.
protocol::OutgoingFrame encodePodFrame(const PodPlanes& planes,
                                       std::vector<protocol::StageStamp>& stamps,
                                       uint32_t camera_id, const PodEncoding& encoding);

}  // namespace holofuse
