#include "fusion_server/peer_capabilities.h"

namespace holofuse::fusion {

PeerCapabilities capabilitiesOf(uint8_t minor, protocol::Role role, uint64_t hello_capabilities) {
  using Bundle = PeerCapabilities::Bundle;
  using Stats = PeerCapabilities::Stats;
  const bool client = role == protocol::Role::kClient;
  const auto asked = [&](uint64_t bit) { return client && (hello_capabilities & bit) != 0; };
  PeerCapabilities c;
  c.minor = minor;
  c.authenticates = minor >= 4;
  c.bundle = minor >= 3 ? Bundle::kCurrent : minor == 2 ? Bundle::kV1_2 : Bundle::kV1_1;
  c.stats = minor >= 8   ? Stats::kCurrent
            : minor >= 3 ? Stats::kV1_7
            : minor >= 1 ? Stats::kV1_2
                         : Stats::kV1_0;
  c.layers = minor >= 5 && asked(protocol::kCapabilityLayers);
  c.layer_video = c.layers && minor >= 6 && asked(protocol::kCapabilityLayerVideo);
  c.any_mesh_codec = minor >= 7;
  c.clock_probes = minor >= 8;
  c.asks_for_frames = minor >= 9 && asked(protocol::kCapabilityAsksForFrames);
  c.changes_layers = client && minor >= 10;
  c.zstd_planes = minor >= 11;
  c.key_half_steps = minor >= 11;
  c.surface_facing_charts = minor >= 12;
  c.edge_places = minor >= 13;
  return c;
}

}  // namespace holofuse::fusion
