#include "codec/pod_frame_codec.h"

#include <array>
#include <memory>

#include "codec/image_codec.h"
#include "protocol/clock.h"
#include "protocol/connection.h"

namespace holofuse {

const std::vector<Setting<PodEncoding>>& podEncodingFlags() {
  static const std::vector<Setting<PodEncoding>> flags = [] {
    std::vector<Setting<PodEncoding>> all = imageEncodingSettings<PodEncoding>(
        "--codec", "colour codec",
        [](PodEncoding& e) -> protocol::Codec& { return e.color_codec; });
    all.push_back(numberSetting<PodEncoding>(
        "--crop-margin",
        "send only the foreground's rectangle grown by this many pixels (-1: whole images)", -1,
        4096, [](PodEncoding& e) -> int& { return e.crop_margin; }));
    return all;
  }();
  return flags;
}

using protocol::monotonicNs;
using protocol::Stage;

protocol::OutgoingFrame encodePodFrame(const PodPlanes& planes,
                                       std::vector<protocol::StageStamp>& stamps,
                                       uint32_t camera_id, const PodEncoding& encoding) {
  const auto [color_codec, crop_margin, lz4_acceleration, lz4_hc_level] = encoding;
  const uint64_t t0 = monotonicNs();
  // The compressed planes live as long as the frame that borrows them.
  auto storage = std::make_shared<std::array<std::vector<uint8_t>, 3>>();
  auto& [color_bytes, mask_bytes, feather_bytes] = *storage;
  protocol::PodFrame frame;
  frame.frame_id = planes.frame_id;
  frame.camera_id = camera_id;
  frame.capture_time_ns = planes.capture_time_ns;
  const Image8* color = planes.color;
  const Image8* mask = planes.mask;
  const Image8* feather = planes.feather;
  Image8 cropped[3];
  if (crop_margin >= 0) {
    // No foreground: one background pixel says so.
    PixelRect rect = foregroundRect(*planes.mask, static_cast<uint32_t>(crop_margin));
    if (rect.empty()) rect = {0, 0, 1, 1};
    cropped[0] = cropImage(*planes.color, rect);
    cropped[1] = cropImage(*planes.mask, rect);
    cropped[2] = cropImage(*planes.feather, rect);
    color = &cropped[0];
    mask = &cropped[1];
    feather = &cropped[2];
    frame.offset_x = rect.x;
    frame.offset_y = rect.y;
  }
  frame.planes.push_back(encodePlane(*color, protocol::PlaneKind::kColor, color_codec, color_bytes,
                                     lz4_acceleration, lz4_hc_level));
  frame.planes.push_back(encodePlane(*mask, protocol::PlaneKind::kMask, protocol::Codec::kLz4,
                                     mask_bytes, lz4_acceleration, lz4_hc_level));
  frame.planes.push_back(encodePlane(*feather, protocol::PlaneKind::kFeather, protocol::Codec::kLz4,
                                     feather_bytes, lz4_acceleration, lz4_hc_level));
  stamps.push_back({static_cast<uint16_t>(Stage::kPodEncode), static_cast<uint16_t>(camera_id), t0,
                    monotonicNs()});
  frame.stamps = stamps;
  return protocol::encodeOutgoing(frame, protocol::nextSequence(), storage);
}

}  // namespace holofuse
