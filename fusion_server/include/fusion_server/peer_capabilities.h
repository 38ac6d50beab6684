// What one peer may be sent and may send, from the protocol minor agreed
// in its handshake and the capability bits of its Hello. Computed once per
// peer (capabilitiesOf): the only place the server compares protocol
// minors; everything else asks the capability by name.
#pragma once

#include <cstdint>

#include "protocol/messages.h"

namespace holofuse::fusion {

struct PeerCapabilities {
  uint8_t minor = 0;           // for the log and for encoding under the agreed version
  bool authenticates = false;  // 1.4: answers the Auth challenge
  // The spelling of a frame's TextureBundle and Stats it decodes: the
  // bundle of 1.1 (for 1.0 and 1.1), of 1.2, or the current one (1.3 on);
  // the Stats of 1.0, of 1.2 (for 1.1 and 1.2), of 1.7 (for 1.3 to 1.7),
  // or the current one (1.8 on: with the pods' clock estimates).
  enum class Bundle { kV1_1, kV1_2, kCurrent } bundle = Bundle::kV1_1;
  enum class Stats { kV1_0, kV1_2, kV1_7, kCurrent } stats = Stats::kV1_0;
  bool layers = false;           // 1.5: a client that asked for texture layers
  bool layer_video = false;      // 1.6: ... and for their colour as video
  bool any_mesh_codec = false;   // 1.7: decodes every MeshCodec, not only Draco
  bool clock_probes = false;     // 1.8: answers and sends ClockProbes
  bool asks_for_frames = false;  // 1.9: a client that paces with FrameRequest
  bool changes_layers = false;   // 1.10: a client whose FrameRequests say which layers it takes
  bool zstd_planes = false;      // 1.11: decodes layers' camera planes in Zstandard
  bool key_half_steps = false;   // 1.11: decodes Draco's vertex keys in half steps
  bool surface_facing_charts = false;  // 1.12: lays charts out by the normal around a triangle
  bool edge_places = false;  // 1.13: decodes Draco positions as places along the keys' edges
};

// hello_capabilities: the Hello's kCapability* bits, which count only for a
// client of the minor that defines them.
PeerCapabilities capabilitiesOf(uint8_t minor, protocol::Role role = protocol::Role::kPod,
                                uint64_t hello_capabilities = 0);

}  // namespace holofuse::fusion
