// One fixed, fully populated sample of every message type, shared by the
// round-trip tests, the golden vectors, the fuzz seed corpus and the
// benchmarks.
#pragma once

#include <string>
#include <vector>

#include "protocol/messages.h"

namespace holofuse::protocol::testing {

struct Sample {
  std::string name;  // file name stem of its golden vector
  Bytes frame;       // the encoded frame
};

// The planes' bytes live in static storage, so spans stay valid.
// Every message as the given minor spells it (its fields and header).
std::vector<Sample> allSamples(uint8_t minor = kVersionMinor);
Hello sampleHello();
HelloAck sampleHelloAck();
Calibration sampleCalibration();
PodFrame samplePodFrame();
MeshFrame sampleMeshFrame();
TextureBundle sampleTextureBundle(uint8_t minor = kVersionMinor);
TextureBundle sampleLayeredBundle();  // since 1.5
// Since 1.6: the layers' colour as frames of H.264 streams.
TextureBundle sampleLayerVideoBundle();
TextureBundle sampleZstdCameraPlanesBundle();  // since 1.11
Stats sampleStats();

}  // namespace holofuse::protocol::testing
